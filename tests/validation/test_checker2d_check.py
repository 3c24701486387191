"""Tests of the whole 2D check (validation/checker2d/check.py): candidate pairs,
fiducials, ids, parameters, and the independence from the planners."""
from __future__ import annotations

import math

import numpy as np
import pytest

from rfp_twin.models.errors import SpecError, TrajectoryError, UnknownRobotError
from rfp_twin.models.layout import Layout
from rfp_twin.models.trajectory import Trajectory
from tests.validation.conftest import SPEC, pair_layout, python_lines, swing
from rfp_twin.validation.checker2d import check_trajectory

BUF = 2.5
THR = 2 * BUF
RES = 1e-5


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


def test_focus_checks_only_the_pairs_of_the_named_robots():
    """A re-check after some robots changed (post-processing rounds): only their pairs,
    with the same minima as in the full check; a collision elsewhere is not looked at."""
    layout = Layout.hex_grid(2, 22.4)
    n = layout.n_robots
    fa, fb = SPEC.fold_deg
    ids = layout.robot_ids
    a = [[fa, fa]] * n
    xy = layout.robot_xy
    # robot far from the centre swings its arm into its neighbour
    k = int(np.argmax(xy[:, 0]))
    a[k] = [fa, fa + 180.0]
    traj = Trajectory.from_breakpoints(ids, [[0.0, 2.0]] * n, a, [[0.0, 2.0]] * n, [[fb, 10.0]
                                       if i == k else [fb, fb] for i in range(n)])
    full = check_trajectory(traj, SPEC, layout, BUF)
    assert not full.ok
    centre = int(np.argmin(np.hypot(*xy.T)))
    part = check_trajectory(traj, SPEC, layout, BUF, focus_ids=[int(ids[centre])])
    assert part.ok and 0 < part.n_pairs < full.n_pairs
    assert all(int(ids[centre]) in p for p in part.pair_ids.tolist())
    row = {tuple(p): d for p, d in zip(full.pair_ids.tolist(), full.pair_min_distance_mm)}
    for p, d in zip(part.pair_ids.tolist(), part.pair_min_distance_mm):
        assert d == pytest.approx(row[tuple(p)], abs=1e-12)
    bad = check_trajectory(traj, SPEC, layout, BUF, focus_ids=[int(ids[k])])
    assert {(c.robot_a, c.other) for c in bad.collisions} == \
        {(c.robot_a, c.other) for c in full.collisions}


# -- independence -------------------------------------------------------------------
def test_checker_imports_no_planner_algorithm_and_no_planner_geometry():
    code = ("import rfp_twin.validation.checker2d, sys; "
            "print([m for m in sys.modules if m.startswith('rfp_twin.planners')]); "
            "print('rfp_twin.models.geometry2d' in sys.modules); "
            "print(sorted({m.split('.')[0] for m in sys.modules} & {'fcl', 'trimesh'}))")
    # no planner module, no planner geometry, and light: no FCL, no meshes
    assert python_lines(code)[-3:] == ["[]", "False", "[]"]


# -- errors -------------------------------------------------------------------------
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
    traj = swing([0.0, 1.0, 2.0], [90.0, 50.0, 90.0], 2.0)
    with pytest.raises(SpecError, match="buffer_mm"):
        check_trajectory(traj, SPEC, pair_layout(), 0.0)
    with pytest.raises(SpecError, match="resolution_s"):
        check_trajectory(traj, SPEC, pair_layout(), BUF, resolution_s=0.0)
