"""The dense 2D check of every candidate pair: :func:`check_pairs` (numba, pairs in parallel).

Inputs are plain arrays: per pair ``(i, j)`` robot indices (``j = -1`` for an obstacle,
the segment ``(fx, fy)``-``(ex, ey)``, mm, a point when both ends are equal) and its
threshold (mm); the bases (mm); per robot its own alpha arm length, beta collision
segment start / end and ``r_max`` ((n,) mm,
:func:`rfp_twin.validation.checker2d.speeds.robot_arms`); the trajectory as per-axis
CSR arrays (:func:`rfp_twin.validation.numerics.axis_csr`, angles rad, |slope| rad/s);
per robot the largest and the mean point speed of its collision segment (mm/s,
:mod:`rfp_twin.validation.checker2d.speeds`). Times in s.

*Interval bound.* ``D`` (the segment distance of a pair) is Lipschitz with ``L = V_i +
V_j`` (:mod:`rfp_twin.validation.checker2d.speeds`). On ``[t0, t1]``, ``h = t1 - t0``, with
sampled ``D0 = D(t0)`` and ``D1 = D(t1)``: ``D(t) >= max(D0 - L (t - t0), D1 - L (t1 -
t))``. The right side is smallest where the two lines cross, so for every ``t`` in the
interval::

    D(t) >= (D0 + D1 - L h) / 2 =: lb

If ``lb > threshold`` the whole interval is provably clear.

Algorithm (per candidate pair)
------------------------------
1. Coarse grid. The uniform grid on ``[T0, T1]`` (both ends included) has ``n =
   ceil((T1 - T0) L_m / (2 buffer))`` intervals, i.e. spacing ``h0 <= 2 buffer / L_m``,
   where ``L_m = Vm_i + Vm_j`` is the pair's speed bound with each axis' *mean* |slope|
   over the span in place of its largest. Where the robots move at their typical speed
   the largest slack of the bound, ``L h0 / 2``, is then at most one buffer, so an
   interval whose two ends are both at least one buffer clear of the threshold is
   cleared at once. Using the mean rather than the largest slope keeps one fast blip of
   one robot from forcing a fine grid over the whole span: the bisection below adapts to
   it locally. Static pairs get one interval; ``n`` is capped at ``(T1 - T0) /
   resolution_s``. The grid only sets where refinement starts; the guarantee below does
   not depend on it.
2. Bisection (in time order, depth first). An interval whose two ends are clear is
   bisected while its bound ``lb`` (computed first with the largest speeds of the
   whole trajectory, ``L_g = V_i + V_j``, and, when that does not clear it, with the
   *local* speeds of the window, which are never larger) is ``<= threshold``; once it is
   no longer than ``resolution_s`` and still not cleared it is reported as a collision
   anyway (``Collision.conservative = True``; its ``min_distance_mm`` is then the bound
   ``max(lb, 0)``). An interval with one colliding end is bisected down to
   ``resolution_s`` to locate the start/end of the collision. An interval whose two
   ends collide is bisected (down to ``resolution_s``) only while the mirror upper
   bound ``(D0 + D1 + L h) / 2`` exceeds the threshold, i.e. while a brief exit from
   collision inside it cannot be ruled out; otherwise it is in collision throughout.
3. Minimum refinement. A clear interval is also bisected while ``lb < best - tol``,
   ``tol = distance_tol_mm + distance_rel_tol * max(best - threshold, 0)`` (``best``:
   the pair's smallest sampled distance so far). ``best`` only decreases, so every
   interval that is left has ``lb >= best_final - tol``: the reported per-pair minimum
   (the smallest *sampled* distance, an upper bound of the true one) is within ``tol``
   of the true minimum (up to ``L resolution_s / 2`` where the resolution limit
   stopped the bisection). Pairs near the threshold are thus exact to about
   ``distance_tol_mm``; far pairs, whose distance may stay flat for long stretches,
   are not refined needlessly.

Colliding samples and colliding intervals of a pair that are at most ``resolution_s``
apart are merged into one collision row with ``t_start`` / ``t_end`` the first / last
colliding sample (or the ends of a conservative interval), accurate to
``resolution_s``. ``conservative`` is set only when no sample of the run collided.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from rfp_twin.models.kernel_cache import DELIVERY, warm_up
from rfp_twin.validation.numerics import (STACK, beta_segment, interp_angle, max_rate, push,
                                 push_halves, segment_distance)

#: Upper bound on coarse intervals per pair (memory guard; refinement keeps it safe).
MAX_COARSE = 10_000_000


@njit(cache=True)
def _local_speed(i, t0, t1, la, rmax, pa, ta, ra, pb, tb, rb):
    """Bound on the point speed (mm/s) of robot ``i``'s collision segment on (t0, t1);
    ``la``, ``rmax``: (n,) mm, each robot's alpha arm length and ``r_max``."""
    A = max_rate(pa, ta, ra, i, t0, t1)
    B = max_rate(pb, tb, rb, i, t0, t1)
    return la[i] * A + rmax[i] * (A + B)


