"""MDP2, SDSS-V's production path generator (kaiju ``pathGenMDP2``), as a numba kernel.

The rules, as kaiju 1.4.1 applies them (``RobotGrid::pathGenMDP2`` / ``stepMDP2``):

* a *try* starts every robot from ``start``; step 0 moves nobody; at each later step the
  robots are visited in a new random order, each moving by at most ``step_deg`` per axis;
  the try succeeds after the first step at whose end every robot is at its destination;
* a robot is *encroached* when a neighbour's beta segment is closer than
  ``buffer_i + buffer_j + 20 MD`` (:data:`ENCROACH_MD`); at its destination and not
  encroached it stays; at its destination and encroached it becomes a *nudger* for good
  (the flag outlives the try);
* a robot that is neither a nudger nor encroached takes its obvious move (one step
  towards the destination on each axis, not overshooting) when that move collides with
  nothing;
* otherwise it visits the nine moves {-d, 0, +d}^2 (each clipped to not overshoot the
  destination and to the travel range: a robot outside it may not go further out) in
  random order, and the *first* move that collides ends the visit (kaiju's loop breaks
  there); of the moves visited before it, one that beats the best so far is taken, with
  probability ``greed`` for an encroached nudger (always otherwise). An encroached
  nudger scores by the energy sum 1/D^2 over its neighbours with probability
  ``phobia``, else (and every other robot always) by the squared angular distance to its
  destination. If no move is taken it stays;
* a move collides when its beta segment comes closer than ``buffer_i + buffer_j + MD`` to
  a neighbour's, closer than ``buffer_i + obstacle buffer + MD`` to an obstacle (kaiju
  leaves out MD there: ours is stricter by MD), or, for a robot beside a watched fiducial
  (``fiducialWatch``), when ``beta < 41.2853 - 1.3085 alpha`` in encoder angles
  (:data:`FW_C0`, :data:`FW_C1`; model angle = encoder angle + the robot's offset);
* a try that reaches ``max_steps`` fails; then the robot with the largest encoder beta
  among those away from their destinations and not yet nudgers becomes a nudger, and the
  next try starts (``tries`` in all, 5 in production with greed 0.7, phobia 0.6).

Speed: each robot keeps a *free window*, the steps during which it cannot be encroached
whatever its neighbours do (its smallest margin to the encroachment distance at its last
scan, less 2 MD a step: it and each neighbour move at most once a step, by at most MD).
Inside the window a robot at its destination stays without a look at its neighbours, and
any move of an unencroached robot cannot come within ``buffer_i + buffer_j + MD`` of a
neighbour (20 MD - MD > MD), so only its obstacles are checked. These shortcuts decide
exactly what kaiju's tests would: the plan is the same random process.

Units: angles in deg, lengths in mm, time in planner steps. Arrays as in
:func:`rfp_twin.planners.stepwise.kernel.run_stepwise`, plus ``watch`` (n,) bool and
``offset`` (n, 2) deg (model = encoder + offset).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from rfp_twin.models.geometry2d import point_segment_distance, segment_distance
from rfp_twin.planners.stepwise.kernel import record
from rfp_twin.planners.stepwise.mc_choice import uniform

#: kaiju's fiducialWatch zone: beta < FW_C0 + FW_C1 * alpha (encoder deg) is forbidden.
FW_C0 = 41.2853
FW_C1 = -1.3085
#: A robot is encroached by a neighbour closer than buffer_i + buffer_j + ENCROACH_MD * MD.
ENCROACH_MD = 20.0
#: SDSS-V production parameters (jaeger's configuration of kaiju).
GREED = 0.7
PHOBIA = 0.6
TRIES = 5
#: A neighbour whose base-distance bound is this far (mm) beyond the encroachment
#: distance is not measured exactly when a free window is computed.
FAR_MM = 3.0

__all__ = ["ENCROACH_MD", "FW_C0", "FW_C1", "GREED", "PHOBIA", "TRIES", "mdp2_kernel"]


@njit(cache=True, inline="always")
def segment_from_trig(bx, by, la, s0, s1, c_a, s_a, c_ab, s_ab):
    """Beta segment (x0, y0, x1, y1) mm and reach mm from cos/sin of alpha and alpha + beta."""
    ex = la * c_a
    ey = la * s_a
    x0 = ex + s0 * c_ab
    y0 = ey + s0 * s_ab
    x1 = ex + s1 * c_ab
    y1 = ey + s1 * s_ab
    rho = math.sqrt(max(x0 * x0 + y0 * y0, x1 * x1 + y1 * y1))
    return bx + x0, by + y0, bx + x1, by + y1, rho


@njit(cache=True, inline="always")
def rotate(c, s, k, rot):
    """(cos, sin) of an angle turned by k whole steps, k in -2..2; rot = (cos d, sin d,
    cos 2d, sin 2d) of the step d."""
    if k == 0:
        return c, s
    if k == 1:
        return c * rot[0] - s * rot[1], s * rot[0] + c * rot[1]
    if k == -1:
        return c * rot[0] + s * rot[1], s * rot[0] - c * rot[1]
    if k == 2:
        return c * rot[2] - s * rot[3], s * rot[2] + c * rot[3]
    return c * rot[2] + s * rot[3], s * rot[2] - c * rot[3]


@njit(cache=True, inline="always")
def trig_of(pa, pb, ka, kb, ca, cb, step_deg, trig, i, rot):
    """(cos a, sin a, cos(a + b), sin(a + b)) of the move (ca, cb) -> (pa, pb) deg: robot i's
    current ones (trig (n, 4)) turned by whole steps when the move is (ka, kb) steps,
    computed afresh when a clip made it shorter."""
    if pa == ca + ka * step_deg and pb == cb + kb * step_deg:
        c_a, s_a = rotate(trig[i, 0], trig[i, 1], ka, rot)
        c_ab, s_ab = rotate(trig[i, 2], trig[i, 3], ka + kb, rot)
        return c_a, s_a, c_ab, s_ab
    a = pa * (math.pi / 180.0)
    ab = a + pb * (math.pi / 180.0)
    return math.cos(a), math.sin(a), math.cos(ab), math.sin(ab)


@njit(cache=True, inline="always")
def watched_out(watch, offset, i, a, b):
    """True when robot i is watched and (a, b) model deg lies in kaiju's forbidden zone."""
    return watch[i] and (b - offset[i, 1]) < FW_C0 + FW_C1 * (a - offset[i, 0])


