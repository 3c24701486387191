"""Navigation-function planner (Makarem 2014, sign-corrected): planners/apf.py."""
from __future__ import annotations

import math

import numpy as np
import pytest

from models.array import ArrayGeometry
from models.errors import SpecError, TargetError, UnknownRobotError
from models.kinematics import forward, inverse
from models.layout import Layout
from models.robot import load_spec
from planners.apf import (ApfSettings, apf_target_margin_mm, plan_apf,
                          plan_apf_reconfiguration, random_tip_configs, rep_dpsi_ds, rep_potential)
from planners.plan import DEADLOCKED, OFFLINE, REACHED
from planners.targets import random_targets
from models.trajectory import Trajectory
from validation.checker2d import check_trajectory

DESI = load_spec("desi")
SDSS = load_spec("sdss-v")


def desi_geom(n_positions: int = 61) -> ArrayGeometry:
    return ArrayGeometry(DESI, Layout.hex_grid_positions(n_positions, DESI.pitch_mm), DESI.buffer_mm)


def custom_geom(spec, xy, kinds=None, buffer_mm=None) -> ArrayGeometry:
    n = len(xy)
    lay = Layout(np.arange(n), np.asarray(xy, dtype=float), kinds or ["robot"] * n, "test")
    return ArrayGeometry(spec, lay, spec.buffer_mm if buffer_mm is None else buffer_mm)


def angles_for(geom, i, rel_xy, right=True):
    """(alpha, beta) deg putting robot i's tip at base + rel_xy (mm)."""
    b = geom.base_xy[[i]]
    return inverse(b, b + np.asarray([rel_xy], dtype=float), geom.spec.alpha_length_mm,
                   geom.spec.beta_length_mm, right_arm=right)[0]


def tips(geom, angles):
    return forward(geom.base_xy, np.ascontiguousarray(angles, dtype=float),
                   geom.spec.alpha_length_mm, geom.spec.beta_length_mm)[0]


# --------------------------------------------------------------------------------------
# settings
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("kwargs, field, allowed", [
    ({"model": "capsule"}, "model", "tip | segment"),
    ({"lambda1": 0.0}, "lambda1", "(0, 1000]"),
    ({"lambda2": -1.0}, "lambda2", "(0, 1000]"),
    ({"lambda3": 1.0}, "lambda3", "[0, lambda1 = 1.0)"),
    ({"gain": float("nan")}, "gain", "(0, 1000] 1/s"),
    ({"d_mm": 3.0, "D_mm": 2.0}, "D_mm", "(3.0, 100] mm (D > d)"),
    ({"dt_s": 0.5}, "dt_s", "(0, 0.1] s"),
    ({"tol_mm": 0.0}, "tol_mm", "(0, 10] mm"),
    ({"speed_deg_s": (30.0,)}, "speed_deg_s", "(alpha, beta) deg/s"),
    ({"singular_band_deg": 60.0}, "singular_band_deg", "[0, 45] deg"),
    ({"max_points": 1}, "max_points", "an integer >= 2"),
])
def test_settings_errors_name_field_and_range(kwargs, field, allowed):
    with pytest.raises(SpecError) as exc:
        ApfSettings(**kwargs)
    msg = str(exc.value)
    assert f"field '{field}'" in msg and allowed in msg


def test_resolved_distances_tip_and_segment():
    geom = desi_geom(7)
    d, D, d_f, D_f, margin = ApfSettings().distances(geom)
    assert (d, D, margin) == (2.0, 4.0, 0.0)
    assert d_f == pytest.approx(1.0 + DESI.fiducial_buffer_mm) and D_f == pytest.approx(d_f + 2.0)
    sg = ArrayGeometry(SDSS, Layout.hex_grid_positions(7, SDSS.pitch_mm), 2.5)
    d, D, _, _, margin = ApfSettings(model="segment").distances(sg)
    # margin covers one Euler step of two arms at 30 deg/s (~0.2 mm) plus simplification
    assert 0.15 < margin < 0.3 and d == pytest.approx(5.0 + margin) and D == pytest.approx(d + 2.0)
    assert apf_target_margin_mm(sg, ApfSettings(model="segment")) == pytest.approx(margin)


# --------------------------------------------------------------------------------------
# the sign fix
# --------------------------------------------------------------------------------------
def test_repulsion_sign_fixed():
    d, D = 2.0, 4.0
    s = np.linspace(2.05, 3.95, 50)
    rep = np.array([rep_potential(x, d, D) for x in s])
    drep = np.array([rep_dpsi_ds(x, d, D) for x in s])
    assert np.all(np.diff(rep) < 0) and np.all(drep < 0)      # falls as tips separate
    assert rep_potential(D, d, D) == 0.0 and rep_potential(5.0, d, D) == 0.0
    assert rep_potential(d, d, D) == math.inf
    # the printed Makarem 2014 Eq. 2 term rises as tips separate: descending it pulls
    # them together (towards -inf at s = d)
    printed = np.minimum(0.0, (s ** 2 - D ** 2) / (s ** 2 - d ** 2))
    assert np.all(np.diff(printed) > 0) and printed[0] < -10
    # analytic derivative matches a finite difference
    h = 1e-6
    fd = (rep_potential(3.0 + h, d, D) - rep_potential(3.0 - h, d, D)) / (2 * h)
    assert rep_dpsi_ds(3.0, d, D) == pytest.approx(fd, rel=1e-6)


