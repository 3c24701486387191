"""The sign-corrected repulsion (Makarem 2014 Eq. 2) and its gradient: planners/fields/field.py,
observed through one Euler step of plan_apf."""
from __future__ import annotations

import math

import numpy as np
import pytest

from rfp_twin.models.geometry2d import pair_distances
from rfp_twin.planners.fields import ApfSettings, plan_apf
from tests.planners.fields.cases import DESI, SDSS, angles_for, custom_geom, tips

#: One plain explicit Euler step: no implicit attraction, guard, band rules or saturation.
ONE_STEP = dict(max_time_s=0.01, implicit_attraction=False, guard=False, singular_band_deg=0.0,
                axis_radius_mm=0.0, speed_deg_s=(3600.0, 3600.0))


def rep(s, d, D):
    """The corrected Eq. 2 term: 0 at s = D, +inf at s = d, falling in between."""
    return (D * D - s * s) / (s * s - d * d) if s < D else 0.0


def expected_step(geom, start, i, distance, settings, result):
    """-dt gain grad_theta_i (lambda2 rep(s)) by central differences, deg."""
    h = 1e-6
    grad = np.zeros(2)
    for k in range(2):
        up, dn = start.copy(), start.copy()
        up[i, k] += math.degrees(h)
        dn[i, k] -= math.degrees(h)
        grad[k] = (rep(distance(up), result.d_mm, result.D_mm)
                   - rep(distance(dn), result.d_mm, result.D_mm)) / (2 * h)
    return -settings.dt_s * settings.gain * settings.lambda2 * np.degrees(grad)


def test_tip_model_step_descends_the_corrected_repulsion():
    """Robot 0 sits on its target, its tip 3 mm from robot 1's (inside D = 4 mm): its only
    push is the repulsion, and it steps down the gradient of the corrected term."""
    geom = custom_geom(DESI, [[0.0, 0.0], [DESI.pitch_mm, 0.0]])
    mid = DESI.pitch_mm / 2
    start = np.array([angles_for(geom, 0, [mid - 1.5, 0.3]), angles_for(geom, 1, [-(mid - 1.5), -0.2])])
    targets = np.array([start[0], angles_for(geom, 1, [-1.0, -4.0])])   # robot 1 has to move
    settings = ApfSettings(**ONE_STEP)
    r = plan_apf(geom, start, targets, settings)
    assert r.steps == 1 and r.d_mm < r.min_tip_distance_mm < r.D_mm

    def distance(a):
        t = tips(geom, a)
        return float(np.hypot(*(t[0] - t[1])))

    np.testing.assert_allclose(r.final[0] - start[0], expected_step(geom, start, 0, distance,
                                                                    settings, r), rtol=1e-5)
    moved = r.final.copy()
    moved[1] = start[1]
    assert distance(moved) > distance(start)                     # pushed away from robot 1


def test_segment_model_step_acts_at_the_closest_point_of_the_beta_segment():
    """SDSS-V arms (segment model): robot 0 on its target steps down the gradient of the
    corrected term of the beta-segment distance (the force acts at the closest point
    along the arm, not at the tip)."""
    geom = custom_geom(SDSS, [[0.0, 0.0], [SDSS.pitch_mm, 0.0]], buffer_mm=2.5)
    start = np.array([[5.0, 40.0], [200.0, 40.0]])   # 7.96 mm apart, closest point 23 % along arm 0
    settings = ApfSettings(model="segment", d_mm=6.0, D_mm=9.0, margin_mm=0.2, **ONE_STEP)
    pairs = np.array([[0, 1]])

    def distance(a):
        return float(pair_distances(geom.base_xy, np.ascontiguousarray(a), pairs,
                                    SDSS.alpha_length_mm, SDSS.segment_start_mm, geom.seg_end)[0])

    targets = np.array([start[0], [90.0, 90.0]])                   # robot 1 has to move
    r = plan_apf(geom, start, targets, settings)
    assert r.steps == 1 and r.d_mm < distance(start) < r.D_mm
    np.testing.assert_allclose(r.final[0] - start[0], expected_step(geom, start, 0, distance,
                                                                    settings, r), rtol=1e-5)
    moved = r.final.copy()
    moved[1] = start[1]
    assert distance(moved) > distance(start)


def test_printed_sign_would_pull_tips_together():
    """Makarem 2014 Eq. 2 as printed, min(0, (s^2 - D^2) / (s^2 - d^2)), rises as the tips
    separate (descending it pulls them together, towards -inf at s = d); the corrected
    term falls."""
    d, D = 2.0, 4.0
    s = np.linspace(2.05, 3.95, 50)
    printed = np.minimum(0.0, (s ** 2 - D ** 2) / (s ** 2 - d ** 2))
    corrected = np.array([rep(x, d, D) for x in s])
    assert np.all(np.diff(printed) > 0) and printed[0] < -10
    assert np.all(np.diff(corrected) < 0) and rep(D, d, D) == 0.0


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
    assert r.min_tip_distance_mm == pytest.approx(r.min_distance_mm)   # tip model
