"""Cooperative field (Macktoobian 2019 Eq. 5) on top of the APF: planners/fields/capf.py."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.errors import SpecError
from rfp_twin.models.kinematics import forward
from rfp_twin.models.layout import Layout
from rfp_twin.models.robot import load_spec
from rfp_twin.planners.fields import (ApfSettings, CapfSettings, plan_apf, plan_apf_reconfiguration,
                          random_tip_configs)
from rfp_twin.validation.checker2d import check_trajectory

SDSS = load_spec("sdss-v")
DESI = load_spec("desi")

# Seven SDSS-V robots (hex-7, pitch 22.4 mm, buffer 2.5 mm, segment model). Found by a
# seeded search over 200 random problems (rfp_twin.planners.plan.targets.random_targets, seed 99),
# rounded to 1e-3 deg. With the APF the centre robot (index 3) stalls 7.5 mm from its
# target, blocked by robot 1, which itself stops 1.9 mm short of its own. With the
# cooperative term robot 1 is pushed along robot 3's remaining error, steps past its
# target, lets robot 3 through and comes back.
STALL_START = np.array([
    [289.986, 89.309], [301.792, 56.581], [354.443, 138.285], [311.079, 16.199],
    [196.359, 113.624], [247.689, 63.776], [343.483, 129.431]])
STALL_TARGETS = np.array([
    [86.981, 110.540], [60.148, 49.922], [348.853, 77.992], [43.517, 75.816],
    [354.453, 46.105], [89.066, 86.999], [159.425, 159.737]])


def sdss7(buffer_mm: float = 2.5) -> ArrayGeometry:
    return ArrayGeometry(SDSS, Layout.hex_grid_positions(7, SDSS.pitch_mm), buffer_mm)


@pytest.mark.parametrize("lam3, allowed", [(0.0, "(0, lambda1 = 1.0)"),
                                           (1.0, "[0, lambda1 = 1.0)"),
                                           (-0.1, "[0, lambda1 = 1.0)")])
def test_lambda3_validated(lam3, allowed):
    with pytest.raises(SpecError) as exc:
        CapfSettings(lambda3=lam3)
    assert "field 'lambda3'" in str(exc.value) and allowed in str(exc.value)


def test_defaults():
    s = CapfSettings()
    assert (s.lambda1, s.lambda2, s.lambda3) == (1.0, 0.05, 0.03)


def test_capf_converges_where_apf_stalls():
    geom = sdss7()
    apf = plan_apf(geom, STALL_START, STALL_TARGETS, ApfSettings(model="segment"))
    assert apf.stop_reason == "stalled"
    assert apf.converged.tolist() == [True, False, True, False, True, True, True]
    assert apf.tip_error_mm[3] > 5.0
    capf = plan_apf(geom, STALL_START, STALL_TARGETS, CapfSettings(model="segment"),
                    algorithm="capf")
    assert capf.algorithm == "capf" and capf.stop_reason == "converged" and capf.complete
    assert check_trajectory(capf.trajectory, SDSS, geom.layout, 2.5).ok
    # robot 1 made way: it went farther from its target than the APF's stall point
    t = np.arange(0.0, capf.motion_time_s, 0.05)
    goal = forward(geom.base_xy, STALL_TARGETS, SDSS.alpha_length_mm, SDSS.beta_length_mm)[0][1]
    err1 = [np.hypot(*(forward(geom.base_xy, a, SDSS.alpha_length_mm, SDSS.beta_length_mm)[0][1]
                       - goal)) for a in capf.trajectory.sample(t)]
    assert max(err1[len(t) // 2:]) > apf.tip_error_mm[1] + 1.0


def test_cooperative_term_is_a_vector_field():
    """A robot sitting on its target, far from any repulsion, moves along its
    neighbour's remaining error (Eq. 5); with the APF it does not move at all."""
    p = DESI.pitch_mm
    lay = Layout(np.arange(2), np.array([[0.0, 0.0], [p, 0.0]]), ["robot"] * 2, "pair")
    geom = ArrayGeometry(DESI, lay, DESI.buffer_mm)
    start = np.array([[180.0, 90.0], [90.0, 90.0]])     # tips far apart (> D)
    targets = np.array([[180.0, 90.0], [270.0, 90.0]])  # robot 0 already there
    settings = dict(max_time_s=0.05, stall_window_s=10.0)
    apf = plan_apf(geom, start, targets, ApfSettings(**settings))
    capf = plan_apf(geom, start, targets, CapfSettings(**settings), algorithm="capf")
    la, lb = DESI.alpha_length_mm, DESI.beta_length_mm
    tip = lambda a: forward(geom.base_xy, np.ascontiguousarray(a), la, lb)[0]  # noqa: E731
    assert np.allclose(tip(apf.final)[0], tip(start)[0])
    moved = tip(capf.final)[0] - tip(start)[0]
    want = tip(targets)[1] - tip(start)[1]               # q_1T - q_1
    assert np.hypot(*moved) > 0.01
    cos = moved @ want / (np.hypot(*moved) * np.hypot(*want))
    assert cos > 0.7


def test_desi_random_runs_and_plan():
    geom = ArrayGeometry(DESI, Layout.hex_grid_positions(37, DESI.pitch_mm), DESI.buffer_mm)
    rng = np.random.default_rng(1)
    start = random_tip_configs(geom, rng, 2.1)
    targets = random_tip_configs(geom, rng, 3.0)
    r = plan_apf(geom, start, targets, CapfSettings(), algorithm="capf")
    assert r.complete and r.min_tip_distance_mm > 2.0 and np.all(r.tip_error_mm < 0.1)
    plan, res = plan_apf_reconfiguration(geom, targets, CapfSettings(), algorithm="capf")
    assert res.algorithm == "capf" and plan.metrics["algorithm"] == "capf"
    assert plan.metrics["lambda3"] == 0.03 and plan.complete
