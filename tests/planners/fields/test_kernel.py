"""The integration kernel of the navigation field (Makarem 2014 and this repo's rules for
singularities, alpha limits, obstacles): planners/fields/kernel.py, through plan_apf."""
from __future__ import annotations

import math

import numpy as np
import pytest

from rfp_twin.planners.fields import ApfSettings, plan_apf, random_tip_configs
from tests.planners.fields.cases import DESI, angles_for, custom_geom, desi_geom, tips


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


def test_guard_holds_back_steps_the_explicit_field_would_take_into_the_barrier():
    """With the paper's explicit Euler, a high gain and no speed limit, steps towards targets
    inside the barrier overshoot it; the guard halves them, so no sampled distance ever
    reaches d (without it the tips would come within d)."""
    geom = custom_geom(DESI, [[0.0, 0.0], [DESI.pitch_mm, 0.0]])
    mid = DESI.pitch_mm / 2
    start = np.array([angles_for(geom, 0, [mid - 3.0, 0.0]), angles_for(geom, 1, [-(mid - 3.0), 0.0])])
    targets = np.array([angles_for(geom, 0, [mid, 0.0]), angles_for(geom, 1, [-mid, 0.0])])
    fast = dict(gain=100.0, implicit_attraction=False, speed_deg_s=(3600.0, 3600.0), max_time_s=1.0)
    guarded = plan_apf(geom, start, targets, ApfSettings(**fast))
    assert guarded.n_guard > 0 and guarded.min_tip_distance_mm > guarded.d_mm
    free = plan_apf(geom, start, targets, ApfSettings(guard=False, **fast))
    assert free.n_guard == 0 and free.min_tip_distance_mm <= free.d_mm
