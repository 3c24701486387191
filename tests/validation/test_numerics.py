"""Tests of the numerics shared by the validation side (validation/numerics.py)."""
from __future__ import annotations

import json
import math
from dataclasses import dataclass

import numpy as np
import pytest

from rfp_twin.models.errors import SpecError, TrajectoryError, UnknownRobotError
from rfp_twin.models.trajectory import Trajectory
from tests.validation.conftest import pair_layout
from rfp_twin.validation.numerics import (STACK, axis_csr, beta_segment, checked_float,
                                 collision_table, interp_angle, json_float, max_rate,
                                 pairs_within, peak_and_travel, plain_fields, push,
                                 push_halves, robot_bases, segment_distance,
                                 segment_distance_np, time_span)


# -- segment distance ---------------------------------------------------------------
def _brute_segment_distance(p0, p1, q0, q1, n=301):
    s = np.linspace(0.0, 1.0, n)[:, None]
    a = p0 + s * (p1 - p0)
    b = q0 + s * (q1 - q0)
    return np.sqrt(((a[:, None, :] - b[None, :, :]) ** 2).sum(-1)).min()


SPECIAL = [
    # (p0, p1, q0, q1, exact distance)
    ((0, 0), (10, 0), (0, 3), (10, 3), 3.0),               # parallel, overlapping
    ((0, 0), (10, 0), (12, 0), (20, 0), 2.0),              # collinear, disjoint
    ((0, 0), (10, 0), (4, 0), (6, 0), 0.0),                # collinear, contained
    ((0, 0), (10, 0), (13, 4), (20, 4), 5.0),              # parallel, offset ends
    ((0, 0), (10, 10), (0, 10), (10, 0), 0.0),             # crossing
    ((0, 0), (10, 0), (5, 2), (5, 9), 2.0),                # T, not touching
    ((0, 0), (10, 0), (5, 0), (5, 9), 0.0),                # T, touching
    ((3, 4), (3, 4), (0, 0), (10, 0), 4.0),                # point vs segment
    ((0, 0), (10, 0), (13, 4), (13, 4), 5.0),              # segment vs point
    ((1, 1), (1, 1), (4, 5), (4, 5), 5.0),                 # point vs point
    ((0, 0), (10, 0), (0, 1e-9), (10, 1e-7), 1e-9),        # nearly parallel
    ((0, 0), (10, 0), (-5, -1e-9), (5, 1e-9), 0.0),        # nearly parallel, crossing
    ((0, 0), (10, 0), (11, 1e-7), (21, 2e-7), 1.0),        # nearly collinear, disjoint
]


@pytest.mark.parametrize("p0,p1,q0,q1,exact", SPECIAL)
def test_segment_distance_special_cases(p0, p1, q0, q1, exact):
    got = segment_distance_np(p0, p1, q0, q1)
    assert got == pytest.approx(exact, abs=1e-12)
    assert segment_distance(*p0, *p1, *q0, *q1) == pytest.approx(exact, abs=1e-12)
    # symmetric in the two segments and in their orientation
    assert segment_distance_np(q1, q0, p1, p0) == pytest.approx(exact, abs=1e-12)


def test_segment_distance_random_against_brute_force():
    rng = np.random.default_rng(7)
    n = 120
    p0, p1, q0, q1 = (rng.uniform(-10, 10, (n, 2)) for _ in range(4))
    # parallel, collinear and degenerate variants
    q1[:20] = q0[:20] + (p1[:20] - p0[:20]) * rng.uniform(-2, 2, (20, 1))
    q0[20:30] = p0[20:30] + (p1[20:30] - p0[20:30]) * 1.5
    q1[20:30] = p0[20:30] + (p1[20:30] - p0[20:30]) * rng.uniform(-1, 3, (10, 1))
    p1[30:40] = p0[30:40]
    q1[35:45] = q0[35:45]
    got = segment_distance_np(p0, p1, q0, q1)
    assert got.shape == (n,)
    for k in range(n):
        brute = _brute_segment_distance(p0[k], p1[k], q0[k], q1[k])
        step = (np.linalg.norm(p1[k] - p0[k]) + np.linalg.norm(q1[k] - q0[k])) / 300
        assert got[k] <= brute + 1e-9
        assert brute <= got[k] + step / 2 + 1e-9
        assert segment_distance(*p0[k], *p1[k], *q0[k], *q1[k]) == pytest.approx(got[k], abs=1e-9)
    # broadcasting (..., 2)
    grid = segment_distance_np(p0[:5, None], p1[:5, None], q0[None, :4], q1[None, :4])
    assert grid.shape == (5, 4)


