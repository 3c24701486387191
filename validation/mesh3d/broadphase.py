"""The broadphase of the 3D check over time: lower bounds ``C(t)`` per link pair (numba).

Objects are the robots of the trajectory and the obstacles (``obj_rob[o]`` the robot
index, ``-1`` for an obstacle; bases ``obj_x``, ``obj_y`` mm), plus, with per-robot
geometry, robots posed in the frame of a pair (:mod:`rfp_twin.validation.mesh3d.scene`).
``la`` is every robot's alpha arm (a float) or the per-object placement tuple of
:mod:`rfp_twin.validation.mesh3d.bounds`. A link pair ``p`` is link
kind ``lp_ka[p]`` of object ``lp_oa[p]`` and ``lp_kb[p]`` of ``lp_ob[p]``. The
trajectory comes as per-axis CSR arrays (:func:`rfp_twin.validation.numerics.axis_csr`; rad,
rad/s), times in s.

Why no collision can slip between samples
-----------------------------------------
*Speed bound.* A point of a link moves at most ``rad_alpha[kind] |a'| + rad_beta[kind]
|b'|`` (:class:`rfp_twin.validation.mesh3d.links.LinkModels`). The trajectory is piecewise
linear, so on a window ``|a'|``, ``|b'|`` are at most the largest breakpoint slope
overlapping the window (:func:`rfp_twin.validation.numerics.max_rate`; zero outside the robot's
time range). Jumps have no bound and are refused when the CSR arrays are built.

*Lipschitz distance.* With ``V_A``, ``V_B`` those bounds, the distance between two
moving point sets changes at most at ``L = V_A + V_B``: ``|D(t) - D(t')| <= L |t -
t'|``. This holds for the exact distance ``D`` (any two sets) and for the bound ``C``
(capsule segments and hull vertices move like link points, radii, z intervals and slacks
are constant, ``sqrt(max(x, 0)^2 + dz^2)`` is 1-Lipschitz in ``x``, and max / min of
Lipschitz functions are Lipschitz with the same constant).

*Interval bound.* On ``[t0, t1]`` (``h = t1 - t0``) with samples ``F0``, ``F1`` of
``F = D`` or ``F = C`` (or any lower bounds of them): ``F(t) >= (F0 + F1 - L h) / 2 =:
lb``. Since ``D >= C``, ``D(t) >= max(lb_D, lb_C)`` on the interval.

Kernels
-------
:func:`capsule_min` (step 1 of :mod:`rfp_twin.validation.mesh3d.check`): per link pair, ``C`` on
a uniform grid (spacing such that the pair's mean speed moves ``coarse_mm``), then
bisection while the interval bound can be below the pair's smallest sample minus the
tolerance: ``Cmin``, its time and a certificate. :func:`capsule_suspects` (step 3): the
same bisection against a cut, keeping the intervals the bound cannot clear.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from rfp_twin.validation.mesh3d.bounds import (link_bound_at, obj_alpha, obj_plane, pair_slack,
                                               pose, store_pose_bounds_at)
from rfp_twin.validation.numerics import STACK, interp_angle, max_rate, push, push_halves

#: Upper bound on coarse intervals per link pair.
MAX_COARSE = 1_000_000


@njit(cache=True)
def link_state(o, kind, t, obj_rob, obj_x, obj_y, la, pa, ta, aa, pb, tb, ab):
    """Pose ``(theta, x, y)`` of link ``kind`` of object ``o`` at time ``t`` (``la``: the
    alpha arm(s), :mod:`rfp_twin.validation.mesh3d.bounds`)."""
    r = obj_rob[o]
    a = 0.0
    b = 0.0
    if r >= 0:
        a = interp_angle(pa, ta, aa, r, t)
        b = interp_angle(pb, tb, ab, r, t)
    th, ox, oy = pose(kind, a, b, obj_alpha(la, o))
    return th, obj_x[o] + ox, obj_y[o] + oy


@njit(cache=True, inline="always")
def pair_state(p, t, lp_oa, lp_ka, lp_ob, lp_kb, obj_rob, obj_x, obj_y, la, pa, ta, aa, pb,
               tb, ab):
    """Link pair p at time t: ``(ka, kb, theta_a, x_a, y_a, plane_a, theta_b, x_b, y_b,
    plane_b, s_xy, s_z)``, the two links' kinds, poses (rad, mm) and height planes, and the
    pair's slacks (mm)."""
    ka = lp_ka[p]
    kb = lp_kb[p]
    oa = lp_oa[p]
    ob = lp_ob[p]
    tha, xa, ya = link_state(oa, ka, t, obj_rob, obj_x, obj_y, la, pa, ta, aa, pb, tb, ab)
    thb, xb, yb = link_state(ob, kb, t, obj_rob, obj_x, obj_y, la, pa, ta, aa, pb, tb, ab)
    s_xy, s_z = pair_slack(la, p)
    return ka, kb, tha, xa, ya, obj_plane(la, oa), thb, xb, yb, obj_plane(la, ob), s_xy, s_z