@njit(cache=True)
def _pair_distance(i, j, fx, fy, ex, ey, t, bx, by, la, s0, s1, pa, ta, aa, pb, tb, ab):
    """Segment distance of robot ``i`` to robot ``j`` (or, if j < 0, to the obstacle
    segment (fx, fy)-(ex, ey)) at time ``t``, mm; ``la``, ``s0``, ``s1``: (n,) per robot."""
    p0x, p0y, p1x, p1y = beta_segment(bx[i], by[i], interp_angle(pa, ta, aa, i, t),
                                      interp_angle(pb, tb, ab, i, t), la[i], s0[i], s1[i])
    if j < 0:
        return segment_distance(p0x, p0y, p1x, p1y, fx, fy, ex, ey)
    q0x, q0y, q1x, q1y = beta_segment(bx[j], by[j], interp_angle(pa, ta, aa, j, t),
                                      interp_angle(pb, tb, ab, j, t), la[j], s0[j], s1[j])
    return segment_distance(p0x, p0y, p1x, p1y, q0x, q0y, q1x, q1y)


@njit(cache=True)
def n_intervals(span, speed, slack, resolution):
    """Coarse intervals on a span: spacing <= slack / speed, >= ~resolution."""
    if span <= 0.0:
        return 0
    n_max = math.ceil(span / resolution)
    if n_max > MAX_COARSE:
        n_max = MAX_COARSE
    if speed <= 0.0:
        return 1
    x = span * speed / slack
    if x >= n_max:
        return max(int(n_max), 1)
    return max(int(math.ceil(x)), 1)


@njit(cache=True)
def _add_item(coll, nc, run, p, start, end, d, td, is_sample, gap):
    """Add one colliding item (sample or interval) of pair ``p`` to the open run.

    ``run``: [open, t_start, t_end, d_min, t_min, has_sample]. Items that start at most
    ``gap`` after the open run ends extend it; otherwise the run is flushed first.
    """
    if run[0] != 0.0 and start > run[2] + gap:
        coll, nc = _flush(coll, nc, run, p)
    if run[0] == 0.0:
        run[0] = 1.0
        run[1] = start
        run[3] = np.inf
        run[5] = 0.0
    run[2] = end
    if d < run[3]:
        run[3] = d
        run[4] = td
    if is_sample:
        run[5] = 1.0
    return coll, nc


@njit(cache=True)
def _flush(coll, nc, run, p):
    if run[0] == 0.0:
        return coll, nc
    if nc == coll.shape[0]:
        grown = np.empty((2 * nc + 8, 6))
        grown[:nc] = coll[:nc]
        coll = grown
    # conservative: no colliding sample
    coll[nc] = (float(p), run[1], run[2], run[4], run[3], 1.0 if run[5] == 0.0 else 0.0)
    run[0] = 0.0
    return coll, nc + 1


