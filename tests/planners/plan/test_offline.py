"""Configurations handed to a planner: joint-limit checks and offline robots (planners/plan/offline.py)."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.errors import TargetError, UnknownRobotError
from rfp_twin.models.layout import Layout
from rfp_twin.models.robot import load_spec
from rfp_twin.planners.plan.offline import apply_offline

SPEC = load_spec("sdss-v")


def geom7() -> ArrayGeometry:
    """Seven robots, ids 10..16 (not the indices), and one fiducial, id 99."""
    xy = np.vstack([Layout.hex_grid_positions(7, SPEC.pitch_mm).xy, [[3 * SPEC.pitch_mm, 0.0]]])
    ids = np.array([10, 11, 12, 13, 14, 15, 16, 99])
    return ArrayGeometry(SPEC, Layout(ids, xy, ["robot"] * 7 + ["fiducial"], "hex-7+1"), 2.5)


def test_offline_rows_are_written_in_place_and_masked():
    geom = geom7()
    config = np.zeros((geom.n_robots, 2))
    movable = apply_offline(geom, {12: (10.0, 170.0), 16: [350.0, 0.0]}, config)
    k12, k16 = geom.layout.robot_index(12), geom.layout.robot_index(16)
    assert movable.dtype == bool and movable.shape == (geom.n_robots,)
    assert np.flatnonzero(~movable).tolist() == sorted([k12, k16])
    np.testing.assert_array_equal(config[[k12, k16]], [[10.0, 170.0], [350.0, 0.0]])
    assert np.all(config[movable] == 0.0)
    assert apply_offline(geom, None).all() and apply_offline(geom, {}, config).all()
    assert not apply_offline(geom, {12: (10.0, 170.0)})[k12]      # mask only, nothing written


@pytest.mark.parametrize("offline, error, message", [
    ({7: (0.0, 180.0)}, UnknownRobotError, r"offline robot 7: .*robot id 7 is not in the layout"),
    ({99: (0.0, 180.0)}, UnknownRobotError, r"offline robot 99: .*is a fiducial"),
    ({12: (400.0, 180.0)}, TargetError, r"offline: robot 12: field 'alpha' = 400.0; allowed: \[0"),
    ({12: (0.0, float("nan"))}, TargetError, r"offline: robot 12: field 'beta' = nan"),
    ({12: (0.0, 1.0, 2.0)}, TargetError, r"offline robot 12: angles \(0.0, 1.0, 2.0\); allowed"),
])
def test_bad_offline_robots_are_named(offline, error, message):
    geom = geom7()
    config = np.zeros((geom.n_robots, 2))
    with pytest.raises(error, match=message):
        apply_offline(geom, {11: (10.0, 170.0), **offline}, config)
    assert np.all(config == 0.0)                                  # nothing half-written


def test_config_of_the_wrong_shape_is_refused():
    geom = geom7()
    with pytest.raises(TargetError, match=r"offline: configuration shape \(3, 2\); allowed: \(7, 2\)"):
        apply_offline(geom, {12: (10.0, 170.0)}, np.zeros((3, 2)))


