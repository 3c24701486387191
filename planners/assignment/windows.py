"""Large-neighbourhood improvement: re-solve windows of the plane exactly, the rest held.

For components too large for the exact solver, the heuristic's assignment is improved
window by window: the robots whose bases fall in one cell of a square grid (about
``window_robots`` robots per cell) are freed, every other robot keeps its pose, and the
window's best poses are found exactly (HiGHS) among the candidates that collide with no
held pose and whose targets no held robot has. A window's new poses replace the old ones
only when they weigh more, so the objective never falls. Sweeps alternate the grid's
offset by half a cell so that no cell border stays a border.
"""
from __future__ import annotations

import time

import numpy as np
from numba import njit

from rfp_twin.planners.assignment.problem import EQ, LE, Rows, SubProblem
from rfp_twin.planners.assignment.solvers import solve_highs

#: Robots per window (a cell of the grid), on average.
WINDOW_ROBOTS = 60


def conflict_csr(a: np.ndarray, b: np.ndarray, n_cands: int) -> tuple[np.ndarray, np.ndarray]:
    """Symmetric CSR (ptr (c + 1,), idx) of the conflict pairs ``(a, b)``."""
    rows = np.concatenate([a, b])
    cols = np.concatenate([b, a])
    order = np.argsort(rows, kind="stable")
    ptr = np.searchsorted(rows[order], np.arange(n_cands + 1)).astype(np.int64)
    return ptr, cols[order].astype(np.int64)


@njit(cache=True)
def _local_pairs(cand, keep, conf_ptr, conf_idx, local, out):
    """Conflict pairs ``(q, local[d])``, ``q < local[d]``, among the kept candidates of a
    window; the k-th is written to ``out[k]`` while it has room ((0, 2) ``out``: count
    only). Returns the number of pairs."""
    count = 0
    for q in range(cand.shape[0]):
        if not keep[q]:
            continue
        c = cand[q]
        for m in range(conf_ptr[c], conf_ptr[c + 1]):
            d = conf_idx[m]
            if local[d] > q:
                if count < out.shape[0]:
                    out[count, 0] = q
                    out[count, 1] = local[d]
                count += 1
    return count


@njit(cache=True)
def _window_rows(cand, robot, target, in_win, chosen, holder, conf_ptr, conf_idx, local):
    """Candidates of a window that may be taken, and the conflict pairs among them.

    cand : (k,) candidate indices of the window's robots; in_win : (n,) bool;
    local : (c,) int64 scratch, -1 outside the window (restored on return).
    Returns (keep (k,) bool, pairs (p, 2) int64 in local indices of ``cand``)."""
    k = cand.shape[0]
    keep = np.ones(k, dtype=np.bool_)
    for q in range(k):
        c = cand[q]
        t = target[c]
        if t >= 0 and holder[t] >= 0 and not in_win[holder[t]]:
            keep[q] = False
            continue
        for m in range(conf_ptr[c], conf_ptr[c + 1]):
            d = conf_idx[m]
            r = robot[d]
            if not in_win[r] and chosen[r] == d:
                keep[q] = False
                break
    for q in range(k):
        if keep[q]:
            local[cand[q]] = q
    pairs = np.empty((_local_pairs(cand, keep, conf_ptr, conf_idx, local,
                                   np.empty((0, 2), dtype=np.int64)), 2), dtype=np.int64)
    _local_pairs(cand, keep, conf_ptr, conf_idx, local, pairs)
    for q in range(k):
        local[cand[q]] = -1
    return keep, pairs


def _sub_problem(cands, sel: np.ndarray, pairs: np.ndarray) -> SubProblem:
    """The window's 0/1 program over candidates ``sel`` (global indices, grouped by robot)
    with conflict ``pairs`` (local indices)."""
    robot = cands.robot[sel]
    starts = np.flatnonzero(np.r_[True, robot[1:] != robot[:-1]])
    robot_ptr = np.r_[starts, sel.size].astype(np.int64)
    tgt = cands.target[sel]
    real = np.flatnonzero(tgt >= 0)
    order = real[np.argsort(tgt[real], kind="stable")]
    t = tgt[order]
    bounds = np.flatnonzero(np.r_[True, t[1:] != t[:-1], True]) if t.size else np.zeros(1, int)
    groups = [order[s:e] for s, e in zip(bounds[:-1], bounds[1:]) if e - s > 1]
    n_rob = robot_ptr.size - 1
    ptr = [robot_ptr]
    idx = [np.arange(sel.size, dtype=np.int64)]
    off = int(robot_ptr[-1])
    extra_ptr = []
    for g in groups:
        idx.append(g.astype(np.int64))
        off += g.size
        extra_ptr.append(off)
    if pairs.size:
        idx.append(pairs.reshape(-1))
        extra_ptr.extend(off + 2 * np.arange(1, pairs.shape[0] + 1))
    all_ptr = np.concatenate([robot_ptr, np.asarray(extra_ptr, dtype=np.int64)])
    m = all_ptr.size - 1
    kind = np.full(m, LE, dtype=np.int8)
    kind[:n_rob] = EQ
    lo = np.zeros(m)
    lo[:n_rob] = 1.0
    rows = Rows(all_ptr, np.concatenate(idx), lo, np.ones(m), kind)
    return SubProblem(sel, cands.weight[sel], rows, n_rob, False)