@njit(cache=True, inline="always")
def obstacle_hit(i, x0, y0, x1, y1, obs, buffer, md):
    """True when robot i's segment (x0, y0)-(x1, y1) is within buffer_i + keep-out + MD of
    one of its obstacles. obs = (fid_ptr, fid_idx, fid_xy, fid_end_xy, fid_buffer)."""
    fid_ptr, fid_idx, fid_xy, fid_end_xy, fid_buffer = obs
    for k in range(fid_ptr[i], fid_ptr[i + 1]):
        f = fid_idx[k]
        ax = fid_xy[f, 0]
        ay = fid_xy[f, 1]
        bx = fid_end_xy[f, 0]
        by = fid_end_xy[f, 1]
        if ax == bx and ay == by:
            d = point_segment_distance(ax, ay, x0, y0, x1, y1)
        else:
            d = segment_distance(x0, y0, x1, y1, ax, ay, bx, by)
        if d < buffer[i] + fid_buffer[f] + md:
            return True
    return False


@njit(cache=True, inline="always")
def robot_hit(i, x0, y0, x1, y1, rho_i, energy, nbr, seg, rho, buffer, md):
    """(collides, energy): whether robot i's segment comes within buffer_i + buffer_j + MD
    of a neighbour's, and (when ``energy``) the sum of 1/D^2 over its neighbours, mm^-2.
    nbr = (nbr_ptr, nbr_idx, nbr_dist)."""
    nbr_ptr, nbr_idx, nbr_dist = nbr
    e = 0.0
    for k in range(nbr_ptr[i], nbr_ptr[i + 1]):
        j = nbr_idx[k]
        thr = buffer[i] + buffer[j] + md
        if not energy and nbr_dist[k] - rho_i - rho[j] >= thr:
            continue
        d = segment_distance(x0, y0, x1, y1, seg[j, 0], seg[j, 1], seg[j, 2], seg[j, 3])
        if d < thr:
            return True, e
        e += 1.0 / (d * d)
    return False, e


@njit(cache=True, inline="always")
def near_list(i, nbr, seg, rho, buffer, md, close):
    """Robot i's neighbours that one move of it could bring within buffer_i + buffer_j +
    MD (closer than that + MD now) into ``close``; returns their number."""
    nbr_ptr, nbr_idx, nbr_dist = nbr
    m = 0
    for k in range(nbr_ptr[i], nbr_ptr[i + 1]):
        j = nbr_idx[k]
        thr = buffer[i] + buffer[j] + 2.0 * md
        if nbr_dist[k] - rho[i] - rho[j] >= thr:
            continue
        if segment_distance(seg[i, 0], seg[i, 1], seg[i, 2], seg[i, 3],
                            seg[j, 0], seg[j, 1], seg[j, 2], seg[j, 3]) < thr:
            close[m] = j
            m += 1
    return m


