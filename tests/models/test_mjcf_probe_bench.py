"""The MIRADAS bench in MuJoCo (MjSpec): closed loops that agree with Eqs. 1-4."""
from __future__ import annotations

import mujoco
import numpy as np
import pytest

from rfp_twin.models.kinds import load_kind
from rfp_twin.models.mjcf.probe_bench import arm_name, build_probe_bench, joint_positions
from tests.models.conftest import step_clean


@pytest.fixture(scope="module")
def bench():
    return build_probe_bench(load_kind("miradas-probe"))


def _tips(bench, data):
    return np.array([data.site(arm_name(k, "tip")).xpos[:2] for k in range(bench.kind.n_arms)])


def test_bench_compiles_with_every_loop_closed(bench):
    m = bench.model
    assert m.neq == 12 and m.nu == 24 and m.njnt == 48
    d = mujoco.MjData(m)
    bench.set_pose(d, bench.kind.park())
    assert d.ncon == 0
    np.testing.assert_allclose(_tips(bench, d), bench.kind.tips_world(bench.kind.park()), atol=1e-9)
    step_clean(m, d, 200)
    np.testing.assert_allclose(bench.motor_angles(d), bench.kind.park(), atol=1e-6)


def test_any_feasible_pose_matches_the_kinematics(bench):
    kind = bench.kind
    rng = np.random.default_rng(4)
    q = np.column_stack([rng.uniform(0, 180, 400), rng.uniform(0, 360, 400)])
    q = q[~kind.forbidden(q)][:12]
    d = mujoco.MjData(bench.model)
    bench.set_pose(d, q)
    np.testing.assert_allclose(_tips(bench, d), kind.tips_world(q), atol=1e-9)
    assert np.abs(d.efc_pos[:d.ne]).max() < 1e-9                  # the loops are closed
    np.testing.assert_allclose(joint_positions(kind, q)[:, 3], kind.d34(q))   # J4 slide = d34

