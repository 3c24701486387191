"""Shared fixtures of the models tests: the SDSS-V 3D robot and a 7-robot MuJoCo grid.

Heavy imports (trimesh, mujoco) happen inside the fixtures, so layout or kinematics tests
do not pay for them.
"""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.layout import Layout
from rfp_twin.models.robot import load_spec


@pytest.fixture(scope="session")
def sdss():
    """The procedural SDSS-V robot (RobotGeometry of the ``sdss-v`` preset)."""
    from rfp_twin.models.geometry import load_geometry
    return load_geometry("sdss-v")


@pytest.fixture(scope="session")
def sdss7():
    """The compiled MuJoCo model of 7 SDSS-V robots (one hex ring)."""
    from rfp_twin.models.mjcf import build_model
    spec = load_spec("sdss-v")
    return build_model(spec, Layout.hex_grid(1, spec.pitch_mm))


def step_clean(m, d, n: int = 100) -> None:
    """Step a MuJoCo model n times; fail on any MuJoCo warning (message or counter)."""
    import mujoco

    from rfp_twin.models.mjcf import collect_mujoco_warnings
    with collect_mujoco_warnings() as messages:
        for _ in range(n):
            mujoco.mj_step(m, d)
    assert messages == []
    assert [int(w.number) for w in d.warning] == [0] * int(mujoco.mjtWarning.mjNWARNING)


def with_fiducials(n_rings: int, pitch: float, fid_ids) -> Layout:
    """A hex grid whose positions ``fid_ids`` are fiducials."""
    grid = Layout.hex_grid(n_rings, pitch)
    kinds = np.where(np.isin(grid.ids, fid_ids), "fiducial", "robot")
    return Layout(grid.ids, grid.xy, kinds, name="hex-fid")