@njit(cache=True, inline="always")
def close_hit(i, x0, y0, x1, y1, close, m, seg, buffer, md):
    """True when robot i's segment comes within buffer_i + buffer_j + MD of one of the m
    neighbours listed in ``close``."""
    for k in range(m):
        j = close[k]
        if segment_distance(x0, y0, x1, y1, seg[j, 0], seg[j, 1], seg[j, 2],
                            seg[j, 3]) < buffer[i] + buffer[j] + md:
            return True
    return False


@njit(cache=True, inline="always")
def scan(i, nbr, seg, rho, buffer, md):
    """(encroached, margin mm): whether a neighbour is within buffer_i + buffer_j + 20 MD
    of robot i, and the smallest distance beyond that (a lower bound for far neighbours)."""
    nbr_ptr, nbr_idx, nbr_dist = nbr
    margin = 1e300
    for k in range(nbr_ptr[i], nbr_ptr[i + 1]):
        j = nbr_idx[k]
        thr = buffer[i] + buffer[j] + ENCROACH_MD * md
        g = nbr_dist[k] - rho[i] - rho[j] - thr
        if g < FAR_MM:
            g = segment_distance(seg[i, 0], seg[i, 1], seg[i, 2], seg[i, 3],
                                 seg[j, 0], seg[j, 1], seg[j, 2], seg[j, 3]) - thr
            if g < 0.0:
                return True, g
        if g < margin:
            margin = g
    return False, margin


@njit(cache=True, inline="always")
def quiet(i, nbr, moved_at, since):
    """True when neither robot i nor a neighbour has moved since move count ``since``."""
    nbr_ptr, nbr_idx, _ = nbr
    if since < 0 or moved_at[i] > since:
        return False
    for k in range(nbr_ptr[i], nbr_ptr[i + 1]):
        if moved_at[nbr_idx[k]] > since:
            return False
    return True


@njit(cache=True, inline="always")
def toward(cur, dest, step):
    """(angle, k): one step from cur towards dest, not overshooting (deg), and its
    direction k in (-1, 0, 1)."""
    if cur > dest:
        return max(cur - step, dest), -1
    if cur < dest:
        return min(cur + step, dest), 1
    return dest, 0


@njit(cache=True, inline="always")
def candidate(cur, delta, dest, lo, hi):
    """cur + delta clipped to not overshoot dest, then to the travel range [lo, hi] (a robot
    already outside it may not go further out), deg."""
    nxt = cur + delta
    if cur > dest and nxt <= dest:
        nxt = dest
    if cur < dest and nxt >= dest:
        nxt = dest
    if cur < lo and nxt < cur:
        nxt = cur
    elif cur > hi and nxt > cur:
        nxt = cur
    elif nxt > hi:
        nxt = hi
    elif nxt < lo:
        nxt = lo
    return nxt


@njit(cache=True, inline="always")
def shuffle(rng_state, a, n):
    """Fisher-Yates shuffle of the first n entries of the int64 array a, in place."""
    for k in range(n - 1, 0, -1):
        m = int(uniform(rng_state) * (k + 1))
        t = a[k]
        a[k] = a[m]
        a[m] = t


