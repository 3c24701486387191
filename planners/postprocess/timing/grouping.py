"""Interaction groups: which robots must share one path parameter ``s(t)``.

Robots that come close to each other during the plan must share one ``s(t)``: then at
every instant they are at the same ``s``, so their relative configuration is the
smoothed plan's and the planner's clearance holds (up to the smoothing deviation).
Robots that never come close may be timed apart, which lets a free robot run at full
speed while a crowded group slows down for its reversals. :func:`interaction_pairs`
finds every Eq. 4 neighbour pair whose clearance ``D_ij - 2 sigma`` falls below the
interaction distance at some step of the plan (continuous in the step: it walks the
plan with strides that the pair cannot close in); those pairs are edges, and
:func:`interaction_groups` returns the connected components. A group of ``k`` robots is
one path with ``2k`` joints (:func:`rfp_twin.planners.postprocess.timing.time_group`).

The interaction distance is a heuristic, not a proof: groups timed apart are at
different ``s`` at the same instant, which the plan never checked. The post-processing
pipeline therefore re-verifies the result and merges the groups of any pair that comes
too close (:mod:`rfp_twin.planners.postprocess`).

Each robot has its own collision body: alpha length ``geom.alpha_len``, beta segment
``geom.seg_start``-``geom.seg_end`` and buffer ``geom.buffer`` ((n,) mm each); the
clearance of a pair is ``D_ij - (buffer_i + buffer_j)``.

Units: mm, degrees, plan steps. Pairs are (p, 2) robot indices in layout order.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from rfp_twin.models.geometry2d import DEG, beta_segment, segment_distance
from rfp_twin.models.kernel_cache import DELIVERY, warm_up

__all__ = ["interaction_pairs", "interaction_groups", "pair_clearance"]


@njit(cache=True, inline="always")
def _plan_angles(ptr, steps, angles, i, s, out, col):
    """Robot i of a plan (CSR breakpoints) at step s, held outside: out[col], out[col+1]."""
    k0 = ptr[i]
    k1 = ptr[i + 1]
    if s <= steps[k0] or k1 - k0 < 2:
        out[col] = angles[k0, 0]
        out[col + 1] = angles[k0, 1]
        return
    if s >= steps[k1 - 1]:
        out[col] = angles[k1 - 1, 0]
        out[col + 1] = angles[k1 - 1, 1]
        return
    # the segment [steps[lo], steps[lo + 1]) holding s (the last one for a NaN s)
    lo = min(k0 + np.searchsorted(steps[k0:k1], s, side="right") - 1, k1 - 2)
    h = steps[lo + 1] - steps[lo]
    f = (s - steps[lo]) / h if h > 0.0 else 0.0
    out[col] = angles[lo, 0] + f * (angles[lo + 1, 0] - angles[lo, 0])
    out[col + 1] = angles[lo, 1] + f * (angles[lo + 1, 1] - angles[lo, 1])


@njit(cache=True, inline="always")
def _clearance_at(ptr, steps, angles, base_xy, i, j, s, alpha_len, seg_start, seg_end, thr, q):
    """Segment distance of robots i, j in the plan at step s, minus ``thr`` (mm); q (4,)
    scratch. alpha_len, seg_start, seg_end : (n,) mm, each robot's own."""
    _plan_angles(ptr, steps, angles, i, s, q, 0)
    _plan_angles(ptr, steps, angles, j, s, q, 2)
    a0x, a0y, a1x, a1y = beta_segment(base_xy[i, 0], base_xy[i, 1], q[0], q[1],
                                      alpha_len[i], seg_start[i], seg_end[i])
    b0x, b0y, b1x, b1y = beta_segment(base_xy[j, 0], base_xy[j, 1], q[2], q[3],
                                      alpha_len[j], seg_start[j], seg_end[j])
    return segment_distance(a0x, a0y, a1x, a1y, b0x, b0y, b1x, b1y) - thr


@njit(cache=True, parallel=True, nogil=True)
def pair_clearance_below(ptr, steps, angles, n_steps, base_xy, pairs, alpha_len, seg_start,
                          seg_end, buffer, mu, margin):
    """Per pair: the smallest clearance found before it drops below ``margin`` (mm).

    alpha_len, seg_start, seg_end, buffer : (n,) mm per robot; mu : (n,) mm per step, the
    fastest a point of each robot's capsule moves.

    Walks the plan's steps with adaptive strides: at clearance ``c`` the pair cannot get
    below ``margin`` within ``(c - margin) / (mu_i + mu_j)`` steps, so those are skipped. The
    walk stops at the first sample below ``margin`` (its value is returned). A value
    ``>= margin`` is the smallest sample (an upper bound of the minimum) and proves the
    whole plan stays ``>= margin``; a value ``< margin`` only says "below". Pairs are
    walked in parallel (each on its own; the result does not depend on the threads).
    """
    p = pairs.shape[0]
    out = np.empty(p)
    for k in prange(p):
        q = np.empty(4)
        i = pairs[k, 0]
        j = pairs[k, 1]
        thr = buffer[i] + buffer[j]
        closing = mu[i] + mu[j]
        best = np.inf
        s = 0.0
        while True:
            c = _clearance_at(ptr, steps, angles, base_xy, i, j, s, alpha_len, seg_start,
                              seg_end, thr, q)
            if c < best:
                best = c
            if c < margin or s >= n_steps:
                break
            skip = math.floor((c - margin) / closing)
            if skip < 1.0:
                skip = 1.0
            s = min(s + skip, float(n_steps))
        out[k] = best
    return out


