"""The integration kernel of the potential-field planners: one numba function, run_apf.

Every robot ``i`` descends its own potential (Makarem et al. 2014, Eq. 2)::

    psi_i = lambda1 |q_i - q_iT|^2 + lambda2 sum_j rep(s_ij)

with joint velocities ``u_i = -J_i^T grad_q psi_i`` (Makarem 2014, Eqs. 3-4; ``rep`` is
sign-corrected, see :mod:`rfp_twin.planners.fields.field`), integrated by Euler steps of ``dt``
until every fiber tip is within ``tol`` of its target. With ``lambda3 > 0`` robot i's
Cartesian push also gets its cooperative neighbours' remaining errors, as a vector
field (Macktoobian et al. 2019, Eq. 5; :mod:`rfp_twin.planners.fields.capf`).

Not in the papers, and what this kernel does
--------------------------------------------
* **Speed saturation** (not given in Makarem 2014). ``u = (u_alpha, u_beta)`` rad/s is
  scaled by ``1 / max(1, |u_alpha| / vmax_alpha, |u_beta| / vmax_beta)``: both joints
  slow down together, so the joint-space direction of the descent is kept.
* **Theorem 1 / "lambda1 < 72 lambda2"** (Makarem 2014 Sect. 4) do not check out in any
  unit: convergence is verified by simulation (benchmarks/bench_apf.py), and every run
  reports its smallest distance, because discrete steps can break the barrier.
* **Units / time scale.** The paper states no units. Lengths are mm, psi is mm^2 and
  ``u = -gain J^T grad psi`` is rad/s with ``gain`` in 1/s (default 1: the weights read
  in mm and s). The gain sets how fast robots descend before the speed limit, not where
  the field's equilibria are; with the DESI preset ``gain = 10`` gives the paper's
  ~2.5 s motion time, ``gain = 1`` about 3-4 s.
* **Singularities (beta = 0 and 180 deg).** There ``J`` loses rank: a push along the
  beta arm gives ``u = 0`` and the robot would sit there forever (the hardware stop at
  beta = 0 makes this reachable); Makarem 2014 Sect. 5 only says to avoid them. Inside a
  band ``|sin beta| < band_sin``, when the attractive (and cooperative) push ``f``
  points where moving beta helps (inwards at beta ~ 0, outwards at beta ~ 180), beta
  additionally gets ``sign(beta_T - beta) |f . r| l_beta (1 - |sin beta| / band_sin)``
  rad/s, ``r`` the unit vector from the base to the tip, fading out at the band edge.
* **Alpha axis.** When ``l_alpha ~ l_beta`` (DESI: 3 + 3 mm) beta = 180 deg puts the tip
  on the alpha axis, where alpha moves the tip with gain ``r = |tip - base|`` only, and
  the tangential approach to a target near the centre slows as ``r^2``. For
  ``r < axis_r`` alpha's velocity is multiplied by ``(axis_r / max(r, axis_r / 10))^2``:
  a positive diagonal scaling of ``u`` keeps it a descent direction and moves no
  equilibrium. It never acts when ``|l_alpha - l_beta| >= axis_r`` (SDSS-V).
* **Linearly implicit attraction.** Near its target the attraction is stiff (joint-space
  Hessian ``2 lambda1 J^T J``; for SDSS-V arms, |J| ~ 22 mm, explicit Euler at 10 ms
  overshoots by ~10x and chatters). With ``implicit`` the step is ``dtheta = dt (I + 2
  lambda1 gain dt J^T J)^-1 u`` (then saturated): exact for the quadratic attraction,
  positive definite, so it keeps ``u``'s descent property and every equilibrium.
* **Step guard.** After all robots propose their step (Jacobi: every robot sees the same
  state), any pair whose new distance is ``<= d`` (robot-fiducial ``<= d_fid``) has the
  steps of both of its robots halved, up to ``GUARD_HALVINGS`` times, then cancelled.
  The state at every step thus keeps all distances ``> d``; ``n_guard`` counts how often
  the field alone would not have.

Offline robots never move and repel their neighbours like any other robot; they take
no part in the cooperative term. Alpha is continuous unless ``clamp_alpha``; beta is
always clamped to its limits. Each axis's path is recorded online with a swing-door
filter: kept points are original Euler samples, and linear interpolation between them is
within ``simp_tol`` of every sample. Cost O(N k) per step (k neighbours in the CSR).

Per-robot geometry: each robot has its own alpha arm length, beta collision segment and
buffer excess, each obstacle its own shape (a point or a segment) and keep-out excess;
the thresholds ``d``, ``D`` (and ``d_fid``, ``D_fid``) of a pair grow by the two bodies'
excesses, so the envelope width ``D - d`` stays the same for every pair.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from rfp_twin.planners.fields.field import (arm_poses, barrier_push, jacobian_transpose,
                                            obstacle_distance, pair_distance)

#: Halvings of a guarded step before it is cancelled.
GUARD_HALVINGS = 4


@njit(cache=True)
def _emit(ev_r, ev_a, ev_s, ev_v, n_ev, robot, axis, step, value):
    """Append one breakpoint, growing the buffers when full. Returns the new buffers."""
    if n_ev >= ev_r.shape[0]:
        m = ev_r.shape[0] * 2
        r2 = np.empty(m, dtype=np.int64)
        a2 = np.empty(m, dtype=np.int64)
        s2 = np.empty(m, dtype=np.int64)
        v2 = np.empty(m)
        r2[:n_ev] = ev_r[:n_ev]
        a2[:n_ev] = ev_a[:n_ev]
        s2[:n_ev] = ev_s[:n_ev]
        v2[:n_ev] = ev_v[:n_ev]
        ev_r, ev_a, ev_s, ev_v = r2, a2, s2, v2
    ev_r[n_ev] = robot
    ev_a[n_ev] = axis
    ev_s[n_ev] = step
    ev_v[n_ev] = value
    return ev_r, ev_a, ev_s, ev_v, n_ev + 1


@njit(cache=True)
def run_apf(base, th0, th_target, target_xy, movable, nbr_ptr, nbr_idx, nbr_coop,
            fid_ptr, fid_idx, fid_a, fid_b, la, lb, s0, s1, ex, fex, segment, d, D, d_f, D_f,
            l1, l2, l3, gain, w_a, w_b, beta_lo, beta_hi, alpha_lo, alpha_hi, clamp_alpha,
            dt, tol, max_steps, stall_steps, stall_rad, band_sin, axis_r, implicit, guard,
            simp_tol, cap):
    """Integrate the (cooperative) navigation field. Angles in radians, lengths in mm.

    Parameters
    ----------
    base : (n, 2) base positions; th0, th_target : (n, 2) start / target angles (rad)
    target_xy : (n, 2) target tip positions; movable : (n,) bool
    nbr_ptr, nbr_idx : CSR robot neighbours (pairs that can come within D)
    nbr_coop : (len(nbr_idx),) bool, entry is a cooperative neighbour (CAPF)
    fid_ptr, fid_idx : CSR robot -> obstacles
    fid_a, fid_b : (m, 2) obstacle ends (equal for a point obstacle such as a fiducial)
    la : (n,) each robot's alpha arm length; lb : beta arm length (tip at la[i] + lb)
    s0, s1 : (n,) each robot's beta collision segment start / end along its arm
    ex : (n,) each robot's buffer beyond the nominal one (segment model; 0 in tip mode)
    fex : (m,) each obstacle's keep-out radius beyond the spec's fiducial buffer
    segment : bool, segment model (else tip model)
    d, D, d_f, D_f : nominal robot and obstacle safety / envelope distances; pair (i, j)
        uses ``d + ex[i] + ex[j]`` and ``D + ex[i] + ex[j]``, robot i and obstacle f
        ``d_f + ex[i] + fex[f]`` and ``D_f + ex[i] + fex[f]``
    l1, l2, l3 : field weights; gain : 1/s factor on u; w_a, w_b : saturation speeds (rad/s)
    beta_lo, beta_hi, alpha_lo, alpha_hi : (n,) float64 each robot's joint limits (rad);
        clamp_alpha : bool
    dt : Euler step (s); tol : convergence distance; max_steps, stall_steps : ints
    stall_rad, band_sin, axis_r, implicit, guard, simp_tol : see ApfSettings
    cap : initial breakpoint buffer size

    Returns
    -------
    n_steps, stop (0 converged, 1 stalled, 2 max steps), th (n, 2) final,
    ev_r, ev_a, ev_s, ev_v, n_ev : breakpoints (robot, axis, step, angle rad),
    stats (4,) = min pair distance less ``ex[i] + ex[j]`` (comparable with d), min tip
    distance, min obstacle distance less ``ex[i] + fex[f]`` (comparable with d_f),
    guard events; settle (n,) int64 step of last entry into
    tolerance (-1 if not converged); err (n,) final tip errors (mm); th_min, th_max
    (n, 2) angle ranges visited.
    """
    n = base.shape[0]
    th = th0.copy()
    P = np.empty((n, 6))
    Q = np.empty((n, 6))
    prop = np.empty((n, 2))
    frac = np.ones(n)
    moved = np.zeros(n, dtype=np.bool_)
    u = np.zeros((n, 2))
    err = np.zeros(n)
    settle = -np.ones(n, dtype=np.int64)
    ckpt = th0.copy()
    th_min = th0.copy()
    th_max = th0.copy()
    # swing-door state per robot and axis: anchor step/value, slope cone, last sample
    anc_k = np.zeros((n, 2), dtype=np.int64)
    anc_v = th0.copy()
    lo = np.full((n, 2), -np.inf)
    hi = np.full((n, 2), np.inf)
    last_v = th0.copy()
    ev_r = np.empty(cap, dtype=np.int64)
    ev_a = np.empty(cap, dtype=np.int64)
    ev_s = np.empty(cap, dtype=np.int64)
    ev_v = np.empty(cap)
    n_ev = 0
    for i in range(n):
        for ax in range(2):
            ev_r, ev_a, ev_s, ev_v, n_ev = _emit(ev_r, ev_a, ev_s, ev_v, n_ev, i, ax, 0, th0[i, ax])
    min_pair = np.inf
    min_tip = np.inf
    min_fid = np.inf
    n_guard = 0
    k = 0
    stop = 2
    while True:
        arm_poses(base, th, la, P)
        # --- state statistics, convergence -------------------------------------------
        all_conv = True
        for i in range(n):
            tx = P[i, 4] + lb * P[i, 2]
            ty = P[i, 5] + lb * P[i, 3]
            for kk in range(nbr_ptr[i], nbr_ptr[i + 1]):
                j = nbr_idx[kk]
                if j <= i:
                    continue
                ux = P[j, 4] + lb * P[j, 2] - tx
                uy = P[j, 5] + lb * P[j, 3] - ty
                st = math.sqrt(ux * ux + uy * uy)
                if st < min_tip:
                    min_tip = st
                if segment:
                    s, _, _, _, _, _ = pair_distance(P, i, j, segment, lb, s0, s1)
                    s -= ex[i] + ex[j]
                    if s < min_pair:
                        min_pair = s
                elif st < min_pair:
                    min_pair = st
            for kk in range(fid_ptr[i], fid_ptr[i + 1]):
                f = fid_idx[kk]
                s, _, _, _, _, _ = obstacle_distance(P, i, fid_a, fid_b, f, segment, lb, s0, s1)
                s -= ex[i] + fex[f]
                if s < min_fid:
                    min_fid = s
            if movable[i]:
                e = math.sqrt((tx - target_xy[i, 0]) ** 2 + (ty - target_xy[i, 1]) ** 2)
                err[i] = e
                if e < tol:
                    if settle[i] < 0:
                        settle[i] = k
                else:
                    settle[i] = -1
                    all_conv = False
        if all_conv:
            stop = 0
            break
        if k >= max_steps:
            stop = 2
            break
        if stall_steps > 0 and k > 0 and k % stall_steps == 0:
            net = 0.0
            for i in range(n):
                if movable[i]:
                    net = max(net, abs(th[i, 0] - ckpt[i, 0]), abs(th[i, 1] - ckpt[i, 1]))
                    ckpt[i, 0] = th[i, 0]
                    ckpt[i, 1] = th[i, 1]
            if net <= stall_rad:
                stop = 1
                break
        # --- velocities --------------------------------------------------------------
        for i in range(n):
            u[i, 0] = 0.0
            u[i, 1] = 0.0
            moved[i] = False
            if not movable[i]:
                continue
            tx = P[i, 4] + lb * P[i, 2]
            ty = P[i, 5] + lb * P[i, 3]
            gx = 2.0 * l1 * (tx - target_xy[i, 0])
            gy = 2.0 * l1 * (ty - target_xy[i, 1])
            if l3 > 0.0:   # Macktoobian Eq. 5: neighbours' remaining errors, as a vector field
                for kk in range(nbr_ptr[i], nbr_ptr[i + 1]):
                    j = nbr_idx[kk]
                    if nbr_coop[kk] and movable[j]:
                        gx += 2.0 * l3 * (P[j, 4] + lb * P[j, 2] - target_xy[j, 0])
                        gy += 2.0 * l3 * (P[j, 5] + lb * P[j, 3] - target_xy[j, 1])
            fa, fb = jacobian_transpose(P, i, la[i], lb, -gx, -gy)
            sb = P[i, 2] * P[i, 1] - P[i, 3] * P[i, 0]     # sin(beta)
            if band_sin > 0.0 and abs(sb) < band_sin:
                cb = P[i, 2] * P[i, 0] + P[i, 3] * P[i, 1]  # cos(beta)
                rx = tx - base[i, 0]
                ry = ty - base[i, 1]
                rn = math.sqrt(rx * rx + ry * ry)
                if rn > 1e-9:
                    fr = -(gx * rx + gy * ry) / rn
                    helps = fr < 0.0 if cb > 0.0 else fr > 0.0
                else:
                    fr = math.sqrt(gx * gx + gy * gy)
                    helps = True
                if helps:
                    sgn = 1.0
                    if th_target[i, 1] < th[i, 1] or (th_target[i, 1] == th[i, 1] and cb < 0.0):
                        sgn = -1.0
                    fb += sgn * abs(fr) * lb * (1.0 - abs(sb) / band_sin)
            ua = fa
            ub = fb
            # repulsion from neighbours (sign-corrected Eq. 2)
            for kk in range(nbr_ptr[i], nbr_ptr[i + 1]):
                j = nbr_idx[kk]
                s, r, px, py, qx, qy = pair_distance(P, i, j, segment, lb, s0, s1)
                e = ex[i] + ex[j]
                if s >= D + e:
                    continue
                ra, rb = barrier_push(P, i, la[i], r, s, d + e, D + e, l2, px, py, qx, qy,
                                      base[i, 0], base[i, 1], base[j, 0], base[j, 1])
                ua += ra
                ub += rb
            for kk in range(fid_ptr[i], fid_ptr[i + 1]):
                f = fid_idx[kk]
                s, r, px, py, qx, qy = obstacle_distance(P, i, fid_a, fid_b, f, segment, lb, s0, s1)
                e = ex[i] + fex[f]
                if s >= D_f + e:
                    continue
                # on the obstacle: pushed away from it towards the base
                ra, rb = barrier_push(P, i, la[i], r, s, d_f + e, D_f + e, l2, px, py, qx, qy,
                                      base[i, 0], base[i, 1], qx, qy)
                ua += ra
                ub += rb
            # alpha-axis rule: alpha moves the tip with gain r = |tip - base|; below
            # axis_r its push is scaled by (axis_r / r)^2 (capped at 100)
            if axis_r > 0.0:
                rx = tx - base[i, 0]
                ry = ty - base[i, 1]
                rn = max(math.sqrt(rx * rx + ry * ry), 0.1 * axis_r)
                if rn < axis_r:
                    ua *= (axis_r / rn) ** 2
            ua *= gain
            ub *= gain
            if implicit:
                # linearly implicit Euler in the attractive term: (I + 2 l1 dt J^T J) du = u
                c1x = -la[i] * P[i, 1] - lb * P[i, 3]
                c1y = la[i] * P[i, 0] + lb * P[i, 2]
                c2x = -lb * P[i, 3]
                c2y = lb * P[i, 2]
                h = 2.0 * l1 * dt * gain
                m11 = 1.0 + h * (c1x * c1x + c1y * c1y)
                m12 = h * (c1x * c2x + c1y * c2y)
                m22 = 1.0 + h * (c2x * c2x + c2y * c2y)
                det = m11 * m22 - m12 * m12
                ua, ub = (m22 * ua - m12 * ub) / det, (m11 * ub - m12 * ua) / det
            # saturation: scale both joints, keep the direction
            sat = max(1.0, abs(ua) / w_a, abs(ub) / w_b)
            u[i, 0] = ua / sat
            u[i, 1] = ub / sat
            moved[i] = u[i, 0] != 0.0 or u[i, 1] != 0.0
        # --- proposals, guard ----------------------------------------------------------
        for i in range(n):
            frac[i] = 1.0 if moved[i] else 0.0
        changed = True
        first = True
        while changed:
            changed = False
            for i in range(n):
                if first or frac[i] < 1.0:
                    a = th[i, 0] + frac[i] * dt * u[i, 0]
                    b = th[i, 1] + frac[i] * dt * u[i, 1]
                    if b < beta_lo[i]:
                        b = beta_lo[i]
                    elif b > beta_hi[i]:
                        b = beta_hi[i]
                    if clamp_alpha:
                        if a < alpha_lo[i]:
                            a = alpha_lo[i]
                        elif a > alpha_hi[i]:
                            a = alpha_hi[i]
                    prop[i, 0] = a
                    prop[i, 1] = b
            arm_poses(base, prop, la, Q)
            first = False
            if not guard:
                break
            for i in range(n):
                if frac[i] == 0.0:
                    continue
                bad = False
                for kk in range(nbr_ptr[i], nbr_ptr[i + 1]):
                    j = nbr_idx[kk]
                    s, _, _, _, _, _ = pair_distance(Q, i, j, segment, lb, s0, s1)
                    if s <= d + (ex[i] + ex[j]):
                        bad = True
                        if frac[j] > 0.0:
                            frac[j] = frac[j] * 0.5 if frac[j] > 0.5 ** GUARD_HALVINGS else 0.0
                        break
                if not bad:
                    for kk in range(fid_ptr[i], fid_ptr[i + 1]):
                        f = fid_idx[kk]
                        s, _, _, _, _, _ = obstacle_distance(Q, i, fid_a, fid_b, f, segment, lb, s0, s1)
                        if s <= d_f + (ex[i] + fex[f]):
                            bad = True
                            break
                if bad:
                    frac[i] = frac[i] * 0.5 if frac[i] > 0.5 ** GUARD_HALVINGS else 0.0
                    changed = True
                    n_guard += 1
            if changed:
                for i in range(n):
                    if frac[i] == 0.0:
                        prop[i, 0] = th[i, 0]
                        prop[i, 1] = th[i, 1]
        # --- commit and record -----------------------------------------------------------
        k += 1
        for i in range(n):
            th[i, 0] = prop[i, 0]
            th[i, 1] = prop[i, 1]
            for ax in range(2):
                v = th[i, ax]
                if v < th_min[i, ax]:
                    th_min[i, ax] = v
                if v > th_max[i, ax]:
                    th_max[i, ax] = v
                span = k - anc_k[i, ax]
                sl = (v - anc_v[i, ax]) / span
                if lo[i, ax] <= sl <= hi[i, ax]:
                    lo[i, ax] = max(lo[i, ax], (v - simp_tol - anc_v[i, ax]) / span)
                    hi[i, ax] = min(hi[i, ax], (v + simp_tol - anc_v[i, ax]) / span)
                else:
                    ev_r, ev_a, ev_s, ev_v, n_ev = _emit(ev_r, ev_a, ev_s, ev_v, n_ev, i, ax, k - 1,
                                                         last_v[i, ax])
                    anc_k[i, ax] = k - 1
                    anc_v[i, ax] = last_v[i, ax]
                    lo[i, ax] = v - simp_tol - last_v[i, ax]
                    hi[i, ax] = v + simp_tol - last_v[i, ax]
                last_v[i, ax] = v
    for i in range(n):
        for ax in range(2):
            ev_r, ev_a, ev_s, ev_v, n_ev = _emit(ev_r, ev_a, ev_s, ev_v, n_ev, i, ax, k, th[i, ax])
    stats = np.array([min_pair, min_tip, min_fid, float(n_guard)])
    return k, stop, th, ev_r, ev_a, ev_s, ev_v, n_ev, stats, settle, err, th_min, th_max
