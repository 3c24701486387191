"""Presolve: drop candidate poses that another pose of the same robot dominates.

Pose ``d`` dominates pose ``c`` of the same robot when it weighs at least as much and
excludes no more: every pose of another robot that ``d`` collides with or shares a
target with, ``c`` collides with or shares a target with too (``N(d)`` is a subset of
``N(c)``), and both count for the same quota (or none). Any assignment taking ``c`` stays
feasible, and weighs no less, with ``d`` instead, so an optimum never needs ``c``. Ties
(equal weight and equal sets) keep the lower index; the relation is then a strict order,
so removing every dominated pose at once leaves an optimum (a chain of dominations ends
at a pose that stays). On the 500-robot APO fields this removes 40-50 % of the poses.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from rfp_twin.planners.assignment.conflicts import symmetric_csr


def exclusion_csr(cands, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """CSR (ptr (c + 1,), idx sorted per row) of ``N(c)``: the conflict pairs ``(a, b)`` both
    ways, plus the candidates of other robots on the same target."""
    tgt = cands.target
    real = np.flatnonzero(tgt >= 0)
    order = real[np.lexsort((real, tgt[real]))]
    ta, tb = _same_target_pairs(order, tgt[order], cands.robot[order])
    return symmetric_csr(np.concatenate([a, ta]), np.concatenate([b, tb]), cands.n)


@njit(cache=True)
def _scan_same_target(order, t, robot, out_a, out_b):
    """Visit the pairs of candidates (of different robots) on one target, ``order`` sorted
    by ``t``; the k-th pair is written to ``out_a[k], out_b[k]`` while they have room (empty
    outputs: count only). Returns the number of pairs."""
    k = 0
    m = order.shape[0]
    s = 0
    while s < m:
        e = s
        while e < m and t[e] == t[s]:
            e += 1
        for i in range(s, e):
            for j in range(i + 1, e):
                if robot[i] != robot[j]:
                    if k < out_a.shape[0]:
                        out_a[k] = order[i]
                        out_b[k] = order[j]
                    k += 1
        s = e
    return k


def _same_target_pairs(order, t, robot):
    """Pairs of candidates (of different robots) on one target: two (k,) int64 arrays."""
    none = np.zeros(0, dtype=np.int64)
    count = _scan_same_target(order, t, robot, none, none)
    out_a = np.empty(count, dtype=np.int64)
    out_b = np.empty(count, dtype=np.int64)
    _scan_same_target(order, t, robot, out_a, out_b)
    return out_a, out_b


@njit(cache=True, inline="always")
def _subset(ptr, idx, d, c):
    """True when row d of the CSR is a subset of row c (both sorted)."""
    i = ptr[d]
    j = ptr[c]
    ei = ptr[d + 1]
    ej = ptr[c + 1]
    if ei - i > ej - j:
        return False
    while i < ei:
        while j < ej and idx[j] < idx[i]:
            j += 1
        if j == ej or idx[j] != idx[i]:
            return False
        i += 1
        j += 1
    return True


@njit(cache=True)
def _dominated(cand_ptr, weight, group, ptr, idx, out):
    for r in range(cand_ptr.shape[0] - 1):
        for c in range(cand_ptr[r], cand_ptr[r + 1]):
            for d in range(cand_ptr[r], cand_ptr[r + 1]):
                if d == c or group[d] != group[c] or weight[d] < weight[c]:
                    continue
                if not _subset(ptr, idx, d, c):
                    continue
                strict = weight[d] > weight[c] or (ptr[d + 1] - ptr[d]) < (ptr[c + 1] - ptr[c])
                if strict or d < c:
                    out[c] = True
                    break


def undominated(cands, a: np.ndarray, b: np.ndarray, group: np.ndarray | None = None) -> np.ndarray:
    """(c,) bool: the poses no other pose of their robot dominates (module docstring).
    ``group`` (c,) int64: quota class of each pose (-1: none); poses dominate only within
    their class."""
    ptr, idx = exclusion_csr(cands, a, b)
    grp = np.full(cands.n, -1, dtype=np.int64) if group is None else group.astype(np.int64)
    out = np.zeros(cands.n, dtype=np.bool_)
    _dominated(cands.ptr, cands.weight, grp, ptr, idx, out)
    return ~out