@njit(cache=True)
def _check_pair(p, pi, pj, pfx, pfy, pex, pey, thr, bx, by, la, s0, s1, rmax,
                pa, ta, aa, ra, pb, tb, ab, rb, vglob, vmean,
                t_lo, t_hi, slack, resolution, tol, rel_tol, st, run, coll, nc, record):
    """The dense check of pair ``p`` (arguments as :func:`check_pairs`; ``st`` (STACK, 4)
    and ``run`` (6,) scratch). With ``record`` its collision runs are appended to ``coll``
    (from row ``nc``); without, only whether it has any is returned.

    Returns (pair minimum mm, its time s, samples taken, coll, nc, any collision).
    """
    span = t_hi - t_lo
    i = pi[p]
    j = pj[p]
    fx = pfx[p]
    fy = pfy[p]
    ex = pex[p]
    ey = pey[p]
    th = thr[p]
    lg = vglob[i] + (vglob[j] if j >= 0 else 0.0)
    lm = vmean[i] + (vmean[j] if j >= 0 else 0.0)
    run[0] = 0.0
    any_hit = False
    n_int = n_intervals(span, lm, slack, resolution)
    if n_int == 0:
        d = _pair_distance(i, j, fx, fy, ex, ey, t_lo, bx, by, la, s0, s1, pa, ta, aa, pb, tb, ab)
        if d <= th:
            any_hit = True
            if record:
                coll, nc = _add_item(coll, nc, run, p, t_lo, t_lo, d, t_lo, True, resolution)
        if record:
            coll, nc = _flush(coll, nc, run, p)
        return d, t_lo, 1, coll, nc, any_hit
    n_samples = 0
    tc = np.empty(n_int + 1)
    dc = np.empty(n_int + 1)
    best = np.inf
    tbest = t_lo
    for k in range(n_int + 1):
        t = t_lo + span * (k / n_int) if k < n_int else t_hi
        tc[k] = t
        d = _pair_distance(i, j, fx, fy, ex, ey, t, bx, by, la, s0, s1, pa, ta, aa, pb, tb, ab)
        dc[k] = d
        if d < best:
            best = d
            tbest = t
    n_samples += n_int + 1
    for k in range(n_int):
        top = push(st, 0, tc[k], tc[k + 1], dc[k], dc[k + 1])
        while top > 0:
            top -= 1
            a, b, da, db = st[top, 0], st[top, 1], st[top, 2], st[top, 3]
            h = b - a
            ca = da <= th
            cb = db <= th
            split = False
            unresolved = False
            lb = 0.0
            loc = lg
            if ca and cb:
                # upper bound: D(t) <= (D0 + D1 + L h) / 2; split while an exit
                # from collision inside the interval cannot be ruled out
                if h > resolution and 0.5 * (da + db + lg * h) > th:
                    loc = _local_speed(i, a, b, la, rmax, pa, ta, ra, pb, tb, rb)
                    if j >= 0:
                        loc += _local_speed(j, a, b, la, rmax, pa, ta, ra, pb, tb, rb)
                    split = 0.5 * (da + db + loc * h) > th
            elif ca or cb:
                split = h > resolution
            else:
                lb = 0.5 * (da + db - lg * h)
                want = best - tol - rel_tol * max(best - th, 0.0)
                if lb <= th or lb < want:
                    loc = _local_speed(i, a, b, la, rmax, pa, ta, ra, pb, tb, rb)
                    if j >= 0:
                        loc += _local_speed(j, a, b, la, rmax, pa, ta, ra, pb, tb, rb)
                    lb = 0.5 * (da + db - loc * h)
                    if lb <= th:
                        if h > resolution:
                            split = True
                        else:
                            unresolved = True
                    elif lb < want and h > resolution:
                        split = True
            if split and top + 2 <= STACK:
                m = a + 0.5 * h
                dm = _pair_distance(i, j, fx, fy, ex, ey, m, bx, by, la, s0, s1,
                                    pa, ta, aa, pb, tb, ab)
                n_samples += 1
                if dm < best:
                    best = dm
                    tbest = m
                top = push_halves(st, top, a, m, b, da, dm, db)
                continue
            if split:               # stack exhausted (cannot happen in practice)
                unresolved = (not (ca or cb)) and lb <= th
            # terminal interval [a, b]: its left sample, then the interval itself
            if ca or unresolved:
                any_hit = True
            if not record:
                continue
            if ca:
                coll, nc = _add_item(coll, nc, run, p, a, a, da, a, True, resolution)
            if ca and cb:
                coll, nc = _add_item(coll, nc, run, p, a, b, np.inf, a, False, resolution)
            elif unresolved:
                # time where the bound is lowest, clipped to the interval
                tl = a + 0.5 * h
                if loc > 0.0:
                    tl = min(max(tl + (da - db) / (2.0 * loc), a), b)
                coll, nc = _add_item(coll, nc, run, p, a, b, max(lb, 0.0), tl, False,
                                     resolution)
    if dc[n_int] <= th:
        any_hit = True
        if record:
            coll, nc = _add_item(coll, nc, run, p, t_hi, t_hi, dc[n_int], t_hi, True, resolution)
    if record:
        coll, nc = _flush(coll, nc, run, p)
    return best, tbest, n_samples, coll, nc, any_hit