def test_beta_segment_is_the_capsule_model_segment():
    # alpha 90, beta -90 from a base at (1, 2): elbow (1, 9.4), arm along +x
    p0x, p0y, p1x, p1y = beta_segment(1.0, 2.0, math.pi / 2, -math.pi / 2, 7.4, 0.0, 15.0)
    np.testing.assert_allclose([p0x, p0y, p1x, p1y], [1.0, 9.4, 16.0, 9.4], atol=1e-12)
    rng = np.random.default_rng(4)
    for bx, by, a, b in rng.uniform(-7, 7, (20, 4)):
        got = beta_segment(bx, by, a, b, 7.4, 2.0, 16.0)
        elbow = np.array([bx, by]) + 7.4 * np.array([math.cos(a), math.sin(a)])
        u = np.array([math.cos(a + b), math.sin(a + b)])
        np.testing.assert_allclose(got, [*(elbow + 2.0 * u), *(elbow + 16.0 * u)], atol=1e-12)


# -- trajectory on CSR arrays -------------------------------------------------------------
def _raw(ids, times, angles) -> Trajectory:
    """A trajectory with exactly these breakpoints (alpha and beta alike)."""
    t = tuple(np.asarray(x, float) for x in times)
    a = tuple(np.asarray(x, float) for x in angles)
    return Trajectory(np.asarray(ids, dtype=np.int64), (t, t), (a, a))


def _traj() -> Trajectory:
    """Robot 5: 0 -> 30 deg on [1, 2] s, then holds (with a repeated breakpoint); robot
    9: 10 -> -20 -> 40 deg at 0, 0.5, 3 s."""
    return _raw([5, 9], [[1.0, 2.0, 2.0, 4.0], [0.0, 0.5, 3.0]],
                [[0.0, 30.0, 30.0, 30.0], [10.0, -20.0, 40.0]])


def test_axis_csr_holds_times_radians_and_slopes():
    ptr, tt, aa, rate = axis_csr(_traj(), 0)
    assert ptr.tolist() == [0, 4, 7]
    np.testing.assert_array_equal(tt, [1.0, 2.0, 2.0, 4.0, 0.0, 0.5, 3.0])
    np.testing.assert_allclose(np.degrees(aa), [0, 30, 30, 30, 10, -20, 40])
    # |slope| of the segment starting at each breakpoint; 0 at the end of a robot
    np.testing.assert_allclose(np.degrees(rate), [30.0, 0.0, 0.0, 0.0, 60.0, 24.0, 0.0])
    peak, travel = peak_and_travel(ptr, tt, rate)
    np.testing.assert_allclose(np.degrees(peak), [30.0, 60.0])
    np.testing.assert_allclose(np.degrees(travel), [30.0, 90.0])
    assert [len(x) for x in axis_csr(Trajectory([], ((), ()), ((), ())), 1)] == [1, 0, 0, 0]


def test_axis_csr_refuses_a_jump():
    jump = _raw([3], [[0.0, 0.5, 0.5, 1.0]], [[0.0, 0.0, 10.0, 10.0]])
    with pytest.raises(TrajectoryError, match="robot 3: axis beta jumps by 10 deg at t = 0.5"):
        axis_csr(jump, 1)


def test_interpolation_matches_numpy_and_holds_outside():
    traj = _traj()
    ptr, tt, aa, _ = axis_csr(traj, 0)
    times = np.concatenate([np.linspace(-1.0, 5.0, 241), [1.0, 2.0, 4.0, 0.5, 3.0]])
    for i in range(2):
        ref = np.interp(times, tt[ptr[i]:ptr[i + 1]], aa[ptr[i]:ptr[i + 1]])
        got = np.array([interp_angle(ptr, tt, aa, i, t) for t in times])
        np.testing.assert_allclose(got, ref, rtol=0, atol=1e-15)
    np.testing.assert_allclose(np.degrees(np.array([interp_angle(ptr, tt, aa, 0, t)
                                                    for t in (1.5, -3.0, 9.0)])),
                               [15.0, 0.0, 30.0], atol=1e-12)


def test_max_rate_is_the_largest_slope_of_the_overlapping_segments():
    rng = np.random.default_rng(5)
    times = [np.sort(rng.uniform(0, 10, k)) for k in (2, 7, 30)]
    times[2][10] = times[2][9]                          # a repeated breakpoint
    angles = [rng.uniform(-90, 90, len(t)) for t in times]
    angles[2][10] = angles[2][9]
    ptr, tt, _, rate = axis_csr(_raw([0, 1, 2], times, angles), 0)
    for _ in range(400):
        t0, t1 = np.sort(rng.uniform(-1, 11, 2))
        for i in range(3):
            lo, hi = ptr[i], ptr[i + 1]
            over = [rate[k] for k in range(lo, hi - 1) if tt[k] < t1 and tt[k + 1] > t0]
            assert max_rate(ptr, tt, rate, i, t0, t1) == max(over, default=0.0)
    p1, t1_, _, r1 = axis_csr(_raw([0], [[1.0]], [[5.0]]), 0)
    assert max_rate(p1, t1_, r1, 0, 0.0, 2.0) == 0.0


