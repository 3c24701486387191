"""Verification rounds of the pipeline: what they checked, what to re-check, how to repair.

A round re-checks only what changed (the verifier's reports merge the re-checks into
the whole trajectory's check). :func:`verify_neighbours` says
which robots the checker pairs (their neighbours are re-checked with them), and
:func:`subset_trajectory` cuts the trajectory to them. :func:`repair` answers a failed
round: a collision between two groups merges them (they met at different ``s``); a
collision inside a group, or with a fiducial, narrows the smoothing window of the robots
involved (by :data:`LOCAL_NARROWING` a level) on the stretch of plan steps around it (:func:`narrow_locally`, with
:func:`near_stretch` for the stretch a pair stays near contact), or along the whole path
for the spline smoothing; the RDP and pre-simplification tolerances are halved only
once the local window is at its floor (or with the spline).

Units: mm, degrees, plan steps; robots by index in layout order unless named ids.
"""
from __future__ import annotations

import math
from typing import Callable

import numpy as np

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.planners.postprocess.smoothing_local import WindowRegions
from rfp_twin.planners.postprocess.timing.grouping import pair_clearance

__all__ = ["LOCAL_NARROWING", "verify_neighbours", "subset_trajectory", "repair", "narrow_locally",
           "near_stretch"]

#: Smallest window / tolerance that tightening goes down to.
_MIN_WINDOW_STEPS = 1.0
_MIN_TOLERANCE_DEG = 1e-3
#: Factor between the windows of two narrowing levels (w, w / f, w / f^2, ...). Smaller
#: steps slow the law down less where they suffice, at the cost of more rounds.
LOCAL_NARROWING = math.sqrt(2.0)
#: A narrowed stretch of level 1 covers the steps in which the colliding pair is closer
#: than this in the plan, mm (this / f at level 2, ...), plus the reach margins of
#: :func:`narrow_locally`. 0: the collision's own steps only: a longer stretch slows the
#: time law over steps where the pair never comes close after smoothing.
_NEAR_MM = 0.0
#: Factor by which a colliding robot's window (then tolerance) shrinks per retry.
_TIGHTEN = 2.0


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
           pre: np.ndarray, regions: WindowRegions | None = None,
           step_span: Callable | None = None, pre_base: float | None = None,
           hits: np.ndarray | None = None) -> tuple[set, set, int, int]:
    """Answer a failed round's ``collisions`` in place (see the module docstring).

    ``labels`` (n,) group of each robot; ``id_index`` robot id -> index; ``window``,
    ``tol``, ``pre`` (n,) smoothing window (steps), RDP and pre-simplification
    tolerance (deg) per robot, each halved at most down to its floor (the
    pre-simplification to 0). With ``regions`` (and ``step_span(collision, margin_mm) ->
    (u0, u1)``, the plan steps around the collision in which the pair stays closer than
    ``margin_mm`` in the plan), the window is narrowed only there
    (:func:`narrow_locally`), not along the whole path. A robot whose pre-simplification
    is above ``pre_base`` (the wiggle tolerance, e.g. 0.5 deg: 0.19 mm at 22 mm, more than
    the post-processing budget) has it halved towards ``pre_base`` from its third round
    in a collision on, whatever the window does (``hits`` (n,) int counts each robot's
    rounds in a collision and is updated in place). Greedy + search at 2.5 mm, 20 seeds:
    from the first round the duration ratio p95 went 1.10 -> 1.16, from the second
    1.13, from the third 1.12 (median 1.060 unchanged); a 3.5 mm fold whose wiggly robot
    grazed a fiducial for 8 rounds passes in 3. Returns
    (groups to redo, robots tightened or at their floor, merges, robots tightened).
    """
    dirty: set = set()
    touched: dict = {}
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
            pair = (a, b)
        else:
            pair = (a,)
        for i in pair:
            touched.setdefault(i, []).append(c)
    for i, found in touched.items():
        # the smoothing deviates from the plan most: narrow its window first (around the
        # collision with regions, else along the path); the pre-simplification and RDP
        # tolerances are halved with a global window, or once the local one is at its floor
        if hits is not None:
            hits[i] += 1
        if pre_base is not None and pre[i] > pre_base and (hits is None or hits[i] >= 3):
            pre[i] = max(float(pre_base), pre[i] / _TIGHTEN)
        if regions is not None:
            narrowed = any([narrow_locally(regions, i, step_span, c, window[i]) for c in found])
        else:
            narrowed = window[i] > _MIN_WINDOW_STEPS
            window[i] = max(_MIN_WINDOW_STEPS, window[i] / _TIGHTEN)
        if regions is None or not narrowed:
            if not narrowed and tol[i] <= _MIN_TOLERANCE_DEG and pre[i] == 0.0:
                continue
            tol[i] = max(_MIN_TOLERANCE_DEG, tol[i] / _TIGHTEN)
            pre[i] = pre[i] / _TIGHTEN if pre[i] / _TIGHTEN >= _MIN_TOLERANCE_DEG else 0.0
        tightened += 1
        dirty.add(int(labels[i]))
    return dirty, set(touched), merges, tightened


def narrow_locally(regions: WindowRegions, i: int, step_span: Callable, collision,
                   window: float) -> bool:
    """Narrow robot ``i``'s window around a collision; False at the floor.

    Where the collision lies deep inside a stretch of level ``k`` (at least ``w_{k-1} / 2``
    from its ends, so every wider level is exact there), the window is narrowed once more
    by ``f = regions.factor`` (level ``k + 1``); near an end of a stretch, that stretch is extended (the chord
    corner of the wider level is what came too close). The new stretch covers the steps
    in which the pair stays within ``_NEAR_MM / f^(k-1)`` of contact in the plan (a
    corner of window ``w`` moves the path by at most ``|slope change| w / 8``, so the
    margin shrinks with the window), plus ``w_{k-1} / 2 + w_k`` on each side
    (:mod:`rfp_twin.planners.postprocess.smoothing_local`)."""
    u0, u1 = step_span(collision, 0.0)
    k = regions.level(i, u0, u1)
    f = regions.factor
    if k == 0 or regions.inside(i, u0, u1, k, 0.5 * window / f ** (k - 1)):
        k += 1
    wk = window / f ** k
    if wk < _MIN_WINDOW_STEPS:
        return False
    u0, u1 = step_span(collision, _NEAR_MM / f ** (k - 1))
    reach = 0.5 * window / f ** (k - 1) + wk
    return regions.add(i, u0 - reach, u1 + reach, k)


def near_stretch(plan, geom: ArrayGeometry, i: int, j: int, u0: float, u1: float,
                 margin_mm: float, reach_steps: float = 4000.0, stride: float = 2.0
                 ) -> tuple[float, float]:
    """``[u0, u1]`` (plan steps) widened to the stretch around it in which robots ``i`` and
    ``j`` stay closer than ``margin_mm`` in the plan (at most ``reach_steps`` each way)."""
    back = np.clip(u0 - np.arange(0.0, reach_steps, stride), 0.0, plan.n_steps)
    ahead = np.clip(u1 + np.arange(0.0, reach_steps, stride), 0.0, plan.n_steps)
    out = []
    for at in (back, ahead):
        far = np.flatnonzero(pair_clearance(plan, geom, i, j, at) >= margin_mm)
        out.append(at[far[0]] if far.size else at[-1])
    return float(out[0]), float(out[1])
