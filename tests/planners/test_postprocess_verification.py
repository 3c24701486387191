"""Verification bookkeeping (planners/postprocess/verification.py): ledger, re-check set, repair."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from rfp_twin.models.trajectory import Trajectory
from rfp_twin.planners.postprocess.verification import (ClearanceLedger, repair, subset_trajectory,
                                               verify_neighbours)
from tests.planners.conftest import make_geom


def check(pairs, dists, fpairs=(), fdists=(), collisions=()):
    """A checker report with only what the ledger reads."""
    return SimpleNamespace(pair_ids=np.array(pairs, dtype=np.int64).reshape(-1, 2),
                           pair_min_distance_mm=np.array(dists, dtype=float),
                           fiducial_pair_ids=np.array(fpairs, dtype=np.int64).reshape(-1, 2),
                           fiducial_min_distance_mm=np.array(fdists, dtype=float),
                           collisions=list(collisions), ok=not collisions)


def hit(a, other, kind="robot", d=0.5):
    return SimpleNamespace(robot_a=a, other=other, kind=kind, min_distance_mm=d)


def test_ledger_keeps_the_latest_distance_of_every_pair():
    led = ClearanceLedger(thr_robot=4.0, thr_fid=3.0)
    assert led.min_clearance() == np.inf and not led.ok
    led.update(check([[1, 2], [3, 2]], [5.0, 4.5], [[1, 90]], [3.8], [hit(2, 3, d=3.9)]))
    assert led.robot == {(1, 2): 5.0, (2, 3): 3.9} and not led.ok
    assert led.min_clearance() == pytest.approx(-0.1)
    # a later round re-checks the pair (2, 3): its new distance replaces the old one
    led.update(check([[2, 3]], [4.25]))
    assert led.ok and led.robot[(2, 3)] == 4.25
    assert led.min_clearance() == pytest.approx(0.25)
    led.update(check([], [], [[1, 90]], [2.0], [hit(1, 90, "fiducial", 1.5)]))
    assert led.fid[(1, 90)] == 1.5 and led.min_clearance() == pytest.approx(-1.5)


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
