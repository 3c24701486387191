"""Verification bookkeeping (planners/postprocess/verification.py): re-check set, repair."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

import rfp_twin.planners.postprocess.verification as verification

from rfp_twin.models.trajectory import Trajectory
from rfp_twin.planners.postprocess.verification import (narrow_locally, repair,
                                                        subset_trajectory, verify_neighbours)
from rfp_twin.planners.postprocess.smoothing_local import WindowRegions
from tests.planners.conftest import make_geom


def hit(a, other, kind="robot", d=0.5):
    return SimpleNamespace(robot_a=a, other=other, kind=kind, min_distance_mm=d)


def test_repair_merges_groups_and_tightens_robots_in_place():
    labels = np.array([0, 0, 1, 2])
    ids = {10: 0, 11: 1, 12: 2, 13: 3}
    window = np.array([200.0, 200.0, 200.0, 1.0])
    tol = np.array([0.1, 0.1, 0.1, 1e-3])
    pre = np.array([0.2, 0.2, 0.2, 0.0])
    # robots 10 and 12 met while timed apart; 10 and 11 collide inside their group
    dirty, touched, merges, tightened = repair([hit(10, 12), hit(10, 11)], labels, ids,
                                               window, tol, pre)
    assert labels.tolist() == [0, 0, 0, 2] and merges == 1
    assert touched == {0, 1} and tightened == 2 and dirty == {0}
    np.testing.assert_array_equal(window, [100.0, 100.0, 200.0, 1.0])
    np.testing.assert_array_equal(tol, [0.05, 0.05, 0.1, 1e-3])
    np.testing.assert_array_equal(pre, [0.1, 0.1, 0.2, 0.0])
    # a robot at its floor (window 1, tolerance 1e-3, no pre-simplification): nothing to do
    dirty, touched, merges, tightened = repair([hit(13, 5, "fiducial")], labels, ids,
                                               window, tol, pre)
    assert dirty == set() and touched == {3} and merges == tightened == 0


def test_local_repair_narrows_around_the_collision_and_keeps_the_tolerances():
    """With regions, a collision inside a group narrows the window of both robots on a
    stretch around it (level 1: the collision +- w/2 + w/2 steps); the global window, RDP
    and pre-simplification tolerances stay."""
    labels = np.array([0, 0, 1])
    ids = {10: 0, 11: 1, 12: 2}
    window = np.array([200.0, 200.0, 200.0])
    tol = np.array([0.1, 0.1, 0.1])
    pre = np.array([0.2, 0.2, 0.2])
    reg = WindowRegions(3)
    spans = []

    def span(c, margin_mm):
        spans.append(margin_mm)
        return (1000.0, 1050.0) if margin_mm == 0.0 else (950.0 - margin_mm, 1100.0)

    dirty, touched, merges, tightened = repair([hit(10, 11)], labels, ids, window, tol, pre,
                                               reg, span)
    assert dirty == {0} and touched == {0, 1} and tightened == 2 and merges == 0
    near = verification._NEAR_MM              # the stretch: the pair within this in the plan
    u0, u1 = span(None, near)
    assert reg.regions[0] == reg.regions[1] == [[(u0 - 200.0, u1 + 200.0)]]
    assert reg.regions[2] == [] and spans[:4] == [0.0, near, 0.0, near]
    np.testing.assert_array_equal(window, 200.0)
    np.testing.assert_array_equal(tol, 0.1)
    np.testing.assert_array_equal(pre, 0.2)


def test_narrow_locally_deepens_inside_extends_near_an_end_and_stops_at_the_floor():
    reg = WindowRegions(1)

    def at(u0, u1):
        return lambda c, margin_mm: (u0, u1)

    assert narrow_locally(reg, 0, at(1000.0, 1010.0), None, 200.0)
    assert reg.regions[0] == [[(800.0, 1210.0)]]
    # deep inside level 1 (>= 100 steps from its ends): level 2, reaching 50 + 50 steps
    assert narrow_locally(reg, 0, at(1000.0, 1010.0), None, 200.0)
    assert reg.regions[0][1] == [(900.0, 1110.0)]
    # near the end of the level-2 stretch (< 50 steps): that stretch grows, no level 3
    assert narrow_locally(reg, 0, at(1100.0, 1105.0), None, 200.0)
    assert reg.regions[0] == [[(800.0, 1210.0)], [(900.0, 1205.0)]]
    # the window cannot go below one step: 200 / 2^8 < 1
    small = WindowRegions(1)
    results = [narrow_locally(small, 0, at(500.0, 500.0), None, 200.0) for _ in range(9)]
    assert results == [True] * 7 + [False] * 2 and small.max_level() == 7


def test_neighbours_are_symmetric_and_local_and_subsets_keep_robots():
    geom = make_geom(37, 2.0)
    near = verify_neighbours(geom, 1.97).toarray()
    assert np.array_equal(near, near.T) and not near.diagonal().any()
    # the robots within twice the collision reach at either buffer
    d = np.linalg.norm(geom.base_xy[:, None] - geom.base_xy[None], axis=2)
    reach = 2.0 * geom.spec.collision_reach_mm(2.0)
    np.testing.assert_array_equal(near, (d <= reach) & (d > 0))
    assert near[d < 1.01 * geom.spec.pitch_mm].sum() == np.sum(np.abs(d - geom.spec.pitch_mm) < 1e-6)
    traj = Trajectory(np.array([5, 6, 7]), ((np.zeros(1),) * 3, (np.zeros(1),) * 3),
                      ((np.zeros(1), np.ones(1), 2 * np.ones(1)),) * 2)
    sub = subset_trajectory(traj, np.array([0, 2]))
    assert sub.robot_ids.tolist() == [5, 7] and sub.angles[0][1].tolist() == [2.0]


def test_a_wiggle_tolerance_above_the_base_is_halved_from_the_third_collision():
    """A robot pre-simplified within the wiggle tolerance (0.5 deg, 0.19 mm at the end of
    the segment) has it halved towards the base tolerance from its third round in a
    collision on, on top of the usual tightening; robots at the base tolerance only get
    the usual tightening (here a global window: both halve)."""
    def tighten(pre_base, rounds):
        pre = np.array([0.5, 0.2])
        hits = np.zeros(2, dtype=np.int64)
        for _ in range(rounds):
            repair([hit(10, 11)], np.array([0, 0]), {10: 0, 11: 1}, np.array([200.0, 200.0]),
                   np.array([0.1, 0.1]), pre, pre_base=pre_base, hits=hits)
        assert hits.tolist() == [rounds, rounds]
        return pre.tolist()

    assert tighten(None, 2) == tighten(0.1, 2) == [0.125, 0.05]
    assert tighten(None, 3) == [0.0625, 0.025]
    # the third round brings robot 10 down to the base first (0.125 -> 0.1 -> 0.05);
    # robot 11, already below it, is tightened as usual
    assert tighten(0.1, 3) == [0.05, 0.025]