def interaction_pairs(plan, geom, margin_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """Neighbour pairs and their clearance over the plan, as far as needed, mm.

    Parameters
    ----------
    plan : Plan (executed direction), robots in ``geom`` order
    geom : ArrayGeometry (its Eq. 4 neighbour pairs; each robot's alpha length, segment
        and buffer)
    margin_mm : the interaction distance

    Returns
    -------
    pairs : (p, 2) int64 robot indices (``geom.pairs``)
    clearance : (p,) float64, mm. A pair below ``margin_mm`` at some step has a value
        below ``margin_mm`` (the first such sample). Any other pair has a value
        ``>= margin_mm`` (its smallest sample) and its clearance ``D_ij(s) - buffer_i -
        buffer_j`` is ``>= margin_mm`` over the whole plan, continuous in ``s``: every
        point of robot i's capsule moves at most ``mu_i = (alpha_len_i + 2 r_i) * step``
        per step (``r_i`` its segment's far end), so a pair closes at most ``mu_i +
        mu_j`` per step, and the walk only skips steps that cannot close the gap to
        ``margin_mm``.
    """
    pairs = np.ascontiguousarray(geom.pairs, dtype=np.int64)
    if pairs.shape[0] == 0:
        return pairs.reshape(0, 2), np.zeros(0)
    alpha_len, seg_start, seg_end = _robot_arrays(geom)
    r = np.maximum(seg_end, seg_start)
    mu = (alpha_len + 2.0 * r) * plan.step_deg * DEG
    cl = pair_clearance_below(np.ascontiguousarray(plan.path_ptr, dtype=np.int64),
                               np.ascontiguousarray(plan.path_step, dtype=np.float64),
                               np.ascontiguousarray(plan.path_angles, dtype=np.float64),
                               float(plan.n_steps), geom.base_xy, pairs, alpha_len, seg_start,
                               seg_end, np.ascontiguousarray(geom.buffer, dtype=np.float64),
                               np.ascontiguousarray(mu), float(margin_mm))
    return pairs, cl


def _robot_arrays(geom) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(alpha_len, seg_start, seg_end)`` of ``geom``, (n,) contiguous float64 mm."""
    return tuple(np.ascontiguousarray(a, dtype=np.float64)
                 for a in (geom.alpha_len, geom.seg_start, geom.seg_end))


@njit(cache=True)
def _pair_clearance_at(ptr, steps, angles, base_xy, i, j, at, alpha_len, seg_start, seg_end,
                       buffer, out):
    """out[k] = clearance of robots i, j at step at[k], mm; per-robot arrays (n,) mm."""
    q = np.empty(4)
    thr = buffer[i] + buffer[j]
    for k in range(at.size):
        out[k] = _clearance_at(ptr, steps, angles, base_xy, i, j, at[k], alpha_len, seg_start,
                               seg_end, thr, q)


def pair_clearance(plan, geom, i: int, j: int, at) -> np.ndarray:
    """Clearance ``D_ij - buffer_i - buffer_j`` of robots ``i``, ``j`` (indices) in the plan
    at steps ``at`` (k,): (k,) mm, each robot with its own alpha length and segment."""
    at = np.ascontiguousarray(np.atleast_1d(np.asarray(at, dtype=np.float64)))
    out = np.empty(at.size)
    _pair_clearance_at(np.ascontiguousarray(plan.path_ptr, dtype=np.int64),
                       np.ascontiguousarray(plan.path_step, dtype=np.float64),
                       np.ascontiguousarray(plan.path_angles, dtype=np.float64),
                       geom.base_xy, int(i), int(j), at, *_robot_arrays(geom),
                       np.ascontiguousarray(geom.buffer, dtype=np.float64), out)
    return out


def interaction_groups(n: int, edges: np.ndarray) -> np.ndarray:
    """Connected components of the graph on ``n`` robots with ``edges`` (e, 2): labels (n,)."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import connected_components

    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    g = csr_matrix((np.ones(edges.shape[0]), (edges[:, 0], edges[:, 1])), shape=(n, n))
    _, labels = connected_components(g, directed=False)
    return labels.astype(np.int64)



# called from Python once the planner has run (loaded ahead from numba's cache)
warm_up(DELIVERY, pair_clearance_below)