@njit(cache=True)
def bound_at(p, t, lp_oa, lp_ka, lp_ob, lp_kb, obj_rob, obj_x, obj_y, la,
             pa, ta, aa, pb, tb, ab, kptr, cap, zlim, pptr, pxy, tight_below):
    """Lower bound C of the distance of link pair p at time t, mm."""
    ka, kb, tha, xa, ya, pl_a, thb, xb, yb, pl_b, s_xy, s_z = pair_state(
        p, t, lp_oa, lp_ka, lp_ob, lp_kb, obj_rob, obj_x, obj_y, la, pa, ta, aa, pb, tb, ab)
    return link_bound_at(ka, kb, tha, xa, ya, pl_a, thb, xb, yb, pl_b, s_xy, s_z, kptr, cap,
                         zlim, pptr, pxy, tight_below)


@njit(cache=True)
def _link_speed(o, kind, a, b, obj_rob, pa, ta, ra, pb, tb, rb, rad_a, rad_b):
    """Point-speed bound (mm/s) of a link of object o on the window [a, b]."""
    r = obj_rob[o]
    if r < 0 or (rad_a[kind] == 0.0 and rad_b[kind] == 0.0):
        return 0.0
    v = 0.0
    if rad_a[kind] > 0.0:
        v += rad_a[kind] * max_rate(pa, ta, ra, r, a, b)
    if rad_b[kind] > 0.0:
        v += rad_b[kind] * max_rate(pb, tb, rb, r, a, b)
    return v


@njit(cache=True)
def _n_coarse(span, speed, coarse_mm, resolution):
    if span <= 0.0 or speed <= 0.0:
        return 1
    n = math.ceil(span * speed / coarse_mm)
    cap = math.floor(span / resolution)
    if n > cap:
        n = cap
    if n > MAX_COARSE:
        n = MAX_COARSE
    if n < 1:
        n = 1
    return n


@njit(cache=True)
def _capsule_min_pair(p, lp_oa, lp_ka, lp_ob, lp_kb, obj_rob, obj_x, obj_y, la,
                      pa, ta, aa, ra, pb, tb, ab, rb, kptr, cap, zlim, pptr, pxy, rad_a, rad_b,
                      vglob, vmean, t_lo, t_hi, coarse_mm, tight_mm, resolution, thr, tol, rel,
                      st):
    """:func:`capsule_min` of link pair ``p`` with the bisection stack ``st`` (STACK, 4):
    (cmin, tmin, cert, evaluations)."""
    span = t_hi - t_lo
    n_eval = 0
    oa, ob, ka, kb = lp_oa[p], lp_ob[p], lp_ka[p], lp_kb[p]
    lg = vglob[oa, ka] + vglob[ob, kb]
    n = _n_coarse(span, vmean[oa, ka] + vmean[ob, kb], coarse_mm, resolution)
    if lg == 0.0:
        n = 1
    tbest = t_lo
    prev_t = t_lo
    prev_f = bound_at(p, t_lo, lp_oa, lp_ka, lp_ob, lp_kb, obj_rob, obj_x, obj_y, la,
                      pa, ta, aa, pb, tb, ab, kptr, cap, zlim, pptr, pxy, np.inf)
    n_eval += 1
    best = prev_f
    leaf_min = np.inf
    for g in range(1, n + 1):
        t = t_lo + span * g / n if g < n else t_hi
        f = bound_at(p, t, lp_oa, lp_ka, lp_ob, lp_kb, obj_rob, obj_x, obj_y, la,
                     pa, ta, aa, pb, tb, ab, kptr, cap, zlim, pptr, pxy, best + tight_mm)
        n_eval += 1
        if f < best:
            best = f
            tbest = t
        # refine [prev_t, t] depth first
        top = push(st, 0, prev_t, t, prev_f, f)
        while top > 0:
            top -= 1
            a, b, fa, fb = st[top, 0], st[top, 1], st[top, 2], st[top, 3]
            h = b - a
            want = best - tol - rel * max(best - thr, 0.0)
            lb = 0.5 * (fa + fb - lg * h)
            if lb >= want:
                leaf_min = min(leaf_min, lb)
                continue
            loc = (_link_speed(oa, ka, a, b, obj_rob, pa, ta, ra, pb, tb, rb, rad_a, rad_b)
                   + _link_speed(ob, kb, a, b, obj_rob, pa, ta, ra, pb, tb, rb, rad_a, rad_b))
            lb = 0.5 * (fa + fb - loc * h)
            if lb >= want or h <= resolution or top + 2 > STACK:
                leaf_min = min(leaf_min, lb)
                continue
            m = a + 0.5 * h
            fm = bound_at(p, m, lp_oa, lp_ka, lp_ob, lp_kb, obj_rob, obj_x, obj_y, la,
                          pa, ta, aa, pb, tb, ab, kptr, cap, zlim, pptr, pxy,
                          best + tight_mm)
            n_eval += 1
            if fm < best:
                best = fm
                tbest = m
            top = push_halves(st, top, a, m, b, fa, fm, fb)
        prev_t = t
        prev_f = f
    return best, tbest, min(leaf_min, best), n_eval