def test_time_span_starts_at_zero_or_the_first_breakpoint():
    assert time_span(_traj()) == (0.0, 4.0)
    early = Trajectory.from_breakpoints([0], [[-2.0, 1.0]], [[0.0, 1.0]], [[0.5, 3.0]],
                                        [[0.0, 1.0]])
    assert time_span(early) == (-2.0, 3.0)
    assert time_span(Trajectory([], ((), ()), ((), ()))) == (0.0, 0.0)


# -- bisection stack ----------------------------------------------------------------
def test_bisection_stack_pops_the_left_half_first():
    st = np.empty((STACK, 4))
    top = push(st, 0, 0.0, 1.0, 10.0, 11.0)
    top -= 1
    a, b, fa, fb = st[top]
    top = push_halves(st, top, a, 0.5, b, fa, 10.5, fb)
    assert top == 2
    np.testing.assert_array_equal(st[1], [0.0, 0.5, 10.0, 10.5])     # popped first
    np.testing.assert_array_equal(st[0], [0.5, 1.0, 10.5, 11.0])


# -- pairs, bases, checks, reports ---------------------------------------------------------
def test_pairs_within_matches_all_pairs_and_counts_the_reach_itself():
    rng = np.random.default_rng(9)
    xy = rng.uniform(0, 60, (80, 2))
    xy[1] = xy[0] + [7.0, 0.0]                          # exactly at the reach
    d = np.hypot(*(xy[:, None, :] - xy[None, :, :]).transpose(2, 0, 1))
    ref = [(i, j) for i in range(80) for j in range(i + 1, 80) if d[i, j] <= 7.0 + 1e-9]
    got = pairs_within(xy, 7.0)
    assert got.dtype == np.int64 and [tuple(p) for p in got] == ref
    assert (0, 1) in ref
    assert pairs_within(xy[:1], 7.0).shape == (0, 2)


def test_robot_bases_in_trajectory_order_and_refuses_bad_ids():
    traj = Trajectory.from_breakpoints([1, 0], [[0.0], [0.0]], [[0.0], [0.0]],
                                       [[0.0], [0.0]], [[0.0], [0.0]])
    ids, base = robot_bases(traj, pair_layout())
    assert ids.tolist() == [1, 0]
    np.testing.assert_array_equal(base, [[22.4, 0.0], [0.0, 0.0]])
    twice = Trajectory.from_breakpoints([0, 0], [[0.0], [0.0]], [[0.0], [0.0]],
                                        [[0.0], [0.0]], [[0.0], [0.0]])
    with pytest.raises(TrajectoryError, match="robot 0: appears more than once"):
        robot_bases(twice, pair_layout())
    stranger = Trajectory.from_breakpoints([4], [[0.0]], [[0.0]], [[0.0]], [[0.0]])
    with pytest.raises(UnknownRobotError, match="4"):
        robot_bases(stranger, pair_layout())


def test_checked_float_names_the_field_and_what_is_allowed():
    assert checked_float("2.5", "buffer_mm", "> 0", "here") == 2.5
    assert checked_float(0.0, "tol", ">= 0", "here", strict=False) == 0.0
    for bad in (0.0, -1.0, math.inf, math.nan, "x", None, True):
        with pytest.raises(SpecError, match=r"here: field 'buffer_mm' = .*; allowed: > 0"):
            checked_float(bad, "buffer_mm", "> 0", "here")
    assert checked_float(True, "flag", "> 0", "here", allow_bool=True) == 1.0
    with pytest.raises(SpecError, match="resolution_s"):
        checked_float(1e-13, "resolution_s", ">= 1e-12", "here", 1e-12, strict=False)


@dataclass
class _Row:
    kind: str
    n: int
    t: float
    conservative: bool = False


def test_report_pieces_are_plain_json_and_aligned_text():
    assert json_float(np.float64(1.5)) == 1.5 and json_float(np.inf) is None
    row = _Row("robot", np.int64(3), np.float32(0.25), np.bool_(True))
    plain = plain_fields(row)
    assert plain == {"kind": "robot", "n": 3, "t": 0.25, "conservative": True}
    assert [type(v) for v in plain.values()] == [str, int, float, bool]
    assert json.loads(json.dumps(plain)) == plain
    columns = (("kind", "kind", "<9"), ("n", "n", ">4"), ("t", "t", ">8.3f"))
    text = collision_table(["summary"], [row, _Row("fiducial", 12, 1.5)], columns)
    assert text.splitlines() == ["summary",
                                 "kind        n       t",
                                 "robot       3   0.250  (bound)",
                                 "fiducial   12   1.500"]
    assert collision_table(["a", "b"], [], columns) == "a\nb"
