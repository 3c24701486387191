"""A robot's neighbours in the stepwise kernel: short lists, free windows, Eq. 10, energy.

:func:`refresh_near` keeps each robot's short list of the neighbours that can matter in
the next NEAR_HORIZON steps; :func:`free_window` finds for how many steps every MC
candidate surely passes the step rule; :func:`encroached` is the MC test of Eq. 10 for a
robot at its destination; :func:`energy_gradient` is the MC energy of Eq. 9 and its
gradient; :func:`woken` tells whether a sleeping robot's neighbour has moved.

Units: angles in deg, lengths in mm, time in steps. The tuples ``arr`` (array
geometry), ``par`` (scalars), ``rs`` (robot trig, segment, reach) and ``near`` (short
lists) are described in :mod:`rfp_twin.planners.stepwise.candidates`; ``home_until``
(n,) int64 is the step before which a robot parked at home needs no Eq. 10 check,
``moved_at`` (n,) int64 the move counter of each robot's last move.

The functions are ``@njit(inline="always")``: numba inlines them into
:func:`rfp_twin.planners.stepwise.kernel.step_loop`, which runs without reference counting.
"""
from __future__ import annotations

from numba import njit

from rfp_twin.models.geometry2d import segment_closest_sq, segment_distance
from rfp_twin.planners.stepwise.moves import DEG, obstacle_distance

#: MC energy (Eq. 9) counts neighbours whose capsules may be nearer than this (mm).
ENERGY_CUTOFF_MM = 12.0
#: Steps for which a robot's short list of near neighbours stays valid.
NEAR_HORIZON = 32


@njit(cache=True, inline="always")
def woken(i, asleep_at_i, nbr_ptr, nbr_idx, moved_at):
    """Has a neighbour of robot i moved since move counter ``asleep_at_i``?"""
    for k in range(nbr_ptr[i], nbr_ptr[i + 1]):
        if moved_at[nbr_idx[k]] > asleep_at_i:
            return True
    return False


@njit(cache=True, inline="always")
def refresh_near(i, step, arr, par, rs, near):
    """Rebuild robot i's short list of the neighbours that can matter.

    A neighbour is left out when its base-disk bound |b_i - b_j| - rho_i - rho_j
    exceeds what matters (the step-rule threshold; for MC also the energy cutoff) by
    more than NEAR_HORIZON * free_step. The bound shrinks by at most free_step per
    step (each reach changes by at most seg_end * step) and candidates are one step
    away, so the list holds NEAR_HORIZON - 2 steps. The list is ordered: first the
    neighbours that can matter to the step rule (``near_col[i]`` of them, all that
    try_cand scans), then those that only the MC energy needs (when near_ref > 0).
    """
    (base_xy, nbr_ptr, nbr_idx, nbr_dist, fid_ptr, fid_idx, fid_xy, fid_end_xy, fid_buffer,
     alpha_len, seg_start, seg_end, buffer) = arr
    step_deg, md, cd, sd, c2d, s2d, free_step, disp, near_ref = par
    trig, seg, rho = rs
    near_k, near_col, near_cnt, near_until = near
    cnt = 0
    for k in range(nbr_ptr[i], nbr_ptr[i + 1]):
        j = nbr_idx[k]
        if nbr_dist[k] - rho[i] - rho[j] - (buffer[i] + buffer[j] + md) \
                <= NEAR_HORIZON * free_step:
            near_k[i, cnt] = k
            cnt += 1
    near_col[i] = cnt
    if near_ref > 0.0:
        for k in range(nbr_ptr[i], nbr_ptr[i + 1]):
            j = nbr_idx[k]
            gap = nbr_dist[k] - rho[i] - rho[j]
            if gap - (buffer[i] + buffer[j] + md) > NEAR_HORIZON * free_step \
                    and gap - near_ref <= NEAR_HORIZON * free_step:
                near_k[i, cnt] = k
                cnt += 1
    near_cnt[i] = cnt
    near_until[i] = step + NEAR_HORIZON - 2


@njit(cache=True, inline="always")
def free_window(i, step, arr, par, rs, near):
    """MC: how many steps from now every candidate of robot i surely passes the step rule.

    slack = min over the step-rule neighbours (and obstacles) of distance - threshold,
    from the base-disk bound where that suffices, else the exact segment distance.
    Between now and the visit k steps later each of the two segments moves by at
    most (k + 1) ``disp`` (k committed steps plus the candidate), so every candidate
    passes while 2 (k + 1) disp < slack. The short list bounds the window: a
    neighbour outside it cannot come within reach before ``near_until[i]``.
    """
    (base_xy, nbr_ptr, nbr_idx, nbr_dist, fid_ptr, fid_idx, fid_xy, fid_end_xy, fid_buffer,
     alpha_len, seg_start, seg_end, buffer) = arr
    step_deg, md, cd, sd, c2d, s2d, free_step, disp, near_ref = par
    trig, seg, rho = rs
    near_k, near_col, near_cnt, near_until = near
    need = 2.0 * disp
    slack = 1e300
    bi = buffer[i]
    for m in range(near_col[i]):
        k = near_k[i, m]
        j = nbr_idx[k]
        th = bi + buffer[j] + md
        g = nbr_dist[k] - rho[i] - rho[j] - th
        if g <= need:
            g = segment_distance(seg[i, 0], seg[i, 1], seg[i, 2], seg[i, 3],
                                 seg[j, 0], seg[j, 1], seg[j, 2], seg[j, 3]) - th
            if g <= need:
                return 0
        slack = min(slack, g)
    for k in range(fid_ptr[i], fid_ptr[i + 1]):
        f = fid_idx[k]
        th = bi + fid_buffer[f] + md
        g = obstacle_distance(seg[i, 0], seg[i, 1], seg[i, 2], seg[i, 3],
                               fid_xy[f, 0], fid_xy[f, 1], fid_end_xy[f, 0], fid_end_xy[f, 1]) - th
        if g <= need:
            return 0
        slack = min(slack, g)
    w = int(min(slack / need, 1e9) * (1.0 - 1e-9))
    return min(w, near_until[i] - step)


