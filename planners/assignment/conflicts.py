"""Pairs of candidate poses that cannot both be taken: their robots' final poses collide.

Two candidates of neighbouring robots ``i`` and ``j`` conflict when their beta collision
segments are within ``buffer_i + buffer_j + margin`` (Sayres 2021 Eq. 3 with each
robot's own buffer, plus the stepwise planners' margin: the rule the random targets of
a plan keep). Parking poses take part like any other pose. Only robot pairs whose bases
are within twice the largest collision reach plus the margin can conflict.

The conflicts of one candidate ``a`` of robot ``i`` with the candidates ``S`` of one
neighbour ``j`` form a clique ``{a} + S`` (``j`` takes at most one pose), which an exact
model states as one row ``x_a + sum(x_S) <= 1`` instead of ``|S|`` pair rows: fewer rows
and a tighter linear relaxation.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from rfp_twin.models.geometry2d import segments_within


def neighbour_pairs(geom, margin_mm: float) -> np.ndarray:
    """(p, 2) int64 robot index pairs ``i < j`` whose poses can conflict (module docstring)."""
    reach = 2.0 * geom.collision_reach + float(margin_mm)
    if geom.n_robots < 2:
        return np.empty((0, 2), dtype=np.int64)
    return geom.layout.neighbour_pairs(reach)


def symmetric_csr(a: np.ndarray, b: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """CSR ``(ptr (n + 1,), idx)`` of the index pairs ``(a[k], b[k])`` taken both ways, each
    row sorted (rows and columns: indices below ``n``)."""
    rows = np.concatenate([a, b])
    cols = np.concatenate([b, a])
    order = np.lexsort((cols, rows))
    ptr = np.searchsorted(rows[order], np.arange(n + 1)).astype(np.int64)
    return ptr, cols[order].astype(np.int64)


@njit(cache=True)
def _scan(seg, ptr, pairs, buffer, margin, degree, out_a, out_b):
    """Visit every conflicting candidate pair ``(a, b)`` of the robot ``pairs``: add 1 to
    ``degree[a]`` and ``degree[b]``, and write the k-th pair to ``out_a[k], out_b[k]`` while
    they have room (empty outputs: count only). Returns the number of pairs."""
    k = 0
    for p in range(pairs.shape[0]):
        i = pairs[p, 0]
        j = pairs[p, 1]
        r = buffer[i] + buffer[j] + margin
        for a in range(ptr[i], ptr[i + 1]):
            for b in range(ptr[j], ptr[j + 1]):
                if segments_within(seg[a, 0], seg[a, 1], seg[a, 2], seg[a, 3],
                                   seg[b, 0], seg[b, 1], seg[b, 2], seg[b, 3], r):
                    degree[a] += 1
                    degree[b] += 1
                    if k < out_a.shape[0]:
                        out_a[k] = a
                        out_b[k] = b
                    k += 1
    return k


def conflict_pairs(cands, pairs: np.ndarray, buffer: np.ndarray,
                   margin_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """Conflicting candidate pairs ``(a, b)``, two (k,) int64 arrays; ``a`` belongs to the
    lower robot of its robot pair, and the pairs come grouped by robot pair then ``a``
    (the clique grouping of the module docstring)."""
    degree = np.zeros(cands.n, dtype=np.int64)
    none = degree[:0]
    k = _scan(cands.seg, cands.ptr, pairs, buffer, float(margin_mm), degree, none, none)
    a = np.empty(k, dtype=np.int64)
    b = np.empty(k, dtype=np.int64)
    _scan(cands.seg, cands.ptr, pairs, buffer, float(margin_mm), degree, a, b)
    return a, b


def conflict_cliques(a: np.ndarray, b: np.ndarray, robot: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Cliques of :func:`conflict_pairs` (grouped output) as CSR ``(ptr, idx)``: one row
    ``{a} + {b : (a, b) conflicts, b on one robot}`` per (candidate, neighbour robot)."""
    if a.size == 0:
        return np.zeros(1, dtype=np.int64), np.zeros(0, dtype=np.int64)
    new = np.ones(a.size, dtype=bool)
    new[1:] = (a[1:] != a[:-1]) | (robot[b[1:]] != robot[b[:-1]])
    starts = np.flatnonzero(new)
    sizes = np.diff(np.append(starts, a.size)) + 1
    ptr = np.zeros(starts.size + 1, dtype=np.int64)
    np.cumsum(sizes, out=ptr[1:])
    idx = np.empty(int(ptr[-1]), dtype=np.int64)
    idx[ptr[:-1]] = a[starts]
    pos = np.arange(a.size) - np.repeat(starts, sizes - 1) + np.repeat(ptr[:-1] + 1, sizes - 1)
    idx[pos] = b
    return ptr, idx


def conflict_degrees(cands, pairs: np.ndarray, buffer: np.ndarray, margin_mm: float) -> np.ndarray:
    """(c,) int64 number of candidate poses of other robots each candidate collides with."""
    out = np.zeros(cands.n, dtype=np.int64)
    _scan(cands.seg, cands.ptr, pairs, buffer, float(margin_mm), out, out[:0], out[:0])
    return out
