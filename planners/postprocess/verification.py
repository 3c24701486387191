"""Verification rounds of the pipeline: what they checked, what to re-check, how to repair.

:class:`ClearanceLedger` keeps the latest checked minimum distance of every robot pair
and robot-fiducial pair over all rounds (a round re-checks only what changed), so the
report's minimum clearance covers the whole trajectory. :func:`verify_neighbours` says
which robots the checker pairs (their neighbours are re-checked with them), and
:func:`subset_trajectory` cuts the trajectory to them. :func:`repair` answers a failed
round: a collision between two groups merges them (they met at different ``s``); a
collision inside a group, or with a fiducial, halves the smoothing window, the RDP
tolerance and the pre-simplification tolerance of the robots involved.

Units: mm, degrees, plan steps; robots by index in layout order unless named ids.
"""
from __future__ import annotations

import math

import numpy as np

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.trajectory import Trajectory

__all__ = ["ClearanceLedger", "verify_neighbours", "subset_trajectory", "repair"]

#: Smallest window / tolerance that tightening goes down to.
_MIN_WINDOW_STEPS = 1.0
_MIN_TOLERANCE_DEG = 1e-3
#: Factor by which a colliding robot's window (then tolerance) shrinks per retry.
_TIGHTEN = 2.0


class ClearanceLedger:
    """Latest checked minimum distance of every pair, over all verification rounds.

    ``thr_robot``, ``thr_fid``: the distances at which a robot pair / a robot and a
    fiducial touch (twice the verification buffer; the buffer plus the fiducial's), mm.
    """

    def __init__(self, thr_robot: float, thr_fid: float) -> None:
        self.thr_robot = thr_robot
        self.thr_fid = thr_fid
        self.robot: dict[tuple[int, int], float] = {}
        self.fid: dict[tuple[int, int], float] = {}
        self.ok = False

    def update(self, check) -> None:
        """Record one round's checker report (its pairs, and its collisions' minima)."""
        for (a, b), d in zip(check.pair_ids.tolist(), check.pair_min_distance_mm.tolist()):
            self.robot[(min(a, b), max(a, b))] = d
        for (a, f), d in zip(check.fiducial_pair_ids.tolist(),
                             check.fiducial_min_distance_mm.tolist()):
            self.fid[(a, f)] = d
        for c in check.collisions:
            table = self.robot if c.kind == "robot" else self.fid
            key = (min(c.robot_a, c.other), max(c.robot_a, c.other)) if c.kind == "robot" \
                else (c.robot_a, c.other)
            table[key] = min(table.get(key, math.inf), c.min_distance_mm)
        self.ok = check.ok

    def min_clearance(self) -> float:
        """Smallest clearance over every pair ever checked, mm (inf if none)."""
        vals = [d - self.thr_robot for d in self.robot.values()]
        vals += [d - self.thr_fid for d in self.fid.values()]
        return float(min(vals)) if vals else math.inf


def verify_neighbours(geom: ArrayGeometry, verify_buffer: float):
    """Sparse (n, n) adjacency of robots that the checker pairs at either buffer."""
    from scipy.sparse import csr_matrix
    from scipy.spatial import cKDTree

    spec = geom.spec
    reach = 2.0 * max(spec.collision_reach_mm(verify_buffer), spec.collision_reach_mm(geom.buffer_mm))
    xy = np.asarray(geom.base_xy)
    pr = cKDTree(xy).query_pairs(reach + 1e-6, output_type="ndarray") if len(xy) > 1 \
        else np.zeros((0, 2), dtype=np.int64)
    n = xy.shape[0]
    rows = np.concatenate([pr[:, 0], pr[:, 1]])
    cols = np.concatenate([pr[:, 1], pr[:, 0]])
    return csr_matrix((np.ones(rows.size, dtype=np.int64), (rows, cols)), shape=(n, n))


def subset_trajectory(traj: Trajectory, sel: np.ndarray) -> Trajectory:
    """The robots ``sel`` (indices) of ``traj``."""
    return Trajectory(traj.robot_ids[sel],
                      tuple(tuple(traj.times[ax][i] for i in sel) for ax in range(2)),
                      tuple(tuple(traj.angles[ax][i] for i in sel) for ax in range(2)))


def repair(collisions, labels: np.ndarray, id_index: dict, window: np.ndarray, tol: np.ndarray,
           pre: np.ndarray) -> tuple[set, set, int, int]:
    """Answer a failed round's ``collisions`` in place (see the module docstring).

    ``labels`` (n,) group of each robot; ``id_index`` robot id -> index; ``window``,
    ``tol``, ``pre`` (n,) smoothing window (steps), RDP and pre-simplification
    tolerance (deg) per robot, each halved at most down to its floor (the
    pre-simplification to 0). Returns (groups to redo, robots tightened or at their
    floor, merges, robots tightened).
    """
    dirty: set = set()
    touched: set = set()
    merges = tightened = 0
    for c in collisions:
        a = id_index[c.robot_a]
        if c.kind == "robot":
            b = id_index[c.other]
            if labels[a] != labels[b]:
                # timed apart, they met at different s: one path parameter from now on
                labels[labels == labels[b]] = labels[a]
                merges += 1
                dirty.add(int(labels[a]))
                continue
            touched.update((a, b))
        else:
            touched.add(a)
    for i in touched:
        # both deviations from the plan: smoothing and simplification
        if window[i] <= _MIN_WINDOW_STEPS and tol[i] <= _MIN_TOLERANCE_DEG and pre[i] == 0.0:
            continue
        window[i] = max(_MIN_WINDOW_STEPS, window[i] / _TIGHTEN)
        tol[i] = max(_MIN_TOLERANCE_DEG, tol[i] / _TIGHTEN)
        pre[i] = pre[i] / _TIGHTEN if pre[i] / _TIGHTEN >= _MIN_TOLERANCE_DEG else 0.0
        tightened += 1
        dirty.add(int(labels[i]))
    return dirty, touched, merges, tightened
