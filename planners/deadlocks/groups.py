"""Deadlocked robots and their groups, read off a stepwise run (shared by the strategies).

A robot is *stuck* when a run leaves it away from its destination; stuck robots form
*groups*, the connected components of the Eq. 4 neighbour graph (Sayres 2021) among
them, which the deadlock strategies (:mod:`rfp_twin.planners.deadlocks`) resolve one by
one.

Units: angles in deg, time in planner steps.
"""
from __future__ import annotations

import numpy as np

from rfp_twin.planners.stepwise import ANGLE_EPS, StepRun


def grow_region(pairs: np.ndarray, seed_mask: np.ndarray, hops: int) -> np.ndarray:
    """Robots within ``hops`` steps of ``seed_mask`` through the neighbour pairs.

    pairs : (p, 2) int robot index pairs (the Eq. 4 neighbour graph); seed_mask : (n,) bool.
    Returns a new (n,) bool mask.
    """
    region = np.asarray(seed_mask, dtype=bool).copy()
    for _ in range(hops):
        grown = region.copy()
        grown[pairs[region[pairs[:, 0]], 1]] = True
        grown[pairs[region[pairs[:, 1]], 0]] = True
        if np.array_equal(grown, region):
            break
        region = grown
    return region


def stuck_mask(run: StepRun, goal: np.ndarray, movable: np.ndarray) -> np.ndarray:
    """(n,) bool: movable robots that the run left away from ``goal`` (n, 2) deg."""
    return movable & ~np.all(np.abs(run.final - goal) < ANGLE_EPS, axis=1)


def last_events(run: StepRun, n: int) -> np.ndarray:
    """(n,) int64: each robot's last breakpoint step in ``run`` (-1: none)."""
    last = np.full(n, -1, dtype=np.int64)
    np.maximum.at(last, run.ev_robot, run.ev_step)
    return last


def arrival_steps(run: StepRun, stuck: np.ndarray) -> int:
    """Steps until the last robot that reached its destination in ``run`` got there: the
    run's fold without the stuck robots, which may go on moving now and then until the
    run stops (at most ``run.n_steps``). ``stuck`` (n,) bool."""
    arrived = last_events(run, stuck.size)[~stuck]
    if arrived.size == 0 or arrived.max() < 0:
        return int(run.n_steps)
    return int(min(run.n_steps, arrived.max() + 1))


def clusters(pairs: np.ndarray, stuck: np.ndarray, reach: int) -> list[np.ndarray]:
    """The stuck robots (``stuck`` (n,) bool) in clusters: two are in one cluster when
    their ``reach``-hop neighbourhoods touch (connected through the neighbour pairs).
    Returns a list of (k,) int64 robot index arrays."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import connected_components

    zone = grow_region(pairs, stuck, reach)
    n = stuck.size
    both = zone[pairs[:, 0]] & zone[pairs[:, 1]]
    graph = csr_matrix((np.ones(int(both.sum())), (pairs[both, 0], pairs[both, 1])), shape=(n, n))
    _, labels = connected_components(graph, directed=False)
    return [np.flatnonzero(stuck & (labels == c)) for c in np.unique(labels[stuck])]


def deadlocked_groups(pairs: np.ndarray, stuck: np.ndarray) -> list[np.ndarray]:
    """Connected components of the stuck robots (``stuck`` (n,) bool) through the Eq. 4
    neighbour graph (``pairs`` (p, 2) robot index pairs); [] when none is stuck."""
    return clusters(pairs, stuck, 0) if stuck.any() else []
