"""Tests of the independent dense 2D checker (validation/checker2d.py).

Geometry used throughout (SDSS-V spec, buffer 2.5 mm, threshold 5 mm): robot 0 at the
origin with alpha = 0 sweeps its beta arm; robot 1 at (22.4, 0) sits still with alpha =
beta = 180, so its collision segment is [(15, 0), (30, 0)]. For beta = b in [0, 90] deg
the segment distance is exactly ``7.6 sin b`` (point (15, 0) to robot 0's arm).
"""
from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from models.errors import SpecError, TrajectoryError, UnknownRobotError
from models.layout import Layout
from models.robot import load_spec
from models.trajectory import Trajectory
from validation.checker2d import (CheckReport, Collision, check_trajectory,
                                  coarse_grid, segment_distance_np, speed_bounds_mm_s)
from validation.numerics import segment_distance as _segment_distance

ROOT = Path(__file__).resolve().parents[2]
SPEC = load_spec("sdss-v")
BUF = 2.5
THR = 2 * BUF
RES = 1e-5


def pair_layout() -> Layout:
    return Layout([0, 1], [[0.0, 0.0], [22.4, 0.0]], ["robot", "robot"], name="pair")


def swing_traj(beta_times, beta_angles, duration) -> Trajectory:
    """Robot 0 moves its beta arm; robot 1 is parked at (180, 180)."""
    return Trajectory.from_breakpoints(
        [0, 1],
        [[0.0, duration], [0.0, duration]], [[0.0, 0.0], [180.0, 180.0]],
        [beta_times, [0.0, duration]], [beta_angles, [180.0, 180.0]])


def brute_distances(traj: Trajectory, layout: Layout, times, a: int, b: int | None = None,
                    point=None) -> np.ndarray:
    """Segment distance of robot index a to robot index b (or to a point) at times."""
    ang = np.deg2rad(traj.sample(times))
    s0, s1 = SPEC.segment_start_mm, SPEC.segment_end(BUF)
    base = layout.robot_xy

    def seg(k):
        al, be = ang[:, k, 0], ang[:, k, 1]
        elbow = base[k] + SPEC.alpha_length_mm * np.stack([np.cos(al), np.sin(al)], -1)
        u = np.stack([np.cos(al + be), np.sin(al + be)], -1)
        return elbow + s0 * u, elbow + s1 * u

    p0, p1 = seg(a)
    if b is None:
        q = np.broadcast_to(np.asarray(point, float), p0.shape)
        return segment_distance_np(p0, p1, q, q)
    q0, q1 = seg(b)
    return segment_distance_np(p0, p1, q0, q1)


# -- a brief overlap ----------------------------------------------------------------
def test_brief_swing_through_is_caught_by_refinement():
    # beta 90 -> 39 -> 90 deg in 5 ms; collision while 7.6 sin b <= 5
    traj = swing_traj([0.0, 0.1, 0.1025, 0.105, 0.2], [90.0, 90.0, 39.0, 90.0, 90.0], 0.2)
    rate = 51.0 / 0.0025
    b_crit = math.degrees(math.asin(THR / 7.6))
    t_in, t_out = 0.1 + (90 - b_crit) / rate, 0.105 - (90 - b_crit) / rate
    overlap = t_out - t_in
    assert 1e-4 < overlap < 3e-4

    report = check_trajectory(traj, SPEC, pair_layout(), BUF, resolution_s=RES)
    assert not report.ok
    assert len(report.collisions) == 1
    c = report.collisions[0]
    assert (c.kind, c.robot_a, c.other) == ("robot", 0, 1)
    assert not c.conservative
    assert c.threshold_mm == pytest.approx(THR)
    assert abs(c.t_start - t_in) <= 2 * RES and abs(c.t_end - t_out) <= 2 * RES
    assert t_in <= c.t_min <= t_out
    assert c.min_distance_mm <= THR
    assert report.min_clearance_mm < 0

    # the coarse grid alone would miss it: its spacing exceeds the overlap and none of
    # its samples is in collision; the bisection is what catches it
    grid = coarse_grid(traj, SPEC, BUF, 0, 1, resolution_s=RES)
    assert grid[0] == 0.0 and grid[-1] == pytest.approx(0.2)
    assert np.diff(grid).min() > overlap
    assert np.all(brute_distances(traj, pair_layout(), grid, 0, 1) > THR)
    # the speed bound is the peak beta speed times the arm reach (alpha is still)
    v = speed_bounds_mm_s(traj, SPEC, BUF)
    assert v[0] == pytest.approx(SPEC.segment_end(BUF) * math.radians(rate))
    assert v[1] == 0.0