@njit(cache=True, inline="always")
def encroached(i, margin, step, arr, par, rs, home_until):
    """Eq. 10: is any neighbour within buffer_i + buffer_j + margin of robot i now?

    When none is, robot i (parked at home) cannot be encroached before every base-disk
    bound has shrunk to the threshold; only neighbours move, each reach by at most
    free_step / 2 per step, so no check is needed until ``home_until[i]`` (set here).
    """
    (base_xy, nbr_ptr, nbr_idx, nbr_dist, fid_ptr, fid_idx, fid_xy, fid_end_xy, fid_buffer,
     alpha_len, seg_start, seg_end, buffer) = arr
    step_deg, md, cd, sd, c2d, s2d, free_step, disp, near_ref = par
    trig, seg, rho = rs
    hit = False
    slack = 1e300
    for k in range(nbr_ptr[i], nbr_ptr[i + 1]):
        j = nbr_idx[k]
        th = buffer[i] + buffer[j] + margin
        lb = nbr_dist[k] - rho[i] - rho[j] - th
        slack = min(slack, lb)
        if lb > 0.0:
            continue
        if segment_distance(seg[i, 0], seg[i, 1], seg[i, 2], seg[i, 3],
                            seg[j, 0], seg[j, 1], seg[j, 2], seg[j, 3]) <= th:
            hit = True
            break
    if not hit and slack > 0.0:
        home_until[i] = step + int(slack / (0.5 * free_step)) - 1
    return hit


@njit(cache=True, inline="always")
def energy_gradient(i, s1, arr, par, rs, near):
    """Eq. 9 energy E = sum 1/D^2 of robot i now (mm^-2), and dE/dalpha, dE/dbeta (per deg).

    s1 mm is robot i's segment end; its alpha arm and segment start come from ``arr``.

    The nine candidates differ from the current state by at most one step, so the MC
    planner ranks them by E + grad . (dalpha, dbeta): one pass over the neighbours
    instead of nine. By the envelope theorem dD/dtheta is the motion of robot i's
    closest point along the unit vector between the closest points. Neighbours whose
    disk bound is beyond ENERGY_CUTOFF_MM are left out: their term changes between
    candidates by < 2 MD / cutoff^3, too little to reorder what near ones separate.
    """
    (base_xy, nbr_ptr, nbr_idx, nbr_dist, fid_ptr, fid_idx, fid_xy, fid_end_xy, fid_buffer,
     alpha_len, seg_start, seg_end, buffer) = arr
    step_deg, md, cd, sd, c2d, s2d, free_step, disp, near_ref = par
    trig, seg, rho = rs
    near_k, near_col, near_cnt, near_until = near
    e = 0.0
    ga = 0.0
    gb = 0.0
    ca_ = trig[i, 0]
    sa_ = trig[i, 1]
    cab = trig[i, 2]
    sab = trig[i, 3]
    l_alpha = alpha_len[i]
    s0 = seg_start[i]
    seg_len = s1 - s0
    for m in range(near_cnt[i]):
        k = near_k[i, m]
        j = nbr_idx[k]
        if nbr_dist[k] - rho[i] - rho[j] > ENERGY_CUTOFF_MM:
            continue
        d2, t, px, py, qx, qy = segment_closest_sq(seg[i, 0], seg[i, 1], seg[i, 2], seg[i, 3],
                                                   seg[j, 0], seg[j, 1], seg[j, 2], seg[j, 3])
        d2 = max(d2, 1e-12)
        e += 1.0 / d2
        nx = px - qx                  # D times the unit normal
        ny = py - qy
        r = s0 + t * seg_len          # closest point: r mm along the beta arm
        # dP/dalpha = l_alpha u'(a) + r u'(a+b);  dP/dbeta = r u'(a+b);  u' = (-sin, cos)
        dpa = nx * (-l_alpha * sa_ - r * sab) + ny * (l_alpha * ca_ + r * cab)
        dpb = nx * (-r * sab) + ny * (r * cab)
        # dE/dtheta = -2 / D^3 * (n . dP) = -2 / D^4 * ((P - Q) . dP): no root needed
        w = -2.0 / (d2 * d2) * DEG
        ga += w * dpa
        gb += w * dpb
    return e, ga, gb
