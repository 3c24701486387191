"""Smoothing of stepwise plans (planners/postprocess/smoothing.py): exact running average, ends kept."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.errors import SpecError
from rfp_twin.models.robot import load_spec
from rfp_twin.planners.postprocess.smoothing import plan_deviation, smooth_plan, window_for_limits
from tests.planners.conftest import make_geom, plan_random
from tests.planners.path_builders import CORNER, make_plan


def test_running_average_is_exact_piecewise_quadratic():
    w = 40.0
    sp = smooth_plan(CORNER, window_steps=w)
    assert sp.pad_steps == w / 2 and sp.s_end == CORNER.n_steps + w
    # brute-force running average of the held piecewise-linear plan
    s = np.linspace(0, sp.s_end, 801)
    u = np.linspace(-0.5, 0.5, 4001) * w
    raw = CORNER.angles_at((s[:, None] + u[None, :] - sp.pad_steps).ravel()).reshape(s.size, u.size, 2)
    brute = np.trapezoid(raw, u, axis=1) / w
    np.testing.assert_allclose(sp.evaluate(s)[:, 0, :], brute, atol=1e-5)


def test_corner_deviation_is_slope_change_times_window_over_8():
    w = 40.0
    sp = smooth_plan(CORNER, window_steps=w)
    at = sp.evaluate(np.array([100.0, 300.0]) + sp.pad_steps)[:, 0, :]
    # alpha reverses at step 300: slope change 0.2 deg/step -> 0.2 * 40 / 8 = 1.0 deg
    assert at[1, 0] == pytest.approx(40.0 - 0.2 * w / 8)
    # beta starts at step 100: slope change 0.1 -> 0.5 deg
    assert at[0, 1] == pytest.approx(170.0 - 0.1 * w / 8)
    # straight stretches further than w/2 from any corner are untouched
    mid = sp.evaluate(np.array([200.0]) + sp.pad_steps)[0, 0]
    np.testing.assert_allclose(mid, CORNER.angles_at([200.0])[0, 0], atol=1e-12)
    assert plan_deviation(CORNER, sp).max() == pytest.approx(1.0)


def test_c1_with_bounded_slope_and_curvature():
    w = 25.0
    sp = smooth_plan(CORNER, window_steps=w)
    knots = sp.robot_knots(0)
    left = sp.evaluate(knots[1:-1] - 1e-9, deriv=1)
    right = sp.evaluate(knots[1:-1] + 1e-9, deriv=1)
    np.testing.assert_allclose(left, right, atol=1e-8)                      # C1
    s = np.linspace(0, sp.s_end, 5001)
    assert np.abs(sp.evaluate(s, deriv=1)).max() <= 0.1 + 1e-12              # <= plan slope
    assert np.abs(sp.evaluate(s, deriv=2)).max() <= 0.2 / w + 1e-12          # |dm| / w
    # between knots the second derivative is constant (what timing relies on)
    mid = 0.5 * (knots[1:] + knots[:-1])
    q2 = sp.evaluate(mid, deriv=2)[:, 0, :]
    q2b = sp.evaluate(mid + 0.25 * np.diff(knots)[:, None].min(axis=1), deriv=2)[:, 0, :]
    np.testing.assert_allclose(q2, q2b, atol=1e-12)


@pytest.mark.parametrize("method", ["average", "spline"])
def test_real_plan_keeps_start_and_end_exactly(method):
    geom = make_geom(37, 2.0)
    _, plan = plan_random(geom, 3, step_deg=0.1)
    sp = smooth_plan(plan, method=method, window_steps=21)
    np.testing.assert_array_equal(sp.start(), plan.start())
    np.testing.assert_array_equal(sp.end(), plan.end())
    np.testing.assert_allclose(sp.evaluate([0.0])[0], plan.start(), atol=1e-12)
    np.testing.assert_allclose(sp.evaluate([sp.s_end])[0], plan.end(), atol=1e-12)
    # outside the domain the path holds
    np.testing.assert_allclose(sp.evaluate([-5.0, sp.s_end + 5])[:, :, :],
                               np.stack([plan.start(), plan.end()]), atol=1e-12)
    dev = plan_deviation(plan, sp)
    assert dev.max() < 21 * 0.2 / 8 + 0.05


def test_per_robot_windows_and_zero_window():
    geom = make_geom(37, 2.0)
    _, plan = plan_random(geom, 1, step_deg=0.1)
    w = np.full(plan.n_robots, 30.0)
    w[::2] = 0.0
    sp = smooth_plan(plan, window_steps=w)
    np.testing.assert_array_equal(sp.window_steps, w)
    steps = np.arange(plan.n_steps + 1.0)
    sm = sp.evaluate(steps + sp.pad_steps)
    raw = plan.angles_at(steps)
    np.testing.assert_allclose(sm[:, ::2], raw[:, ::2], atol=1e-9)   # window 0 = the plan
    assert np.abs(sm[:, 1::2] - raw[:, 1::2]).max() > 0.01


def test_moving_range_brackets_motion():
    sp = smooth_plan(CORNER, window_steps=20)
    lo, hi = sp.moving_range()[0]
    assert lo == pytest.approx(0.0) and hi == pytest.approx(400 + 20)
    still = make_plan([([0, 50], [[10, 170], [10, 170]]), ([0, 50], [[0, 0], [5, 0]])])
    rng = smooth_plan(still, window_steps=10).moving_range()
    assert rng[0, 0] == rng[0, 1]
    assert rng[1, 0] == pytest.approx(0.0) and rng[1, 1] == pytest.approx(60.0)


def test_window_for_limits_spans_time_to_full_speed():
    spec = load_spec("sdss-v")
    assert spec.max_speed_deg_s == (30.0, 30.0) and spec.max_accel_deg_s2 == (45.0, 45.0)
    assert window_for_limits(spec.max_speed_deg_s, spec.max_accel_deg_s2, 0.1) == 200.0
    assert window_for_limits((30, 20), (45, 90), 1.0) == round(400 / 45)


@pytest.mark.parametrize("kwargs,field", [
    ({"method": "savgol"}, "method"),
    ({"window_steps": -1.0}, "window_steps"),
    ({"window_steps": np.nan}, "window_steps"),
    ({"window_steps": 20.0, "pad_steps": 5.0}, "pad_steps"),
])
def test_bad_arguments_name_the_field(kwargs, field):
    with pytest.raises(SpecError, match=field):
        smooth_plan(CORNER, **kwargs)


@pytest.mark.parametrize("w", [200 / 1.5, 200 / 1.5**2, 100 / 3, 12.5])
def test_fractional_windows_stay_c1(w):
    """Regression: a knot at breakpoint + w/2 must not read the slope on the wrong side
    of the breakpoint through rounding. With a padded domain (pad 100, w = 133.3) this
    once made q' jump by 1.9 deg/step on a straight stretch, and a group's time law 90 s
    long. The breakpoints are those of the robot where it happened."""
    steps = [0, 373, 3048, 3049, 3508, 3509, 3799]
    angles = [[10, 170], [10.01535036, 170], [277.51535036, 170], [277.61535036, 169.9095471],
              [323.51535036, 124.0095471], [323.61535036, 124.0095471],
              [352.61535036, 95.7095471]]
    plan = make_plan([(steps, angles)])
    sp = smooth_plan(plan, window_steps=w, pad_steps=100.0)
    k = sp.robot_knots(0)[1:-1]
    jump = sp.evaluate(k + 1e-7, deriv=1) - sp.evaluate(k - 1e-7, deriv=1)
    assert np.abs(jump).max() < 1e-6
    s = np.linspace(0, sp.s_end, 4001)
    assert np.abs(sp.evaluate(s, deriv=1)).max() <= 0.1 + 1e-9
    assert np.abs(sp.evaluate(s, deriv=2)).max() <= 0.2 / w + 1e-9
    u = np.linspace(-0.5, 0.5, 2001) * w
    raw = plan.angles_at((s[:, None] + u[None, :] - 100.0).ravel()).reshape(s.size, u.size, 2)
    np.testing.assert_allclose(sp.evaluate(s)[:, 0], np.trapezoid(raw, u, axis=1) / w, atol=1e-4)


def test_a_knot_starts_its_own_piece():
    """At a knot exactly, evaluate uses the piece that starts there: the value is that
    piece's constant coefficient (both sides agree) and q'' its right-hand constant."""
    sp = smooth_plan(CORNER, window_steps=40.0)
    knots = sp.robot_knots(0)
    inner = knots[1:-1]
    np.testing.assert_array_equal(sp.evaluate(inner)[:, 0, :], sp.coef[1:-1, :, 0])
    np.testing.assert_array_equal(sp.evaluate(inner, deriv=1)[:, 0, :], sp.coef[1:-1, :, 1])
    np.testing.assert_array_equal(sp.evaluate(inner, deriv=2)[:, 0, :], 2.0 * sp.coef[1:-1, :, 2])
    # a NaN parameter gives NaN, not a neighbour's value
    assert np.isnan(sp.evaluate([np.nan])).all()