def test_two_brief_overlaps_in_one_coarse_interval_stay_separate():
    t = [0.0, 0.1, 0.1025, 0.105, 0.1075, 0.11, 0.2]
    traj = swing_traj(t, [90.0, 90.0, 39.0, 90.0, 39.0, 90.0, 90.0], 0.2)
    grid = coarse_grid(traj, SPEC, BUF, 0, 1, resolution_s=RES)
    assert np.diff(grid).min() > 0.0075          # both swings inside one coarse interval
    report = check_trajectory(traj, SPEC, pair_layout(), BUF, resolution_s=RES)
    assert len(report.collisions) == 2
    for c, peak in zip(report.collisions, (0.1025, 0.1075)):
        assert c.t_start < peak < c.t_end and c.t_end - c.t_start < 3e-4
        assert abs(c.t_min - peak) < 1.5e-4


# -- a near miss --------------------------------------------------------------------
def near_miss_traj() -> Trajectory:
    b_min = math.degrees(math.asin((THR + 0.01) / 7.6))
    return swing_traj([0.0, 1.0, 2.0], [90.0, b_min, 90.0], 2.0)


def test_near_miss_is_ok_and_minimum_matches_brute_force():
    traj = near_miss_traj()
    report = check_trajectory(traj, SPEC, pair_layout(), BUF, resolution_s=RES)
    assert report.ok, report.table()
    assert report.n_pairs == 1 and report.n_fiducial_pairs == 0
    times = np.arange(0.0, 2.0 + RES / 2, RES)
    brute = brute_distances(traj, pair_layout(), times, 0, 1).min()
    assert abs(report.pair_min_distance_mm[0] - brute) <= 0.01
    assert report.pair_min_distance_mm[0] == pytest.approx(THR + 0.01, abs=0.006)
    assert report.min_clearance_mm == pytest.approx(0.01, abs=0.006)
    assert report.min_clearance_mm > 0
    assert report.duration_s == pytest.approx(2.0)


def test_near_miss_below_resolution_is_reported_conservatively():
    # with a 20 ms resolution the bound cannot clear the 0.01 mm near miss
    report = check_trajectory(near_miss_traj(), SPEC, pair_layout(), BUF, resolution_s=0.02)
    assert not report.ok
    assert len(report.collisions) == 1
    c = report.collisions[0]
    assert c.conservative
    assert c.t_start <= 1.0 <= c.t_end and c.t_end - c.t_start <= 0.05
    assert c.min_distance_mm < THR


# -- fiducials ----------------------------------------------------------------------
def test_robot_sweeps_through_fiducial():
    layout = Layout([0, 100], [[0.0, 0.0], [15.0, 0.0]], ["robot", "fiducial"], name="fid")
    # beta 0 (arm straight out), alpha 60 -> -60 deg in 1 s: distance 15 |sin alpha|
    traj = Trajectory.from_breakpoints([0], [[0.0, 1.0]], [[60.0, -60.0]],
                                       [[0.0, 1.0]], [[0.0, 0.0]])
    thr = BUF + SPEC.fiducial_buffer_mm
    a_crit = math.degrees(math.asin(thr / 15.0))
    t_in, t_out = (60 - a_crit) / 120, (60 + a_crit) / 120
    report = check_trajectory(traj, SPEC, layout, BUF, resolution_s=RES)
    assert report.n_pairs == 0 and report.n_fiducial_pairs == 1
    assert report.fiducial_pair_ids.tolist() == [[0, 100]]
    assert len(report.collisions) == 1
    c = report.collisions[0]
    assert (c.kind, c.robot_a, c.other) == ("fiducial", 0, 100)
    assert c.threshold_mm == pytest.approx(thr)
    assert abs(c.t_start - t_in) <= 2 * RES and abs(c.t_end - t_out) <= 2 * RES
    assert c.min_distance_mm <= thr and t_in <= c.t_min <= t_out
    assert report.fiducial_min_distance_mm[0] == pytest.approx(c.min_distance_mm)