@njit(cache=True, parallel=True)
def capsule_min(lp_oa, lp_ka, lp_ob, lp_kb, obj_rob, obj_x, obj_y, la,
                pa, ta, aa, ra, pb, tb, ab, rb, kptr, cap, zlim, pptr, pxy, rad_a, rad_b,
                vglob, vmean, t_lo, t_hi, coarse_mm, tight_mm, resolution, thr, tol, rel):
    """Per link pair, the smallest lower bound C over [t_lo, t_hi] (within tolerance);
    link pairs in parallel (numba threads), each on its own.

    Returns (cmin (n,), tmin (n,), cert (n,), evaluations). ``cert[p]`` is a value
    that the interval bound of every leaf of the bisection reached, so ``C(t) >=
    cert[p]`` on the whole span (``-inf`` when some leaf was stopped by the
    resolution before it got there).
    """
    n_lp = len(lp_oa)
    cmin = np.empty(n_lp)
    tmin = np.empty(n_lp)
    cert = np.empty(n_lp)
    evals = np.zeros(n_lp, dtype=np.int64)
    for p in prange(n_lp):
        st = np.empty((STACK, 4))
        cmin[p], tmin[p], cert[p], evals[p] = _capsule_min_pair(
            p, lp_oa, lp_ka, lp_ob, lp_kb, obj_rob, obj_x, obj_y, la, pa, ta, aa, ra, pb, tb,
            ab, rb, kptr, cap, zlim, pptr, pxy, rad_a, rad_b, vglob, vmean, t_lo, t_hi,
            coarse_mm, tight_mm, resolution, thr, tol, rel, st)
    return cmin, tmin, cert, evals.sum()


@njit(cache=True)
def _grow(buf, n):
    if n < buf.shape[0]:
        return buf
    out = np.empty((2 * buf.shape[0] + 16, buf.shape[1]))
    out[:n] = buf[:n]
    return out