def test_two_approaching_tips_are_pushed_apart():
    """Targets 1 mm apart pull two tips together; the field alone (guard off) keeps
    them beyond d, and each ends displaced away from the other."""
    geom = custom_geom(DESI, [[0.0, 0.0], [DESI.pitch_mm, 0.0]])
    mid = DESI.pitch_mm / 2
    start = np.array([angles_for(geom, 0, [mid - 3.0, 2.0]), angles_for(geom, 1, [-(mid - 3.0), 2.0])])
    targets = np.array([angles_for(geom, 0, [mid - 0.5, 0.0]), angles_for(geom, 1, [-(mid - 0.5), 0.0])])
    r = plan_apf(geom, start, targets, ApfSettings(guard=False, max_time_s=5.0))
    assert r.n_guard == 0
    assert r.min_tip_distance_mm > r.d_mm
    end, goal = tips(geom, r.final), tips(geom, targets)
    assert np.hypot(*(end[0] - end[1])) > 2.0 > np.hypot(*(goal[0] - goal[1]))
    assert end[0, 0] < goal[0, 0] and end[1, 0] > goal[1, 0]     # pushed apart along x
    assert not r.converged.any()


# --------------------------------------------------------------------------------------
# Makarem 2014 reproduction (DESI preset, tip model)
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("gain, t_lo, t_hi", [(1.0, 2.0, 4.0), (10.0, 1.8, 3.2)])
def test_desi_random_runs(gain, t_lo, t_hi):
    """100 um convergence, no tip closer than d, motion time about 2.5 s (paper); the
    literal weights in mm/s are somewhat slower (see ApfSettings.gain)."""
    geom = desi_geom(61)
    times = []
    for seed in range(4):
        rng = np.random.default_rng(seed)
        start = random_tip_configs(geom, rng, 2.1)
        targets = random_tip_configs(geom, rng, 3.0)
        r = plan_apf(geom, start, targets, ApfSettings(gain=gain))
        assert r.stop_reason == "converged" and r.complete
        assert np.all(r.tip_error_mm < 0.1)
        assert r.min_tip_distance_mm > 2.0
        # the sampled trajectory ends where the kernel stopped, within the recording tolerance
        assert np.allclose(r.trajectory.end(), r.final, atol=0.02)
        assert r.trajectory.point_counts().max() <= 1024
        times.append(r.motion_time_s)
    assert t_lo < np.mean(times) < t_hi


def test_make_way_three_robots():
    """Makarem 2014 Fig. 7: robot 1 sits on its target in robot 2's way; it steps away,
    lets robot 2 pass, and comes back. Robot 3's target is where robot 2 starts."""
    p = DESI.pitch_mm
    geom = custom_geom(DESI, [[0.0, 0.0], [p, 0.0], [p / 2, p * math.sqrt(3) / 2]])
    a2 = math.radians(32.0)
    start = np.array([angles_for(geom, 0, [5.0, 0.0]),
                      angles_for(geom, 1, [-5.8 * math.cos(a2), 5.8 * math.sin(a2)]),
                      angles_for(geom, 2, [0.0, -3.0])])
    targets = np.array([start[0],
                        angles_for(geom, 1, [-5.8 * math.cos(a2), -5.8 * math.sin(a2)]),
                        angles_for(geom, 2, [0.0, -5.0])])
    r = plan_apf(geom, start, targets)
    assert r.complete and r.min_tip_distance_mm > 2.0
    times = np.arange(0.0, r.motion_time_s + 1e-9, 0.01)
    goal = tips(geom, targets)
    err1 = np.array([np.hypot(*(tips(geom, a)[0] - goal[0])) for a in r.trajectory.sample(times)])
    k = int(np.argmax(err1))
    assert err1[0] == pytest.approx(0.0, abs=1e-9)
    assert err1[k] > 1.5                       # really moved out of the way ...
    assert 0.2 * len(times) < k < 0.9 * len(times)
    assert err1[-1] < 0.1                      # ... and came back
    assert r.settle_time_s[0] > r.settle_time_s[2]


# --------------------------------------------------------------------------------------
# singularities, limits, obstacles
# --------------------------------------------------------------------------------------
def test_singular_start_on_beta_stop():
    """Fully stretched (beta = 0, on the hardware stop) with the target closer in: J^T
    cannot pull the tip inwards; the singularity rule hands that push to beta."""
    geom = custom_geom(DESI, [[0.0, 0.0]])
    start = np.array([[30.0, 0.0]])
    targets = np.array([[30.0 - 40.0, 80.0]])
    targets[0, 0] %= 360.0
    ok = plan_apf(geom, start, targets)
    assert ok.complete
    stuck = plan_apf(geom, start, targets, ApfSettings(singular_band_deg=0.0, max_time_s=3.0))
    assert not stuck.complete and stuck.stop_reason == "stalled"