def improve_windows(cands, chosen: np.ndarray, base_xy: np.ndarray, n_targets: int,
                    a: np.ndarray, b: np.ndarray, *, robots: np.ndarray | None = None,
                    window_robots: int = WINDOW_ROBOTS, sweeps: int = 2,
                    time_limit_s: float = 20.0) -> dict:
    """Improve ``chosen`` (n,) in place window by window (module docstring).

    robots : the robots that may change (default all); a, b : conflict pairs.
    Returns {"windows": solved, "improved": windows that gained, "gain": weight gained,
    "seconds": wall time}."""
    t0 = time.perf_counter()
    n = chosen.size
    movable = np.ones(n, dtype=bool) if robots is None else np.zeros(n, dtype=bool)
    if robots is not None:
        movable[robots] = True
    conf_ptr, conf_idx = conflict_csr(a, b, cands.n)
    holder = np.full(max(n_targets, 1), -1, dtype=np.int64)
    on = cands.target[chosen] >= 0
    holder[cands.target[chosen[on]]] = np.flatnonzero(on)
    pts = base_xy[movable]
    idx_movable = np.flatnonzero(movable)
    span = pts.max(axis=0) - pts.min(axis=0) if pts.size else np.zeros(2)
    area = max(float(span[0] * span[1]), 1e-9)
    cell = max(np.sqrt(area * window_robots / max(pts.shape[0], 1)), 1e-6)
    local = np.full(cands.n, -1, dtype=np.int64)
    stats = {"windows": 0, "improved": 0, "gain": 0.0}
    for sweep in range(sweeps):
        shift = 0.5 * cell * (sweep % 2)
        key = np.floor((pts - pts.min(axis=0) + shift) / cell).astype(np.int64)
        cell_id = key[:, 0] * (int(key[:, 1].max(initial=0)) + 2) + key[:, 1]
        order = np.argsort(cell_id, kind="stable")
        cuts = np.flatnonzero(np.r_[True, cell_id[order][1:] != cell_id[order][:-1], True])
        for s, e in zip(cuts[:-1], cuts[1:]):
            if time.perf_counter() - t0 > time_limit_s:
                break
            win = np.sort(idx_movable[order[s:e]])
            if win.size < 2:
                continue
            in_win = np.zeros(n, dtype=bool)
            in_win[win] = True
            cand = np.concatenate([np.arange(cands.ptr[r], cands.ptr[r + 1]) for r in win])
            keep, pairs = _window_rows(cand, cands.robot, cands.target, in_win, chosen, holder,
                                       conf_ptr, conf_idx, local)
            # the current poses are always allowed (they clear every held pose)
            sel = cand[keep]
            remap = np.cumsum(keep) - 1
            sub = _sub_problem(cands, sel, remap[pairs] if pairs.size else pairs)
            now = float(cands.weight[chosen[win]].sum())
            sol = solve_highs(sub, time_limit_s=max(0.05, time_limit_s - (time.perf_counter() - t0)))
            stats["windows"] += 1
            if sol.status not in ("optimal", "feasible") or sol.objective <= now + 1e-9:
                continue
            taken = sel[sol.x]
            for r in win:
                t = cands.target[chosen[r]]
                if t >= 0 and holder[t] == r:
                    holder[t] = -1
            chosen[cands.robot[taken]] = taken
            tt = cands.target[taken]
            holder[tt[tt >= 0]] = cands.robot[taken][tt >= 0]
            stats["improved"] += 1
            stats["gain"] += sol.objective - now
    stats["seconds"] = time.perf_counter() - t0
    return stats