@njit(cache=True, _nrt=False)
def mdp2_kernel(geo, start, dest, movable, limits, watch, offset, step_deg, max_steps, md,
                greed, phobia, tries, rng_state, state, ev):
    """Run MDP2 (module docstring) from ``start`` towards ``dest``; compiled without numba's
    runtime (creates no arrays).

    Parameters
    ----------
    geo : (base_xy (n, 2) mm, alpha_len, seg_start, seg_end, buffer (n,) mm,
        (nbr_ptr, nbr_idx, nbr_dist) CSR robot neighbours with base distances (mm),
        (fid_ptr, fid_idx, fid_xy, fid_end_xy, fid_buffer) CSR obstacles)
    start, dest : (n, 2) model deg; movable (n,) bool (others never move: offline)
    limits : (n, 4) (alpha_lo, alpha_hi, beta_lo, beta_hi) model deg
    watch : (n,) bool; offset : (n, 2) deg, model = encoder + offset
    step_deg : float; max_steps : int, steps of a try; md : float, MD mm
    greed, phobia : float; tries : int; rng_state : (1,) uint64 splitmix64 state
    state : (cur (n, 2), trig (n, 4) cos/sin of alpha and alpha + beta, seg (n, 4), rho (n,),
        home (n,) bool, nudge (n,) bool in/out,
        free_until (n,) int64, order (n,) int64, perm (9,) int64, last (n, 2), moved_at (n,)
        int64 move count of each robot's last move, scan_at (n,) int64 move count at its
        last scan (-1: none), margins (n,) mm its margin then, close (n,) int64 scratch)
    ev : (ev_robot, ev_step (cap,) int64, ev_angles (cap, 2)): the last try's breakpoints

    Returns (n_events (-1: buffers overflowed), n_steps of the last try, tries made,
    converged).
    """
    base_xy, alpha_len, seg_start, seg_end, buffer, nbr, obs = geo
    (cur, trig, seg, rho, home, nudge, free_until, order, perm, last, moved_at, scan_at, margins,
     close) = state
    rot = (math.cos(step_deg * (math.pi / 180.0)), math.sin(step_deg * (math.pi / 180.0)),
           math.cos(2.0 * step_deg * (math.pi / 180.0)),
           math.sin(2.0 * step_deg * (math.pi / 180.0)))
    n = base_xy.shape[0]
    n_ev = 0
    step = 0
    n_mov = 0
    converged = False
    made = 0
    for t in range(tries):
        made = t + 1
        n_mov = 0
        n_left = 0
        n_ev = 0
        for i in range(n):
            cur[i, 0] = start[i, 0]
            cur[i, 1] = start[i, 1]
            a = start[i, 0] * (math.pi / 180.0)
            ab = a + start[i, 1] * (math.pi / 180.0)
            trig[i, 0] = math.cos(a)
            trig[i, 1] = math.sin(a)
            trig[i, 2] = math.cos(ab)
            trig[i, 3] = math.sin(ab)
            x0, y0, x1, y1, r = segment_from_trig(base_xy[i, 0], base_xy[i, 1], alpha_len[i],
                                                  seg_start[i], seg_end[i], trig[i, 0],
                                                  trig[i, 1], trig[i, 2], trig[i, 3])
            seg[i, 0] = x0
            seg[i, 1] = y0
            seg[i, 2] = x1
            seg[i, 3] = y1
            rho[i] = r
            home[i] = (not movable[i]) or (cur[i, 0] == dest[i, 0] and cur[i, 1] == dest[i, 1])
            free_until[i] = -1
            last[i, 0] = 0.0
            last[i, 1] = 0.0
            if movable[i]:
                order[n_mov] = i
                n_mov += 1
                if not home[i]:
                    n_left += 1
        step = 0
        n_moves = 0
        for i in range(n):
            moved_at[i] = 0
            scan_at[i] = -1
        while n_left > 0 and step < max_steps:
            step += 1
            shuffle(rng_state, order, n_mov)
            for p in range(n_mov):
                i = order[p]
                ca = cur[i, 0]
                cb = cur[i, 1]
                da = dest[i, 0]
                db = dest[i, 1]
                if step <= free_until[i]:
                    enc = False
                elif home[i] and quiet(i, nbr, moved_at, scan_at[i]):
                    # nothing around it moved since its scan: the same margin again
                    enc = False
                    free_until[i] = step + int(margins[i] / md - 1.0)
                else:
                    enc, margin = scan(i, nbr, seg, rho, buffer, md)
                    if not enc:
                        # it and each neighbour move at most MD a step (at home, only they do)
                        free_until[i] = step + int((margin / md - 1.0) * (1.0 if home[i] else 0.5))
                        margins[i] = margin
                        scan_at[i] = n_moves
                if home[i] and not enc:
                    continue
                if home[i]:
                    nudge[i] = True
                bx = base_xy[i, 0]
                by = base_xy[i, 1]
                la = alpha_len[i]
                s0 = seg_start[i]
                s1 = seg_end[i]
                moved = False
                na = ca
                nb = cb
                # a nudger that is not encroached and has nothing else to meet (no obstacle,
                # not watched) takes the least-cost move, the obvious one, as others do
                if not enc and (not nudge[i] or (not watch[i] and obs[0][i] == obs[0][i + 1])):
                    # the obvious move; an unencroached robot cannot reach a neighbour
                    na, ka = toward(ca, da, step_deg)
                    nb, kb = toward(cb, db, step_deg)
                    c_a, s_a, c_ab, s_ab = trig_of(na, nb, ka, kb, ca, cb, step_deg, trig, i, rot)
                    x0, y0, x1, y1, r = segment_from_trig(bx, by, la, s0, s1, c_a, s_a, c_ab, s_ab)
                    moved = not (watched_out(watch, offset, i, na, nb)
                                 or obstacle_hit(i, x0, y0, x1, y1, obs, buffer, md))
                m_close = 0
                if not moved and enc:
                    m_close = near_list(i, nbr, seg, rho, buffer, md, close)
                    if (m_close == 0 and not nudge[i] and not watch[i]
                            and obs[0][i] == obs[0][i + 1]):
                        # nothing within reach of its moves: the least-cost move, as above
                        na, ka = toward(ca, da, step_deg)
                        nb, kb = toward(cb, db, step_deg)
                        c_a, s_a, c_ab, s_ab = trig_of(na, nb, ka, kb, ca, cb, step_deg, trig,
                                                       i, rot)
                        x0, y0, x1, y1, r = segment_from_trig(bx, by, la, s0, s1, c_a, s_a,
                                                              c_ab, s_ab)
                        moved = True
                if not moved:
                    use_energy = False
                    g = 1.0
                    if nudge[i] and enc:
                        use_energy = uniform(rng_state) < phobia
                        g = greed
                    shuffle(rng_state, perm, 9)
                    best = 1e16
                    na = ca
                    nb = cb
                    bka = 0
                    bkb = 0
                    for q in range(9):
                        ka = perm[q] // 3 - 1
                        kb = perm[q] % 3 - 1
                        pa = candidate(ca, ka * step_deg, da, limits[i, 0], limits[i, 1])
                        pb = candidate(cb, kb * step_deg, db, limits[i, 2], limits[i, 3])
                        c_a, s_a, c_ab, s_ab = trig_of(pa, pb, ka, kb, ca, cb, step_deg, trig,
                                                       i, rot)
                        x0, y0, x1, y1, r = segment_from_trig(bx, by, la, s0, s1, c_a, s_a,
                                                              c_ab, s_ab)
                        if watched_out(watch, offset, i, pa, pb) or obstacle_hit(
                                i, x0, y0, x1, y1, obs, buffer, md):
                            break
                        e = 0.0
                        if use_energy:
                            hit, e = robot_hit(i, x0, y0, x1, y1, r, True, nbr, seg, rho,
                                               buffer, md)
                            if hit:
                                break
                        elif m_close > 0 and close_hit(i, x0, y0, x1, y1, close, m_close, seg,
                                                       buffer, md):
                            break
                        if use_energy:
                            score = e
                        else:
                            score = (pa - da) * (pa - da) + (pb - db) * (pb - db)
                        if score < best and (g >= 1.0 or uniform(rng_state) < g):
                            best = score
                            na = pa
                            nb = pb
                            bka = ka
                            bkb = kb
                    moved = na != ca or nb != cb
                    if moved:
                        c_a, s_a, c_ab, s_ab = trig_of(na, nb, bka, bkb, ca, cb, step_deg, trig,
                                                       i, rot)
                        x0, y0, x1, y1, r = segment_from_trig(bx, by, la, s0, s1, c_a, s_a,
                                                              c_ab, s_ab)
                if not moved:
                    n_ev = record(ev, last, i, step, ca, cb, 0.0, 0.0, n_ev)
                    continue
                n_ev = record(ev, last, i, step, ca, cb, na - ca, nb - cb, n_ev)
                cur[i, 0] = na
                cur[i, 1] = nb
                trig[i, 0] = c_a
                trig[i, 1] = s_a
                trig[i, 2] = c_ab
                trig[i, 3] = s_ab
                seg[i, 0] = x0
                seg[i, 1] = y0
                seg[i, 2] = x1
                seg[i, 3] = y1
                rho[i] = r
                n_moves += 1
                moved_at[i] = n_moves
                now_home = na == da and nb == db
                if now_home:
                    # its arrival is a breakpoint: it may wait here to the plan's end
                    n_ev = record(ev, last, i, step + 1, na, nb, 0.0, 0.0, n_ev)
                    n_left -= 1
                elif home[i]:
                    n_left += 1
                home[i] = now_home
        if n_left == 0:
            converged = True
            break
        if t + 1 < tries:
            # nudge the most folded robot (largest encoder beta) away from its destination
            pick = -1
            top = -1e300
            for p in range(n_mov):
                i = order[p]
                if not home[i] and not nudge[i] and cur[i, 1] - offset[i, 1] > top:
                    top = cur[i, 1] - offset[i, 1]
                    pick = i
            if pick >= 0:
                nudge[pick] = True
    return n_ev, step, made, converged