@njit(cache=True)
def capsule_suspects(lp_oa, lp_ka, lp_ob, lp_kb, obj_rob, obj_x, obj_y, la,
                     pa, ta, aa, ra, pb, tb, ab, rb, kptr, cap, zlim, pptr, pxy, rad_a, rad_b,
                     vglob, vmean, t_lo, t_hi, coarse_mm, tight_mm, resolution, thr, cut, tolp,
                     sel, contact_mm):
    """Intervals the lower bound C cannot clear against ``max(thr, cut[p])``, for the
    link pairs ``sel``.

    An interval is split until its relative motion ``L h`` is at most ``2 tolp[p]``, except
    where C is at or below ``thr`` at both ends (a contact, or a bound too loose to tell):
    there intervals of up to ``contact_mm`` of relative motion are emitted whole, and the
    exact step settles them (a contact throughout in one or two exact distances, a near
    miss by bisection on exact values).

    Returns (rows (m, 6): p, a, b, C(a), C(b), local speed bound L; evaluations).
    Rows of one pair are in time order; consecutive rows may share an end.
    """
    out = np.empty((1024, 6))
    n_out = 0
    n_eval = 0
    st = np.empty((STACK, 4))
    span = t_hi - t_lo
    for p in sel:
        oa, ob, ka, kb = lp_oa[p], lp_ob[p], lp_ka[p], lp_kb[p]
        lg = vglob[oa, ka] + vglob[ob, kb]
        n = _n_coarse(span, vmean[oa, ka] + vmean[ob, kb], coarse_mm, resolution)
        if lg == 0.0:
            n = 1
        want = cut[p]
        tight = max(want, thr) + tight_mm
        prev_t = t_lo
        prev_f = bound_at(p, t_lo, lp_oa, lp_ka, lp_ob, lp_kb, obj_rob, obj_x, obj_y, la,
                          pa, ta, aa, pb, tb, ab, kptr, cap, zlim, pptr, pxy, tight)
        n_eval += 1
        for g in range(1, n + 1):
            t = t_lo + span * g / n if g < n else t_hi
            f = bound_at(p, t, lp_oa, lp_ka, lp_ob, lp_kb, obj_rob, obj_x, obj_y, la,
                         pa, ta, aa, pb, tb, ab, kptr, cap, zlim, pptr, pxy, tight)
            n_eval += 1
            top = push(st, 0, prev_t, t, prev_f, f)
            while top > 0:
                top -= 1
                a, b, fa, fb = st[top, 0], st[top, 1], st[top, 2], st[top, 3]
                h = b - a
                lb = 0.5 * (fa + fb - lg * h)
                if lb > thr and lb >= want:
                    continue
                loc = (_link_speed(oa, ka, a, b, obj_rob, pa, ta, ra, pb, tb, rb, rad_a, rad_b)
                       + _link_speed(ob, kb, a, b, obj_rob, pa, ta, ra, pb, tb, rb, rad_a, rad_b))
                lb = 0.5 * (fa + fb - loc * h)
                if lb > thr and lb >= want:
                    continue
                deep = fa <= thr and fb <= thr and loc * h <= contact_mm
                if loc * h > 2.0 * tolp[p] and h > resolution and top + 2 <= STACK and not deep:
                    m = a + 0.5 * h
                    fm = bound_at(p, m, lp_oa, lp_ka, lp_ob, lp_kb, obj_rob, obj_x, obj_y, la,
                                  pa, ta, aa, pb, tb, ab, kptr, cap, zlim, pptr, pxy, tight)
                    n_eval += 1
                    top = push_halves(st, top, a, m, b, fa, fm, fb)
                    continue
                out = _grow(out, n_out)
                out[n_out] = (float(p), a, b, fa, fb, loc)
                n_out += 1
            prev_t = t
            prev_f = f
    return out[:n_out], n_eval


@njit(cache=True)
def poses_and_bounds(qp, qt, lp_oa, lp_ka, lp_ob, lp_kb, obj_rob, obj_x, obj_y, la,
                     pa, ta, aa, pb, tb, ab, kptr, cap, zlim, pptr, pxy, max_pp):
    """For queries (link pair qp[k], time qt[k]): both link poses (theta, x, y) and the
    capsule bound of every piece pair (row-major u, v; padded with inf)."""
    n = len(qp)
    poses = np.empty((n, 6))
    bounds = np.full((n, max_pp), np.inf)
    for k in range(n):
        ka, kb, tha, xa, ya, pl_a, thb, xb, yb, pl_b, s_xy, s_z = pair_state(
            qp[k], qt[k], lp_oa, lp_ka, lp_ob, lp_kb, obj_rob, obj_x, obj_y, la, pa, ta, aa,
            pb, tb, ab)
        store_pose_bounds_at(poses, bounds, k, ka, kb, tha, xa, ya, pl_a, thb, xb, yb, pl_b,
                             s_xy, s_z, kptr, cap, zlim, pptr, pxy)
    return poses, bounds


@njit(cache=True)
def query_angles(qp, qt, lp_oa, lp_ob, obj_rob, pa, ta, aa, pb, tb, ab):
    """(n, 4) joint angles (alpha_a, beta_a, alpha_b, beta_b), rad, of the two objects of
    link pair ``qp[k]`` at time ``qt[k]`` (zeros for an obstacle)."""
    n = len(qp)
    out = np.zeros((n, 4))
    for k in range(n):
        for side in range(2):
            o = lp_oa[qp[k]] if side == 0 else lp_ob[qp[k]]
            r = obj_rob[o]
            if r >= 0:
                out[k, 2 * side] = interp_angle(pa, ta, aa, r, qt[k])
                out[k, 2 * side + 1] = interp_angle(pb, tb, ab, r, qt[k])
    return out