# -- static folded grid -------------------------------------------------------------
def test_static_folded_grid_clearance_is_analytic():
    layout = Layout.hex_grid(1, 22.4)
    n = layout.n_robots
    fa, fb = SPEC.fold_deg
    traj = Trajectory.from_breakpoints(layout.robot_ids, [[0.0, 1.0]] * n, [[fa, fa]] * n,
                                       [[0.0, 1.0]] * n, [[fb, fb]] * n)
    report = check_trajectory(traj, SPEC, layout, BUF)
    assert report.ok
    assert report.n_pairs == n * (n - 1) // 2          # 7-robot grid spans < 49.8 mm
    # identical orientation: the segments are translates of one another; for a base
    # offset d and unit arm direction u the distance is |d x u| if |d.u| <= length,
    # else hypot(|d.u| - length, d x u)
    length = SPEC.segment_end(BUF) - SPEC.segment_start_mm
    phi = math.radians(fa + fb)
    u = np.array([math.cos(phi), math.sin(phi)])
    xy = layout.robot_xy
    idx = layout.robot_indices(report.pair_ids.ravel()).reshape(-1, 2)
    d = xy[idx[:, 1]] - xy[idx[:, 0]]
    along = np.abs(d @ u)
    across = np.abs(d[:, 0] * u[1] - d[:, 1] * u[0])
    expected = np.where(along <= length, across, np.hypot(along - length, across))
    np.testing.assert_allclose(report.pair_min_distance_mm, expected, atol=1e-9)
    assert report.min_clearance_mm == pytest.approx(22.4 - 15.0 - THR, abs=1e-9)
    assert report.n_samples == 2 * report.n_pairs      # static pairs need no refinement


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
    assert _segment_distance(*p0, *p1, *q0, *q1) == pytest.approx(exact, abs=1e-12)
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
        assert _segment_distance(*p0[k], *p1[k], *q0[k], *q1[k]) == pytest.approx(got[k], abs=1e-9)
    # broadcasting (..., 2)
    grid = segment_distance_np(p0[:5, None], p1[:5, None], q0[None, :4], q1[None, :4])
    assert grid.shape == (5, 4)


# -- independence -------------------------------------------------------------------
def test_checker_imports_no_planner_algorithm_and_no_planner_geometry():
    code = ("import validation.checker2d, sys; "
            "print([m for m in sys.modules if m.startswith('planners') "
            "and m != 'models.trajectory' and m != 'planners']); "
            "print('models.geometry2d' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True,
                         text=True, env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"},
                         check=True, timeout=120)
    lines = out.stdout.strip().splitlines()
    assert lines[-2] == "[]"
    assert lines[-1] == "False"


# -- report and errors --------------------------------------------------------------
def test_report_serialises_to_json():
    traj = swing_traj([0.0, 0.1, 0.1025, 0.105, 0.2], [90.0, 90.0, 39.0, 90.0, 90.0], 0.2)
    report = check_trajectory(traj, SPEC, pair_layout(), BUF)
    assert isinstance(report, CheckReport) and isinstance(report.collisions[0], Collision)
    data = json.loads(json.dumps(report.to_dict(), allow_nan=False))
    assert data["ok"] is False and data["n_collisions"] == 1
    assert data["pair_ids"] == [[0, 1]] and len(data["pair_min_distance_mm"]) == 1
    assert data["collisions"][0]["kind"] == "robot"
    assert "COLLISION" in report.table()
    # a lone robot has no pair: clearance is inf and serialises as null
    lone = Trajectory.from_breakpoints([0], [[0.0]], [[0.0]], [[0.0]], [[180.0]])
    alone = check_trajectory(lone, SPEC, pair_layout(), BUF)
    assert alone.ok and alone.n_pairs == 0 and alone.to_dict()["min_clearance_mm"] is None


def test_unknown_robot_id_raises():
    traj = Trajectory.from_breakpoints([0, 7], [[0.0], [0.0]], [[0.0], [0.0]],
                                       [[0.0], [0.0]], [[180.0], [180.0]])
    with pytest.raises(UnknownRobotError, match="7"):
        check_trajectory(traj, SPEC, pair_layout(), BUF)


def test_jump_and_bad_parameters_raise():
    jump = Trajectory.from_breakpoints([0, 1], [[0.0, 0.5, 0.5, 1.0], [0.0, 1.0]],
                                       [[0.0, 0.0, 10.0, 10.0], [180.0, 180.0]],
                                       [[0.0, 1.0], [0.0, 1.0]], [[90.0, 90.0], [180.0, 180.0]])
    with pytest.raises(TrajectoryError, match="robot 0: axis alpha jumps"):
        check_trajectory(jump, SPEC, pair_layout(), BUF)
    traj = near_miss_traj()
    with pytest.raises(SpecError, match="buffer_mm"):
        check_trajectory(traj, SPEC, pair_layout(), 0.0)
    with pytest.raises(SpecError, match="resolution_s"):
        check_trajectory(traj, SPEC, pair_layout(), BUF, resolution_s=0.0)