def test_enforced_alpha_limits():
    geom = custom_geom(DESI, [[0.0, 0.0]])
    start, targets = np.array([[10.0, 90.0]]), np.array([[340.0, 90.0]])
    free = plan_apf(geom, start, targets)
    assert free.complete and free.alpha_out_of_limits == 1 and free.final[0, 0] < 0.0
    held = plan_apf(geom, start, targets, ApfSettings(enforce_alpha_limits=True, max_time_s=5.0))
    lo = min(a.min() for a in held.trajectory.angles[0])
    assert held.alpha_out_of_limits == 0 and lo >= 0.0


def test_offline_robot_and_fiducial_repel():
    p = DESI.pitch_mm
    xy = [[0.0, 0.0], [p, 0.0], [3.0, -8.0]]
    geom = custom_geom(DESI, xy, ["robot", "robot", "fiducial"])
    start = np.array([angles_for(geom, 0, [2.0, 4.0]), angles_for(geom, 1, [-5.9, 0.0])])
    targets = np.array([angles_for(geom, 0, [3.2, -5.0]), start[1]])
    r = plan_apf(geom, start, targets, movable=np.array([True, False]))
    assert r.complete and r.movable.tolist() == [True, False]
    assert r.trajectory.point_counts()[1].tolist() == [2, 2]
    assert np.allclose(r.final[1], start[1])
    assert r.min_tip_distance_mm > r.d_mm
    assert r.d_fid_mm < r.min_fiducial_distance_mm < r.D_fid_mm
    # the straight line to the target passes the offline tip within d: it had to go around
    line = np.linspace(tips(geom, start)[0], tips(geom, targets)[0], 200)
    assert np.min(np.hypot(*(line - tips(geom, start)[1]).T)) < r.d_mm


def test_start_errors_name_robots():
    geom = custom_geom(DESI, [[0.0, 0.0], [DESI.pitch_mm, 0.0]])
    mid = DESI.pitch_mm / 2
    start = np.array([angles_for(geom, 0, [mid - 0.5, 0.0]), angles_for(geom, 1, [-(mid - 0.5), 0.0])])
    with pytest.raises(TargetError, match=r"start: robots 0 and 1: tips 1\.\d+ mm apart; allowed: > d = 2"):
        plan_apf(geom, start, start)
    with pytest.raises(TargetError, match="field 'beta'"):
        plan_apf(geom, np.array([[0.0, 0.0], [0.0, 400.0]]), start)
    with pytest.raises(UnknownRobotError, match="offline robot 9"):
        plan_apf_reconfiguration(geom, start, offline={9: (0.0, 0.0)})


# --------------------------------------------------------------------------------------
# segment model on SDSS-V, and the Plan shape for the CLI
# --------------------------------------------------------------------------------------
def test_segment_mode_passes_checker_at_buffer():
    buffer = 2.5
    geom = ArrayGeometry(SDSS, Layout.hex_grid_positions(7, SDSS.pitch_mm), buffer)
    settings = ApfSettings(model="segment")
    m = apf_target_margin_mm(geom, settings)
    rng = np.random.default_rng(0)
    start = random_targets(geom, rng, margin_mm=m + 0.05)
    targets = random_targets(geom, rng, margin_mm=m + 0.5)
    r = plan_apf(geom, start, targets, settings)
    assert r.complete and r.min_distance_mm > 2 * buffer
    report = check_trajectory(r.trajectory, SDSS, geom.layout, buffer)
    assert report.ok, report.table()
    assert report.min_clearance_mm > 0.1
    assert r.trajectory.point_counts().max() <= 1024
    assert np.all(r.trajectory.max_speed() <= np.array(SDSS.max_speed_deg_s) + 1e-6)


def test_plan_for_cli():
    geom = desi_geom(19)
    rng = np.random.default_rng(3)
    targets = random_tip_configs(geom, rng, 3.0)
    plan, res = plan_apf_reconfiguration(geom, targets, offline={4: (10.0, 170.0)})
    assert plan.step_s == 0.01 and plan.n_steps == res.steps
    assert plan.step_deg == pytest.approx(0.01 * max(DESI.max_speed_deg_s))
    assert set(plan.status) <= {REACHED, DEADLOCKED, OFFLINE}
    assert plan.status[4] == OFFLINE and np.all(plan.status[np.arange(19) != 4] == REACHED)
    assert np.allclose(plan.start(), np.array([DESI.fold_deg] * 19))
    for key in ("efficiency", "convergence", "tau_pg_s", "tau_sr_s", "fold_time_s",
                "n_deadlocked", "n_replaced", "n_offline", "rounds"):
        assert key in plan.metrics
    assert plan.metrics["efficiency"] == 1.0 and plan.metrics["n_offline"] == 1
    # the Plan replays the result's trajectory exactly
    t = np.linspace(0.0, res.motion_time_s, 57)
    back = Trajectory.from_plan(plan)
    assert np.allclose(back.sample(t), res.trajectory.sample(t), atol=1e-9)
