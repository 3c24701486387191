"""A robot's nine candidate moves: their angles and cost, their geometry, and the step rule.

The candidates are the moves {-d, 0, +d}^2 clipped to the travel limits and to not
overshoot the destination (:func:`fill_candidates`); :func:`try_cand` computes one
candidate's trig functions, beta segment and reach and checks it against the step rule
(Sayres 2021 Eqs. 6-7); :func:`commit` makes a candidate the robot's state.

Units: angles in deg, lengths in mm. The kernel's state, passed explicitly:

cand : (9, 13) float64, one row per candidate: (alpha, beta) deg, cos alpha, sin alpha,
    cos(alpha + beta), sin(alpha + beta), cos beta, sin beta, beta segment
    (x0, y0, x1, y1) mm, reach mm (largest base distance of a segment point)
arr : the array geometry, a tuple (base_xy (n, 2) mm, nbr_ptr (n + 1,) int64,
    nbr_idx (e,) int64, nbr_dist (e,) mm, fid_ptr (n + 1,) int64, fid_idx (f,) int64,
    fid_xy (m, 2) mm, fid_end_xy (m, 2) mm, fid_buffer (m,) mm, alpha_len (n,) mm,
    seg_start (n,) mm, seg_end (n,) mm, buffer (n,) mm): CSR neighbours and obstacles
    (obstacle f is the segment fid_xy[f]-fid_end_xy[f], a point when both ends agree,
    with keep-out radius fid_buffer[f]); each robot's alpha arm, beta collision segment
    (start, end along the beta arm) and buffer
par : the scalars, a tuple of floats (step_deg deg, md mm (step-rule margin MD),
    cos d, sin d, cos 2d, sin 2d, free_step mm, disp mm, near_ref mm), set in
    :func:`rfp_twin.planners.stepwise.state.new_state`
rs : the robots' geometry, a tuple (trig (n, 6): cos a, sin a, cos(a+b), sin(a+b),
    cos b, sin b; seg (n, 4) mm, beta segment; rho (n,) mm, reach)
near : the short lists of near neighbours, a tuple (near_k (n, max_degree) int64 CSR
    entries, near_col (n,) int64, near_cnt (n,) int64, near_until (n,) int64 steps);
    see :func:`rfp_twin.planners.stepwise.neighbours.refresh_near`

The functions are ``@njit(inline="always")``: numba inlines them into
:func:`rfp_twin.planners.stepwise.kernel.step_loop`, which runs without reference counting.
"""
from __future__ import annotations

import math

from numba import njit

from rfp_twin.models.geometry2d import segments_within
from rfp_twin.planners.stepwise.moves import (ANGLE_EPS, DEG, obstacle_distance, segment_reach,
                                              rotate_steps, direction_sign, step_toward)


@njit(cache=True, inline="always")
def cand_trig(cand, q, na, nb):
    """Candidate q's trig functions (cand[q, 2:8]) of (na, nb) deg, computed afresh."""
    a = na * DEG
    b = nb * DEG
    cand[q, 2] = math.cos(a)
    cand[q, 3] = math.sin(a)
    cand[q, 4] = math.cos(a + b)
    cand[q, 5] = math.sin(a + b)
    cand[q, 6] = math.cos(b)
    cand[q, 7] = math.sin(b)


@njit(cache=True, inline="always")
def cand_segment(cand, q, bx, by, s1, l_alpha, s0):
    """Candidate q's beta segment (cand[q, 8:12]) and reach (cand[q, 12]) from its trig.

    (bx, by) mm is the robot's base, l_alpha mm its alpha arm, s0 and s1 mm the start and
    end of its collision segment along the beta arm.
    """
    ex = bx + l_alpha * cand[q, 2]
    ey = by + l_alpha * cand[q, 3]
    cand[q, 8] = ex + s0 * cand[q, 4]
    cand[q, 9] = ey + s0 * cand[q, 5]
    cand[q, 10] = ex + s1 * cand[q, 4]
    cand[q, 11] = ey + s1 * cand[q, 5]
    cand[q, 12] = segment_reach(l_alpha, s0, s1, cand[q, 6])


@njit(cache=True, inline="always")
def commit(rs, cand, i, q):
    """Copy candidate q's state into robot i's state."""
    trig, seg, rho = rs
    for k in range(6):
        trig[i, k] = cand[q, 2 + k]
    for k in range(4):
        seg[i, k] = cand[q, 8 + k]
    rho[i] = cand[q, 12]


@njit(cache=True, inline="always")
def fill_candidates(cand, cost, order, ca, cb, da, db, step_deg, a_lo, a_hi, b_lo, b_hi):
    """The 9 moves {-d, 0, +d}^2 from (ca, cb) towards (da, db) deg, clipped to the limits.

    Row 3 (ka + 1) + kb + 1 of ``cand`` gets the (alpha, beta) of the move (ka, kb) steps,
    ``cost`` (9,) its cost C = |theta - theta_dest|^2 (Eq. 8, deg^2), ``order`` the identity.
    """
    for ub in range(3):   # the beta values first, in column 1 of rows 0..2
        cand[ub, 1] = step_toward(cb, db, ub - 1, step_deg, b_lo, b_hi)
    for ua in range(3):
        na = step_toward(ca, da, ua - 1, step_deg, a_lo, a_hi)
        ea = (na - da) * (na - da)
        for ub in range(3):
            nb = cand[ub, 1]
            c = 3 * ua + ub
            cand[c, 0] = na
            cand[c, 1] = nb
            cost[c] = ea + (nb - db) * (nb - db)
            order[c] = c