@njit(cache=True, parallel=True)
def _scan_pairs(pi, pj, pfx, pfy, pex, pey, thr, bx, by, la, s0, s1, rmax,
                pa, ta, aa, ra, pb, tb, ab, rb, vglob, vmean,
                t_lo, t_hi, slack, resolution, tol, rel_tol):
    """Every pair checked in parallel, nothing recorded: (pair_min, pair_tmin,
    samples per pair, any collision per pair)."""
    n_p = pi.shape[0]
    pmin = np.full(n_p, np.inf)
    ptmin = np.zeros(n_p)
    ns = np.zeros(n_p, dtype=np.int64)
    hit = np.zeros(n_p, dtype=np.bool_)
    for p in prange(n_p):
        st = np.empty((STACK, 4))
        run = np.zeros(6)
        none = np.empty((1, 6))
        d, td, k, _, _, h = _check_pair(p, pi, pj, pfx, pfy, pex, pey, thr, bx, by, la, s0,
                                        s1, rmax, pa, ta, aa, ra, pb, tb, ab, rb, vglob,
                                        vmean, t_lo, t_hi, slack, resolution, tol, rel_tol,
                                        st, run, none, 0, False)
        pmin[p] = d
        ptmin[p] = td
        ns[p] = k
        hit[p] = h
    return pmin, ptmin, ns, hit


@njit(cache=True)
def _record_pairs(pairs, pi, pj, pfx, pfy, pex, pey, thr, bx, by, la, s0, s1, rmax,
                  pa, ta, aa, ra, pb, tb, ab, rb, vglob, vmean,
                  t_lo, t_hi, slack, resolution, tol, rel_tol):
    """The collision rows (k, 6) of the pairs ``pairs`` (indices), checked again in order."""
    coll = np.empty((8, 6))
    nc = 0
    st = np.empty((STACK, 4))
    run = np.zeros(6)
    for q in range(pairs.shape[0]):
        _, _, _, coll, nc, _ = _check_pair(pairs[q], pi, pj, pfx, pfy, pex, pey, thr, bx, by,
                                           la, s0, s1, rmax, pa, ta, aa, ra, pb, tb, ab, rb,
                                           vglob, vmean, t_lo, t_hi, slack, resolution, tol,
                                           rel_tol, st, run, coll, nc, True)
    return coll[:nc]


def check_pairs(pi, pj, pfx, pfy, pex, pey, thr, bx, by, la, s0, s1, rmax,
                pa, ta, aa, ra, pb, tb, ab, rb, vglob, vmean,
                t_lo, t_hi, slack, resolution, tol, rel_tol):
    """Dense check of every pair. Returns (pair_min, pair_tmin, n_samples, coll (k, 6)).

    ``pfx, pfy, pex, pey`` (pairs,): the obstacle segment of a pair with ``pj < 0``, mm;
    ``la, s0, s1, rmax`` (n,): each robot's arm, mm (see the module docstring).

    ``coll`` rows: pair index, t_start, t_end, t_min, d_min, conservative (0/1), in pair
    order. The pairs are checked in parallel (numba threads); the few pairs with a
    collision are checked again, the same way, to record their collision runs.
    """
    args = (pi, pj, pfx, pfy, pex, pey, thr, bx, by, la, s0, s1, rmax,
            pa, ta, aa, ra, pb, tb, ab, rb, vglob, vmean,
            float(t_lo), float(t_hi), float(slack), float(resolution), float(tol), float(rel_tol))
    pmin, ptmin, ns, hit = _scan_pairs(*args)
    coll = _record_pairs(np.flatnonzero(hit).astype(np.int64), *args)
    return pmin, ptmin, int(ns.sum()), coll


# called from Python once the planner has run (loaded ahead from numba's cache)
warm_up(DELIVERY, _scan_pairs, _record_pairs)
