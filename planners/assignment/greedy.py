"""The fast assignment heuristic: greedy by priority, then local improvement (numba).

Greedy: target candidates in order of decreasing weight (ties: fewer robots that can
take the target first, then catalogue order); a candidate is taken when its robot is
still parked, its target is free, and its pose keeps clear of every neighbour's current
pose (a parked neighbour's fold included), so the assignment is feasible at every step.

Local improvement (repeated sweeps until nothing changes or ``max_sweeps``): for each
robot and each of its candidates worth more than its current pose: take it when its
target is free and it collides with no neighbour; when exactly one other robot ``j`` is
in the way (``j`` holds the target, or ``j``'s pose collides with the new one), look for
another pose of ``j`` (a free target, the one the first robot lets go, or its parking)
clear of the new pose and of ``j``'s other neighbours, and make both moves when the sum
of the two weights grows. Each accepted move raises the objective, so the sweeps end.

Ejection moves (:func:`eject_kernel`) then let one robot give way, even to a lighter
pose, when its neighbours gain more; the two kinds of moves alternate until neither
gains.

Robots are indices, candidates as :class:`rfp_twin.planners.assignment.candidates.Candidates`.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from rfp_twin.models.geometry2d import segments_within


@njit(cache=True, inline="always")
def _clash(seg, a, b, r):
    return segments_within(seg[a, 0], seg[a, 1], seg[a, 2], seg[a, 3],
                           seg[b, 0], seg[b, 1], seg[b, 2], seg[b, 3], r)


@njit(cache=True)
def _clear_of_neighbours(seg, i, a, chosen, nbr_ptr, nbr_idx, buffer, margin, skip):
    """True when candidate ``a`` of robot ``i`` clears every neighbour's current pose
    (neighbour ``skip`` ignored; -1: none)."""
    for q in range(nbr_ptr[i], nbr_ptr[i + 1]):
        j = nbr_idx[q]
        if j == skip:
            continue
        if _clash(seg, a, chosen[j], buffer[i] + buffer[j] + margin):
            return False
    return True


@njit(cache=True)
def _holders(target, chosen, n_targets):
    """(max(n_targets, 1),) int64: the robot whose ``chosen`` pose takes each target (-1: none)."""
    holder = np.full(max(n_targets, 1), -1, dtype=np.int64)
    for i in range(chosen.shape[0]):
        if target[chosen[i]] >= 0:
            holder[target[chosen[i]]] = i
    return holder


@njit(cache=True)
def greedy_kernel(seg, robot, target, weight, ptr, order, n_targets, nbr_ptr, nbr_idx, buffer,
                  margin, chosen, allowed, limit=-1):
    """Greedy pass over ``order`` (candidate indices): fills ``chosen`` (n,) with one
    candidate per robot (start: parking). ``allowed`` (c,) bool: candidates it may take;
    ``limit``: stop after taking that many (-1: no limit). Returns the number taken."""
    taken = np.zeros(n_targets, dtype=np.bool_)
    for i in range(chosen.shape[0]):
        if target[chosen[i]] >= 0:
            taken[target[chosen[i]]] = True
    count = 0
    for k in range(order.shape[0]):
        if count == limit:
            break
        a = order[k]
        i = robot[a]
        t = target[a]
        if t < 0 or not allowed[a] or target[chosen[i]] >= 0 or taken[t]:
            continue
        if _clear_of_neighbours(seg, i, a, chosen, nbr_ptr, nbr_idx, buffer, margin, -1):
            chosen[i] = a
            taken[t] = True
            count += 1
    return count


@njit(cache=True, inline="always")
def _release(i, chosen, target, holder):
    """Robot i lets go of its target (its pose is about to change)."""
    t = target[chosen[i]]
    if t >= 0 and holder[t] == i:
        holder[t] = -1


@njit(cache=True, inline="always")
def _move(i, a, chosen, target, holder):
    """Robot i takes pose a (its old target released, a's target held)."""
    _release(i, chosen, target, holder)
    chosen[i] = a
    if target[a] >= 0:
        holder[target[a]] = i


@njit(cache=True)
def _improve_move(i, a, seg, target, weight, ptr, nbr_ptr, nbr_idx, buffer, margin, chosen,
                  allowed, holder):
    """One local-improvement move (module docstring): robot ``i`` takes its candidate ``a``
    when it weighs more than its pose, moving at most one robot in the way to another
    pose. Returns True when the move was made."""
    cur = chosen[i]
    if not allowed[a] or weight[a] <= weight[cur] or a == cur:
        return False
    t = target[a]
    # the robots in the way of a: the holder of its target, and neighbours whose
    # poses collide with it; at most one may be moved
    hit = -1
    n_hit = 0
    if t >= 0 and holder[t] >= 0 and holder[t] != i:
        hit = holder[t]
        n_hit = 1
    for q in range(nbr_ptr[i], nbr_ptr[i + 1]):
        j = nbr_idx[q]
        if j == hit:
            continue
        if _clash(seg, a, chosen[j], buffer[i] + buffer[j] + margin):
            n_hit += 1
            hit = j
            if n_hit > 1:
                break
    if n_hit > 1:
        return False
    if n_hit == 0:
        _move(i, a, chosen, target, holder)
        return True
    j = hit
    cj = chosen[j]
    best = -1
    best_gain = 1e-12
    for b in range(ptr[j], ptr[j + 1]):
        if b == cj or not allowed[b]:
            continue
        tb = target[b]
        if tb >= 0 and (tb == t or (holder[tb] >= 0 and holder[tb] != j and holder[tb] != i)):
            continue
        if tb >= 0 and holder[tb] == i and tb != target[cur]:
            continue
        gain = weight[a] - weight[cur] + weight[b] - weight[cj]
        if gain <= best_gain:
            continue
        if _clash(seg, a, b, buffer[i] + buffer[j] + margin):
            continue
        if not _clear_of_neighbours(seg, j, b, chosen, nbr_ptr, nbr_idx, buffer, margin, i):
            continue
        best = b
        best_gain = gain
    if best < 0:
        return False
    _release(j, chosen, target, holder)
    _move(i, a, chosen, target, holder)
    _move(j, best, chosen, target, holder)
    return True


@njit(cache=True)
def _eject_move(j, b, seg, target, weight, ptr, nbr_ptr, nbr_idx, buffer, margin, chosen,
                allowed, holder, stack_r, stack_c):
    """One ejection move (:func:`eject_kernel`): robot ``j`` takes its candidate ``b``, then
    each neighbour its heaviest free and clear pose; undone unless the total weight grows.
    ``stack_r``, ``stack_c``: scratch for the undo. Returns True when the move was kept."""
    cj = chosen[j]
    if b == cj or not allowed[b]:
        return False
    tb = target[b]
    if tb >= 0 and holder[tb] >= 0 and holder[tb] != j:
        return False
    if not _clear_of_neighbours(seg, j, b, chosen, nbr_ptr, nbr_idx, buffer, margin, -1):
        return False
    depth = 0
    stack_r[depth] = j
    stack_c[depth] = cj
    depth += 1
    gain = weight[b] - weight[cj]
    _move(j, b, chosen, target, holder)
    for q in range(nbr_ptr[j], nbr_ptr[j + 1]):
        i = nbr_idx[q]
        ci = chosen[i]
        best = -1
        best_w = weight[ci]
        for a in range(ptr[i], ptr[i + 1]):
            if not allowed[a] or weight[a] <= best_w:
                continue
            ta = target[a]
            if ta >= 0 and holder[ta] >= 0 and holder[ta] != i:
                continue
            if not _clear_of_neighbours(seg, i, a, chosen, nbr_ptr, nbr_idx, buffer, margin, -1):
                continue
            best = a
            best_w = weight[a]
        if best >= 0:
            stack_r[depth] = i
            stack_c[depth] = ci
            depth += 1
            gain += weight[best] - weight[ci]
            _move(i, best, chosen, target, holder)
    if gain > 1e-12:
        return True
    for k in range(depth - 1, -1, -1):
        _move(stack_r[k], stack_c[k], chosen, target, holder)
    return False


@njit(cache=True)
def _sweeps(eject, seg, target, weight, ptr, n_targets, nbr_ptr, nbr_idx, buffer, margin,
            chosen, allowed, max_sweeps):
    """Sweeps over every (robot, candidate) trying one kind of move (``eject``: ejection,
    else local improvement) until a sweep changes nothing or ``max_sweeps``; returns the
    sweeps run."""
    holder = _holders(target, chosen, n_targets)
    stack_r = np.empty(nbr_idx.shape[0] + 1, dtype=np.int64)
    stack_c = np.empty(nbr_idx.shape[0] + 1, dtype=np.int64)
    sweeps = 0
    changed = True
    while changed and sweeps < max_sweeps:
        changed = False
        sweeps += 1
        for r in range(chosen.shape[0]):
            for c in range(ptr[r], ptr[r + 1]):
                if eject:
                    moved = _eject_move(r, c, seg, target, weight, ptr, nbr_ptr, nbr_idx,
                                        buffer, margin, chosen, allowed, holder, stack_r,
                                        stack_c)
                else:
                    moved = _improve_move(r, c, seg, target, weight, ptr, nbr_ptr, nbr_idx,
                                          buffer, margin, chosen, allowed, holder)
                if moved:
                    changed = True
    return sweeps


@njit(cache=True)
def improve_kernel(seg, robot, target, weight, ptr, n_targets, nbr_ptr, nbr_idx, buffer,
                   margin, chosen, allowed, max_sweeps):
    """Local improvement of ``chosen`` in place (module docstring); returns the sweeps run."""
    return _sweeps(False, seg, target, weight, ptr, n_targets, nbr_ptr, nbr_idx, buffer, margin,
                   chosen, allowed, max_sweeps)


@njit(cache=True)
def eject_kernel(seg, robot, target, weight, ptr, n_targets, nbr_ptr, nbr_idx, buffer, margin,
                 chosen, allowed, max_sweeps):
    """Ejection moves on ``chosen`` in place: a robot takes another of its poses (parking
    included) clear of its neighbours, even a lighter one, then each neighbour in turn
    takes its heaviest pose that is now free and clear; kept when the total weight grows,
    undone otherwise. Catches what the one-for-one moves of :func:`improve_kernel` miss:
    one robot's pose blocking two others. Returns the sweeps run."""
    return _sweeps(True, seg, target, weight, ptr, n_targets, nbr_ptr, nbr_idx, buffer, margin,
                   chosen, allowed, max_sweeps)


def greedy_order(cands, n_targets: int, degree: np.ndarray | None = None) -> np.ndarray:
    """Target candidates by decreasing weight, then fewest other poses excluded (the poses
    of other robots it collides with, ``degree`` (c,), plus the other candidates of its
    target), then candidate index (deterministic): the minimum-degree rule of greedy
    independent sets."""
    tgt = cands.target
    real = np.flatnonzero(tgt >= 0)
    per_target = np.bincount(tgt[real], minlength=max(n_targets, 1))
    key = per_target[tgt[real]] + (0 if degree is None else degree[real])
    order = np.lexsort((real, key, -cands.weight[real]))
    return real[order].astype(np.int64)


def greedy_assign(cands, n_targets: int, nbr_ptr: np.ndarray, nbr_idx: np.ndarray,
                  buffer: np.ndarray, margin_mm: float, *, allowed: np.ndarray | None = None,
                  degree: np.ndarray | None = None, quotas=(),
                  max_sweeps: int = 20) -> tuple[np.ndarray, int]:
    """Greedy + local improvement: ``(chosen (n,) candidate per robot, sweeps)``;
    ``degree``: see :func:`greedy_order`. ``quotas``: ``[(candidates, minimum)]`` filled
    first, fewest excluded poses first, up to each minimum; the robots that fill them
    then keep those poses."""
    allowed = np.ones(cands.n, dtype=bool) if allowed is None else allowed.copy()
    chosen = cands.parking.astype(np.int64).copy()
    key = np.zeros(cands.n) if degree is None else degree
    for members, minimum in quotas:
        order = np.asarray(members, dtype=np.int64)[np.argsort(key[members], kind="stable")]
        greedy_kernel(cands.seg, cands.robot, cands.target, cands.weight, cands.ptr, order,
                      n_targets, nbr_ptr, nbr_idx, buffer, float(margin_mm), chosen, allowed,
                      int(minimum))
    if len(quotas):
        locked = np.flatnonzero(cands.target[chosen] >= 0)
        for r in locked:
            allowed[cands.ptr[r]:cands.ptr[r + 1]] = False
        allowed[chosen[locked]] = True
    greedy_kernel(cands.seg, cands.robot, cands.target, cands.weight, cands.ptr,
                  greedy_order(cands, n_targets, degree), n_targets, nbr_ptr, nbr_idx, buffer,
                  float(margin_mm), chosen, allowed)
    args = (cands.seg, cands.robot, cands.target, cands.weight, cands.ptr, n_targets, nbr_ptr,
            nbr_idx, buffer, float(margin_mm), chosen, allowed, int(max_sweeps))
    sweeps = 0
    for _ in range(max(1, int(max_sweeps))):
        before = float(cands.weight[chosen].sum())
        sweeps += improve_kernel(*args)
        sweeps += eject_kernel(*args)
        if float(cands.weight[chosen].sum()) <= before + 1e-12:
            break
    return chosen, int(sweeps)
