"""Random target assignment (Sayres 2021 Sect. 4.1) and target checks."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.errors import TargetError
from rfp_twin.models.kinematics import forward
from rfp_twin.models.layout import Layout
from rfp_twin.models.robot import load_spec
from rfp_twin.planners.plan.targets import check_angles, check_targets, random_targets
from tests.planners.conftest import make_geom


@pytest.mark.parametrize("buffer_mm", [1.5, 2.5, 3.5])
def test_random_targets_are_clear_right_armed_and_seeded(buffer_mm):
    geom = make_geom(91, buffer_mm)
    a = random_targets(geom, np.random.default_rng(11), margin_mm=0.2)
    b = random_targets(geom, np.random.default_rng(11), margin_mm=0.2)
    np.testing.assert_array_equal(a, b)
    assert np.all((a[:, 1] >= 0) & (a[:, 1] <= 180))
    assert geom.pair_clearance(a).min() > 0.2
    check_targets(geom, a)
    fiber, _ = forward(geom.base_xy, a, 7.4, 15.0)
    r = np.hypot(*(fiber - geom.base_xy).T)
    assert r.min() >= 7.6 - 1e-6 and r.max() <= 22.4 + 1e-6


def test_random_targets_avoid_fiducials():
    geom = ArrayGeometry(load_spec("sdss-v"), Layout.sdss_v_fps(), 2.5)
    t = random_targets(geom, np.random.default_rng(1))
    assert geom.fiducial_clearance(t).min() > 0.0


def test_redrawing_one_robot_keeps_the_others():
    geom = make_geom(37, 2.0)
    a = random_targets(geom, np.random.default_rng(0))
    keep = np.ones(geom.n_robots, dtype=bool)
    keep[5] = False
    b = random_targets(geom, np.random.default_rng(1), fixed=keep, initial=a, robots=np.array([5]))
    np.testing.assert_array_equal(b[keep], a[keep])
    assert not np.array_equal(b[5], a[5])
    check_targets(geom, b)


def test_impossible_buffer_is_reported():
    geom = make_geom(37, 10.0)
    with pytest.raises(TargetError, match="no clear random target"):
        random_targets(geom, np.random.default_rng(0), attempts=2)


def test_target_checks_name_robot_field_and_range():
    geom = make_geom(7, 2.0)
    good = np.tile([10.0, 170.0], (7, 1))
    check_targets(geom, good)
    bad = good.copy()
    bad[2, 0] = 400.0
    with pytest.raises(TargetError, match=r"robot 2: field 'alpha' = 400.0; allowed: \[0.0, 360.0\]"):
        check_targets(geom, bad)
    with pytest.raises(TargetError, match="shape"):
        check_targets(geom, good[:3])


def test_angle_checks_name_the_array_when_asked():
    geom = make_geom(7, 2.0)
    good = np.tile([10.0, 170.0], (7, 1))
    out = check_angles(geom, good.tolist(), "start")
    assert out.dtype == np.float64 and out.shape == (7, 2)
    bad = good.copy()
    bad[4, 1] = np.nan
    lo, hi = geom.spec.beta_limits_deg
    with pytest.raises(TargetError, match=rf"^start: robot 4: field 'beta' = nan; allowed: \[{lo}, {hi}\] deg"):
        check_angles(geom, bad, "start")
    with pytest.raises(TargetError, match=r"^robot 4: field 'beta'"):
        check_angles(geom, bad)
    with pytest.raises(TargetError, match=r"^start: shape \(2, 2\)"):
        check_angles(geom, good[:2], "start")


def test_random_targets_on_a_calibrated_instrument_use_each_robots_own_reach():
    from rfp_twin.models.kinematics import forward_fiber
    from rfp_twin.models.layout import layout_by_name
    from rfp_twin.models.layout.columns import robot_fibers

    lay = layout_by_name("sdss-v-apo", 22.4)
    geom = ArrayGeometry(load_spec("sdss-v-production"), lay, 2.0)
    t = random_targets(geom, np.random.default_rng(3))
    # clear of each other and of fiducials and guide cameras, with per-robot bodies
    assert geom.pair_clearance(t).min() > 0.0 and geom.fiducial_clearance(t).min() > 0.0
    # the metrology fiber lands in each robot's own annulus, filling it to its own rim
    met = robot_fibers(lay, {})[:, 0]
    r = np.hypot(*(forward_fiber(geom.base_xy, t, geom.alpha_len, met) - geom.base_xy).T)
    outer = geom.alpha_len + met[:, 0]
    assert np.all(r <= outer + 1e-9) and np.all(r >= met[:, 0] - geom.alpha_len - 1e-9)
    # the draws fill each robot's own annulus: the longest arm reaches past the nominal rim,
    # the shortest never gets there
    from rfp_twin.planners.plan.targets import patrol_sampler
    ends = np.array([np.argmax(outer), np.argmin(outer)])
    draws = patrol_sampler(geom)(np.random.default_rng(0), ends, 20000)
    for k, d in zip(ends, draws):
        rr = np.hypot(*(forward_fiber(np.zeros((len(d), 2)), d, np.full(len(d), geom.alpha_len[k]),
                                      np.broadcast_to(met[k], (len(d), 2)))).T)
        assert outer[k] - 0.02 < rr.max() <= outer[k] + 1e-9
    assert outer.max() - 0.02 > 7.4 + 14.314 > outer.min()