@njit(cache=True, inline="always")
def sort_by_cost(order, cost):
    """Sort ``order`` (9,) by ``cost`` of its entries: stable insertion sort."""
    for p in range(1, 9):
        q = order[p]
        r = p - 1
        while r >= 0 and cost[order[r]] > cost[q]:
            order[r + 1] = order[r]
            r -= 1
        order[r + 1] = q


@njit(cache=True, inline="always")
def try_cand(cand, q, i, ca, cb, bx, by, s1, margin, check, arr, par, rs, near):
    """Fill candidate q's state; return q if it passes the step rule, else -1.

    Robot i stands at (ca, cb) deg on base (bx, by) mm, segment end s1 mm (its own alpha
    arm and segment start come from ``arr``). The step rule is checked (``check``) with
    the margin ``margin`` mm against robot i's short list of near neighbours only (see
    :func:`rfp_twin.planners.stepwise.neighbours.refresh_near`) and its obstacles.
    """
    (base_xy, nbr_ptr, nbr_idx, nbr_dist, fid_ptr, fid_idx, fid_xy, fid_end_xy, fid_buffer,
     alpha_len, seg_start, seg_end, buffer) = arr
    step_deg, md, cd, sd, c2d, s2d, free_step, disp, near_ref = par
    trig, seg, rho = rs
    near_k, near_col, near_cnt, near_until = near
    na = cand[q, 0]
    nb = cand[q, 1]
    ka = direction_sign(na - ca)
    kb = direction_sign(nb - cb)
    exact = (ka != 0 and abs(abs(na - ca) - step_deg) > ANGLE_EPS) or \
            (kb != 0 and abs(abs(nb - cb) - step_deg) > ANGLE_EPS)
    if exact:
        cand_trig(cand, q, na, nb)
    else:
        c, s = rotate_steps(trig[i, 0], trig[i, 1], ka, cd, sd, c2d, s2d)
        cand[q, 2] = c
        cand[q, 3] = s
        c, s = rotate_steps(trig[i, 2], trig[i, 3], ka + kb, cd, sd, c2d, s2d)
        cand[q, 4] = c
        cand[q, 5] = s
        c, s = rotate_steps(trig[i, 4], trig[i, 5], kb, cd, sd, c2d, s2d)
        cand[q, 6] = c
        cand[q, 7] = s
    s0 = seg_start[i]
    cand_segment(cand, q, bx, by, s1, alpha_len[i], s0)
    x0 = cand[q, 8]
    y0 = cand[q, 9]
    x1 = cand[q, 10]
    y1 = cand[q, 11]
    rho_i = cand[q, 12]
    if not check:
        return q
    bi = buffer[i]
    hit = False
    # Two cheap bounds before the exact test: the base disks (|b_i - b_j| - rho_i -
    # rho_j) and the segment-midpoint disks (|m_i - m_j| - half lengths).
    mx = 0.5 * (x0 + x1)
    my = 0.5 * (y0 + y1)
    hi = 0.5 * (s1 - s0)
    for m in range(near_col[i]):
        k = near_k[i, m]
        j = nbr_idx[k]
        th = bi + buffer[j] + margin
        if nbr_dist[k] - rho_i - rho[j] > th:
            continue
        ux = 0.5 * (seg[j, 0] + seg[j, 2]) - mx
        uy = 0.5 * (seg[j, 1] + seg[j, 3]) - my
        reach = th + hi + 0.5 * (seg_end[j] - seg_start[j])
        if ux * ux + uy * uy > reach * reach:
            continue
        if segments_within(x0, y0, x1, y1, seg[j, 0], seg[j, 1], seg[j, 2], seg[j, 3], th):
            hit = True
            break
    if not hit:
        for k in range(fid_ptr[i], fid_ptr[i + 1]):
            f = fid_idx[k]
            if obstacle_distance(x0, y0, x1, y1, fid_xy[f, 0], fid_xy[f, 1],
                                  fid_end_xy[f, 0], fid_end_xy[f, 1]) \
                    <= bi + fid_buffer[f] + margin:
                hit = True
                break
    return -1 if hit else q


@njit(cache=True, inline="always")
def any_move_passes(cand, i, ca, cb, bx, by, s1, arr, par, rs, near):
    """Does any of the 9 candidates other than staying pass the step rule (margin MD)?"""
    step_deg, md, cd, sd, c2d, s2d, free_step, disp, near_ref = par
    for q in range(9):
        if cand[q, 0] == ca and cand[q, 1] == cb:
            continue
        if try_cand(cand, q, i, ca, cb, bx, by, s1, md, True, arr, par, rs, near) >= 0:
            return True
    return False
