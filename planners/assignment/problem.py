"""The assignment as a 0/1 program, and its split into independent components.

Variables: one per candidate (``x_c = 1``: the robot takes that pose). Rows (CSR over
candidate indices, each with bounds ``lo <= sum x <= hi``):

- each robot takes exactly one pose (its parking pose included): ``= 1``;
- each target at most once: ``<= 1`` (targets that two or more robots can reach);
- no two poses that collide: one clique row ``<= 1`` per (candidate, neighbour robot)
  (:mod:`rfp_twin.planners.assignment.conflicts`);
- quotas: at least ``m`` candidates of a calibration kind with targets in a region: ``>= m``.

Objective: maximise the sum of the weights (the targets' priorities) of the poses taken.

Robots joined by a row form a component; components share no row, so each is solved on
its own (the sparse fields split into many small ones; a one-robot component is its best
candidate). :class:`Problem` holds the rows; :meth:`Problem.components` splits them.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

EQ, LE, GE = 0, 1, 2


@dataclass(frozen=True)
class Rows:
    """Rows of a 0/1 program over ``n_vars`` variables.

    ptr, idx : CSR, the variables of row r are ``idx[ptr[r]:ptr[r + 1]]``
    lo, hi : (r,) float64 bounds of each row's sum
    kind : (r,) int8 EQ / LE / GE
    """

    ptr: np.ndarray
    idx: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    kind: np.ndarray

    @property
    def n_rows(self) -> int:
        return int(self.lo.size)

    @property
    def n_nonzeros(self) -> int:
        return int(self.idx.size)


@dataclass(frozen=True)
class SubProblem:
    """One component: its candidates (global indices), weights and rows (local indices)."""

    cands: np.ndarray
    weight: np.ndarray
    rows: Rows
    n_robots: int
    has_quota: bool


def _stack(parts: list[tuple[np.ndarray, np.ndarray, float, float, int]]) -> Rows:
    """Rows from blocks (ptr, idx, lo, hi, kind) of rows sharing one bound."""
    ptrs, idxs, los, his, kinds = [np.zeros(1, dtype=np.int64)], [], [], [], []
    offset = 0
    for ptr, idx, lo, hi, kind in parts:
        if ptr.size <= 1:
            continue
        ptrs.append(ptr[1:] + offset)
        idxs.append(idx)
        offset += int(ptr[-1])
        m = ptr.size - 1
        los.append(np.full(m, lo) if np.ndim(lo) == 0 else np.asarray(lo, float))
        his.append(np.full(m, hi) if np.ndim(hi) == 0 else np.asarray(hi, float))
        kinds.append(np.full(m, kind, dtype=np.int8))
    cat = (lambda xs, dt: np.concatenate(xs).astype(dt) if xs else np.zeros(0, dtype=dt))
    return Rows(np.concatenate(ptrs).astype(np.int64), cat(idxs, np.int64), cat(los, np.float64),
                cat(his, np.float64), cat(kinds, np.int8))


def ranges(starts: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """Concatenation of ``arange(s, s + l)`` for each start ``s`` and length ``l``, int64."""
    total = int(lengths.sum())
    if total == 0:
        return np.zeros(0, dtype=np.int64)
    offsets = np.zeros(lengths.size, dtype=np.int64)
    np.cumsum(lengths[:-1], out=offsets[1:])
    return (np.repeat(starts - offsets, lengths) + np.arange(total)).astype(np.int64)


def target_rows(target: np.ndarray, robot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """CSR of the candidates of each target that two or more robots can take."""
    real = np.flatnonzero(target >= 0)
    order = real[np.lexsort((real, target[real]))]
    t = target[order]
    if t.size == 0:
        return np.zeros(1, dtype=np.int64), np.zeros(0, dtype=np.int64)
    starts = np.flatnonzero(np.r_[True, t[1:] != t[:-1]])
    ends = np.r_[starts[1:], t.size]
    r = robot[order]
    # a target whose candidates are all on one robot is covered by that robot's row
    rmin = np.minimum.reduceat(r, starts)
    rmax = np.maximum.reduceat(r, starts)
    keep = rmax > rmin
    sizes = (ends - starts)[keep]
    ptr = np.zeros(sizes.size + 1, dtype=np.int64)
    np.cumsum(sizes, out=ptr[1:])
    sel = ranges(starts[keep], sizes)
    return ptr, order[sel].astype(np.int64)


@dataclass(frozen=True)
class Problem:
    """The whole assignment program (module docstring).

    robot : (c,) robot of each candidate; weight : (c,) objective coefficients
    rows : every row; n_robots : robots (robot rows come first, one per robot in order)
    n_quota : the last ``n_quota`` rows are quota rows
    """

    robot: np.ndarray
    weight: np.ndarray
    rows: Rows
    n_robots: int
    n_quota: int

    @classmethod
    def build(cls, cands, clique_ptr: np.ndarray, clique_idx: np.ndarray,
              quota_rows: list[tuple[np.ndarray, int]]) -> "Problem":
        """From candidates, conflict cliques and quota rows ``[(candidates, minimum)]``."""
        n = cands.ptr.size - 1
        robot_ptr = cands.ptr.astype(np.int64)
        robot_idx = np.arange(cands.n, dtype=np.int64)
        tp, ti = target_rows(cands.target, cands.robot)
        parts = [(robot_ptr, robot_idx, 1.0, 1.0, EQ), (tp, ti, 0.0, 1.0, LE),
                 (clique_ptr, clique_idx, 0.0, 1.0, LE)]
        for members, minimum in quota_rows:
            parts.append((np.array([0, members.size], dtype=np.int64),
                          np.asarray(members, dtype=np.int64), float(minimum), np.inf, GE))
        return cls(cands.robot, cands.weight, _stack(parts), n, len(quota_rows))

    def components(self) -> tuple[int, np.ndarray]:
        """(number of components, (n_robots,) component label of each robot)."""
        rows = self.rows
        sizes = np.diff(rows.ptr)
        first = np.repeat(self.robot[rows.idx[rows.ptr[:-1]]], sizes) if rows.idx.size else \
            np.zeros(0, dtype=np.int64)
        other = self.robot[rows.idx]
        g = coo_matrix((np.ones(first.size, dtype=np.int8), (first, other)),
                       shape=(self.n_robots, self.n_robots))
        return connected_components(g, directed=False)

    def split(self) -> list[SubProblem]:
        """The independent components as sub-problems (local candidate indices)."""
        n_comp, label = self.components()
        rows = self.rows
        row_label = label[self.robot[rows.idx[rows.ptr[:-1]]]]
        cand_label = label[self.robot]
        cand_order = np.argsort(cand_label, kind="stable")
        cand_starts = np.searchsorted(cand_label[cand_order], np.arange(n_comp + 1))
        row_order = np.argsort(row_label, kind="stable")
        row_starts = np.searchsorted(row_label[row_order], np.arange(n_comp + 1))
        local = np.empty(self.robot.size, dtype=np.int64)
        robots_per = np.bincount(label, minlength=n_comp)
        quota_first = rows.n_rows - self.n_quota
        out = []
        for c in range(n_comp):
            cands = cand_order[cand_starts[c]:cand_starts[c + 1]]
            local[cands] = np.arange(cands.size)
            rsel = row_order[row_starts[c]:row_starts[c + 1]]
            lens = rows.ptr[rsel + 1] - rows.ptr[rsel]
            ptr = np.zeros(rsel.size + 1, dtype=np.int64)
            np.cumsum(lens, out=ptr[1:])
            gather = ranges(rows.ptr[rsel], lens)
            sub = Rows(ptr, local[rows.idx[gather]], rows.lo[rsel], rows.hi[rsel],
                       rows.kind[rsel])
            out.append(SubProblem(cands, self.weight[cands], sub, int(robots_per[c]),
                                  bool(np.any(rsel >= quota_first))))
        return out
