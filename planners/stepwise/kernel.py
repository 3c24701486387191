"""The stepwise Greedy (GC) and Markov (MC) planners of Sayres 2021 Sect. 4: the numba kernel.

One call of :func:`run_stepwise` moves every robot from ``start`` towards ``dest`` in
steps of at most ``step_deg`` per axis, robot by robot in index order (Appendix A), and
records each robot's path as breakpoints: the configurations where its move vector
changes, so that linear interpolation between breakpoints on the step clock is exactly
the stepwise path.

Rules, as in the paper:

* candidates: the 9 moves {-d, 0, +d}^2, clipped to the travel limits and to not
  overshoot the destination;
* step rule (Eqs. 6-7): a candidate is allowed only if its beta capsule is farther than
  ``buffer_i + buffer_j + MD`` from every neighbour's (and ``buffer_i + fiducial_buffer
  + MD`` from every fiducial centre), MD = (l_alpha + l_beta) sin(2 d);
* GC: the allowed candidate of least cost C = |theta - theta_dest| (Eq. 8);
* MC: a robot at its destination stays unless a neighbour is within
  ``2 sigma + 3 MD`` (Eq. 10); otherwise with probability ``phobia`` it minimises the
  energy E = sum 1/D^2 (Eq. 9) instead of the cost, visits the candidates in random
  order, and accepts an allowed candidate that beats the best so far with probability
  ``greed`` (a tie with probability 1/2). greed = 1, phobia = 0 is GC.

Why a stepwise plan is collision-free in continuous time: every pair satisfies
D > 2 sigma + MD at every step state (each mover is checked against its neighbours'
latest states, and the pair's state after a step is the one checked last). Within a step
a point at distance r along the beta arm moves at most (l_alpha + 2 r) d (radians), so
the pair distance cannot drop by more than (l_alpha + 2 r_max) d below the mean of its
two end values, which MD covers whenever r_max <= l_beta + l_alpha / 2.
:func:`rfp_twin.planners.stepwise.moves.max_displacement` takes the larger of Eq. 7 and that
bound, so the guarantee holds for any segment.

Speed (see benchmarks/RESULTS.md): no arrays are created inside the step loop and the
helpers are closures (numba inlines them without reference counting); a robot whose best
candidate is to stay sleeps until one of its neighbours moves; candidates are tried in
order of cost so the obvious move is checked first; each robot keeps a short list of the
neighbours that can matter in the next NEAR_HORIZON steps, and two cheap disk bounds skip
most pairs before the exact segment test; trig functions of a candidate come from
rotating the current ones by one step. MC ranks the energy of its nine candidates by the
energy gradient (one pass over the neighbours instead of nine, no square roots). An MC
robot whose neighbours are all farther than two steps' motion beyond the step-rule
threshold is *free* for a computed number of steps: every candidate passes, so its
choice is drawn in one go from the sequential rule's closed form (``mc_pick_free``)
and only the chosen candidate's geometry is computed; about 97 % of MC visits are free
on the SDSS-V layout. Random numbers come from an inline splitmix64.

Units: angles in deg, lengths in mm, time in steps; array shapes in :func:`run_stepwise`.
:mod:`rfp_twin.planners.stepwise.run` calls the kernel on an array geometry.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from rfp_twin.models.geometry2d import (point_segment_distance, segment_closest_sq, segment_distance,
                               segments_within)
from rfp_twin.planners.stepwise.moves import ANGLE_EPS, DEG, _reach_from_cos, _rot, _sign, _toward

#: MC energy (Eq. 9) counts neighbours whose capsules may be nearer than this (mm).
ENERGY_CUTOFF_MM = 12.0
#: Steps for which a robot's short list of near neighbours stays valid.
NEAR_HORIZON = 32


@njit(cache=True)
def run_stepwise(base_xy, start, dest, movable, nbr_ptr, nbr_idx, nbr_dist,
                 fid_ptr, fid_idx, fid_xy, fid_buffer,
                 l_alpha, seg_start, seg_end, buffer, limits, step_deg, max_steps, md,
                 greed, phobia, seed, ev_robot, ev_step, ev_angles, cur):
    """Run GC/MC from ``start`` towards ``dest``.

    Parameters
    ----------
    base_xy : (n, 2) float64, mm
    start, dest : (n, 2) float64, (alpha, beta) deg
    movable : (n,) bool; robots that are False never move (offline robots)
    nbr_ptr, nbr_idx : CSR robot adjacency (Eq. 4), int64
    nbr_dist : (len(nbr_idx),) float64 base distance of each adjacency entry, mm
    fid_ptr, fid_idx : CSR robot -> fiducial index, int64; fid_xy (m, 2) mm
    fid_buffer : float, keep-out radius of fiducials, mm
    l_alpha, seg_start : float, mm
    seg_end, buffer : (n,) float64, mm (per robot)
    limits : (4,) float64 (alpha_lo, alpha_hi, beta_lo, beta_hi), deg
    step_deg : float; max_steps : int; md : float, mm (:func:`max_displacement`)
    greed : (n,) float64 in [0, 1]; phobia : float in [0, 1]; greed 1 and phobia 0
        everywhere selects the deterministic greedy planner
    seed : int, seeds the kernel's splitmix64 generator (used by MC only)
    ev_robot, ev_step : (cap,) int64; ev_angles : (cap, 2) float64
        Output buffers for breakpoints: robot, step index, (alpha, beta).
    cur : (n, 2) float64, output: final configuration.

    Returns
    -------
    n_events : int, number of breakpoints written (-1 if the buffers overflowed)
    n_steps : int, steps taken
    """
    rng_state = np.empty(1, dtype=np.uint64)
    rng_state[0] = np.uint64(seed) * np.uint64(0x9E3779B97F4A7C15) + np.uint64(0x2545F4914F6CDD1D)
    n = base_xy.shape[0]
    cap = ev_robot.shape[0]
    greedy = phobia <= 0.0
    for i in range(n):
        if greed[i] < 1.0:
            greedy = False
    a_lo = limits[0]
    a_hi = limits[1]
    b_lo = limits[2]
    b_hi = limits[3]
    cd = math.cos(step_deg * DEG)
    sd = math.sin(step_deg * DEG)
    c2d = math.cos(2.0 * step_deg * DEG)
    s2d = math.sin(2.0 * step_deg * DEG)
    s0 = seg_start

    # per-robot state: (cos a, sin a, cos(a+b), sin(a+b), cos b, sin b), segment, reach
    trig = np.empty((n, 6))
    seg = np.empty((n, 4))
    rho = np.empty(n)
    last = np.zeros((n, 2))
    home = np.zeros(n, dtype=np.bool_)
    asleep_at = np.full(n, -1, dtype=np.int64)  # move counter when the robot fell asleep
    moved_at = np.zeros(n, dtype=np.int64)      # move counter of the robot's last move
    # short lists of the neighbours that can matter in the next NEAR_HORIZON steps
    max_deg = 1
    for i in range(n):
        max_deg = max(max_deg, nbr_ptr[i + 1] - nbr_ptr[i])
    near_k = np.empty((n, max_deg), dtype=np.int64)   # CSR entries of the near neighbours
    near_cnt = np.zeros(n, dtype=np.int64)
    near_col = np.zeros(n, dtype=np.int64)           # how many of them the step rule needs
    near_until = np.zeros(n, dtype=np.int64)          # step at which the list expires
    near_ref = 0.0 if greedy else ENERGY_CUTOFF_MM    # MC energy needs neighbours to the cutoff
    home_until = np.zeros(n, dtype=np.int64)          # MC: parked robot needs no Eq. 10 check
    free_until = np.zeros(n, dtype=np.int64)          # MC: every candidate passes the step rule
    s1_max = 0.0
    for i in range(n):
        s1_max = max(s1_max, seg_end[i], seg_start)
    free_step = 2.0 * s1_max * step_deg * DEG * 1.001
    # largest displacement of any point of a beta segment in one step (both axes), mm
    disp = (l_alpha + 2.0 * s1_max) * step_deg * DEG * 1.001
    axis_val = np.empty(6)   # per-axis candidate angles (alpha: 0..2, beta: 3..5)
    axis_err = np.empty(6)   # their squared errors to the destination
    cand = np.empty((9, 13))  # na, nb, cos a, sin a, cos ab, sin ab, cos b, sin b, segment, reach
    cost = np.empty(9)
    score_of = np.empty(9)   # MC: each candidate's score (cost or linearised energy)
    order = np.empty(9, dtype=np.int64)

    def uniform():
        """A uniform double in [0, 1): splitmix64 (Steele, Lea & Flood 2014) on rng_state.

        About 2 ns against 6.5 ns for numba's uniform(), which fetches its
        thread-local state on every call; MC draws about five numbers per robot visit.
        """
        z = rng_state[0] + np.uint64(0x9E3779B97F4A7C15)
        rng_state[0] = z
        z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
        z = z ^ (z >> np.uint64(31))
        return np.int64(z >> np.uint64(11)) * (1.0 / 9007199254740992.0)

    def mc_pick_free(g):
        """MC's choice among the 9 candidates when all pass the step rule; -1 = none.

        The sequential rule (random order; a candidate that beats the best so far is
        taken with probability g, one that ties it with probability 1/2) picks candidate
        x with probability (1 - g)^(number of strictly better candidates) *
        (1 - (1 - g)^k) / k, k = the number of candidates tied with x, and none with
        probability (1 - g)^9. (No better candidate is ever taken iff each of them
        failed its one coin, whatever the order; given that, x's score class is taken
        iff one of its k members passed its coin; members of a class are exchangeable.)
        So one draw suffices: the rank p of the first success of i.i.d. g-coins down the
        sorted scores, then a uniform member of the class holding rank p.
        tests/planners/test_stepwise_kernel.py checks the kernel against the sequential rule.
        """
        u = uniform()
        f = 1.0 - g
        p = 0
        hi = 1.0
        lo = f
        while p < 9 and u < lo:     # P(p >= t) = f^t
            p += 1
            hi = lo
            lo *= f
        if p >= 9:
            return -1
        v = (u - lo) / (hi - lo) if hi > lo else 0.0   # uniform in [0, 1) again
        # the score at sorted rank p: p + 1 passes of selection (p is 0 nine times in ten)
        val = -1e300
        below = 0          # candidates with score < val
        while True:
            nxt = 1e300
            for q in range(9):
                sq = score_of[q]
                if sq > val and sq < nxt:
                    nxt = sq
            k = 0
            for q in range(9):
                if score_of[q] == nxt:
                    k += 1
            if below + k > p:
                val = nxt
                break
            below += k
            val = nxt
        m = min(int(v * k), k - 1)
        for q in range(9):
            if score_of[q] == val:
                if m == 0:
                    return q
                m -= 1
        return -1

    def cand_trig(q, na, nb):
        """Candidate q's trig functions (cand[q, 2:8]) of (na, nb) deg, computed afresh."""
        a = na * DEG
        b = nb * DEG
        cand[q, 2] = math.cos(a)
        cand[q, 3] = math.sin(a)
        cand[q, 4] = math.cos(a + b)
        cand[q, 5] = math.sin(a + b)
        cand[q, 6] = math.cos(b)
        cand[q, 7] = math.sin(b)

    def cand_segment(q, bx, by, s1):
        """Candidate q's beta segment (cand[q, 8:12]) and reach (cand[q, 12]) from its trig."""
        ex = bx + l_alpha * cand[q, 2]
        ey = by + l_alpha * cand[q, 3]
        cand[q, 8] = ex + s0 * cand[q, 4]
        cand[q, 9] = ey + s0 * cand[q, 5]
        cand[q, 10] = ex + s1 * cand[q, 4]
        cand[q, 11] = ey + s1 * cand[q, 5]
        cand[q, 12] = _reach_from_cos(l_alpha, s0, s1, cand[q, 6])

    def try_cand(q, i, ca, cb, bx, by, s1, margin, step, check=True):
        """Fill candidate q's state; return q if it passes the step rule, else -1.

        Only robot i's short list of near neighbours is scanned (see ``refresh_near``).
        """
        na = cand[q, 0]
        nb = cand[q, 1]
        ka = _sign(na - ca)
        kb = _sign(nb - cb)
        exact = (ka != 0 and abs(abs(na - ca) - step_deg) > ANGLE_EPS) or \
                (kb != 0 and abs(abs(nb - cb) - step_deg) > ANGLE_EPS)
        if exact:
            cand_trig(q, na, nb)
        else:
            c, s = _rot(trig[i, 0], trig[i, 1], ka, cd, sd, c2d, s2d)
            cand[q, 2] = c
            cand[q, 3] = s
            c, s = _rot(trig[i, 2], trig[i, 3], ka + kb, cd, sd, c2d, s2d)
            cand[q, 4] = c
            cand[q, 5] = s
            c, s = _rot(trig[i, 4], trig[i, 5], kb, cd, sd, c2d, s2d)
            cand[q, 6] = c
            cand[q, 7] = s
        cand_segment(q, bx, by, s1)
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
            reach = th + hi + 0.5 * (seg_end[j] - s0)
            if ux * ux + uy * uy > reach * reach:
                continue
            if segments_within(x0, y0, x1, y1, seg[j, 0], seg[j, 1], seg[j, 2], seg[j, 3], th):
                hit = True
                break
        if not hit:
            th = bi + fid_buffer + margin
            for k in range(fid_ptr[i], fid_ptr[i + 1]):
                f = fid_idx[k]
                if point_segment_distance(fid_xy[f, 0], fid_xy[f, 1], x0, y0, x1, y1) <= th:
                    hit = True
                    break
        return -1 if hit else q

    def refresh_near(i, step):
        """Rebuild robot i's short list of the neighbours that can matter.

        A neighbour is left out when its base-disk bound |b_i - b_j| - rho_i - rho_j
        exceeds what matters (the step-rule threshold; for MC also the energy cutoff) by
        more than NEAR_HORIZON * free_step. The bound shrinks by at most free_step per
        step (each reach changes by at most seg_end * step) and candidates are one step
        away, so the list holds NEAR_HORIZON - 2 steps. The list is ordered: first the
        neighbours that can matter to the step rule (``near_col[i]`` of them, all that
        try_cand scans), then those that only the MC energy needs.
        """
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

    def free_window(i, step):
        """MC: how many steps from now every candidate of robot i surely passes the step rule.

        slack = min over the step-rule neighbours (and fiducials) of distance - threshold,
        from the base-disk bound where that suffices, else the exact segment distance.
        Between now and the visit k steps later each of the two segments moves by at
        most (k + 1) ``disp`` (k committed steps plus the candidate), so every candidate
        passes while 2 (k + 1) disp < slack. The short list bounds the window: a
        neighbour outside it cannot come within reach before ``near_until[i]``.
        """
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
        th = bi + fid_buffer + md
        for k in range(fid_ptr[i], fid_ptr[i + 1]):
            f = fid_idx[k]
            g = point_segment_distance(fid_xy[f, 0], fid_xy[f, 1],
                                       seg[i, 0], seg[i, 1], seg[i, 2], seg[i, 3]) - th
            if g <= need:
                return 0
            slack = min(slack, g)
        w = int(min(slack / need, 1e9) * (1.0 - 1e-9))
        return min(w, near_until[i] - step)

    def encroached(i, margin, step):
        """Eq. 10: is any neighbour within buffer_i + buffer_j + margin of robot i now?

        When none is, robot i (parked at home) cannot be encroached before every base-disk
        bound has shrunk to the threshold; only neighbours move, each reach by at most
        free_step / 2 per step, so no check is needed until ``home_until[i]``.
        """
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

    def energy_gradient(i, s1, step):
        """Eq. 9 energy E = sum 1/D^2 of robot i now, and dE/dalpha, dE/dbeta (per deg).

        The nine candidates differ from the current state by at most one step, so the MC
        planner ranks them by E + grad . (dalpha, dbeta): one pass over the neighbours
        instead of nine. By the envelope theorem dD/dtheta is the motion of robot i's
        closest point along the unit vector between the closest points. Neighbours whose
        disk bound is beyond ENERGY_CUTOFF_MM are left out: their term changes between
        candidates by < 2 MD / cutoff^3, too little to reorder what near ones separate.
        """
        e = 0.0
        ga = 0.0
        gb = 0.0
        ca_ = trig[i, 0]
        sa_ = trig[i, 1]
        cab = trig[i, 2]
        sab = trig[i, 3]
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

    def commit(i, q):
        """Copy candidate q's state into robot i's state."""
        for k in range(6):
            trig[i, k] = cand[q, 2 + k]
        for k in range(4):
            seg[i, k] = cand[q, 8 + k]
        rho[i] = cand[q, 12]

    def record(i, step, ca, cb, ma, mb, n_ev):
        """Breakpoint at (step - 1, current angles) when robot i's move vector changes."""
        if n_ev < 0:
            return n_ev
        if abs(ma - last[i, 0]) > ANGLE_EPS or abs(mb - last[i, 1]) > ANGLE_EPS:
            if n_ev >= cap:
                return -1
            ev_robot[n_ev] = i
            ev_step[n_ev] = step - 1
            ev_angles[n_ev, 0] = ca
            ev_angles[n_ev, 1] = cb
            last[i, 0] = ma
            last[i, 1] = mb
            return n_ev + 1
        return n_ev

    # initial state: each robot's trig, segment and reach, as for a candidate
    n_left = 0
    for i in range(n):
        cur[i, 0] = start[i, 0]
        cur[i, 1] = start[i, 1]
        cand_trig(0, cur[i, 0], cur[i, 1])
        cand_segment(0, base_xy[i, 0], base_xy[i, 1], seg_end[i])
        commit(i, 0)
        home[i] = abs(cur[i, 0] - dest[i, 0]) < ANGLE_EPS and abs(cur[i, 1] - dest[i, 1]) < ANGLE_EPS
        if movable[i] and not home[i]:
            n_left += 1

    n_moves = 1
    n_ev = 0
    step = 0
    n_awake = 1
    moves_before = -1
    while step < max_steps and n_left > 0:
        # quiescent: nothing moved and nobody awake -> nothing can ever change
        if n_moves == moves_before and n_awake == 0:
            break
        moves_before = n_moves
        n_awake = 0
        step += 1
        for i in range(n):
            if not movable[i] or (greedy and home[i]) or step < home_until[i]:
                continue
            if asleep_at[i] >= 0:
                woken = False
                for k in range(nbr_ptr[i], nbr_ptr[i + 1]):
                    if moved_at[nbr_idx[k]] > asleep_at[i]:
                        woken = True
                        break
                if not woken:
                    continue
                asleep_at[i] = -1
            if step >= near_until[i]:
                refresh_near(i, step)
            ca = cur[i, 0]
            cb = cur[i, 1]
            da = dest[i, 0]
            db = dest[i, 1]
            bx = base_xy[i, 0]
            by = base_xy[i, 1]
            s1 = seg_end[i]
            bi = buffer[i]

            if home[i]:
                # MC only (Eq. 10): stay unless a neighbour encroaches
                if not encroached(i, 3.0 * md, step):
                    asleep_at[i] = n_moves
                    n_ev = record(i, step, ca, cb, 0.0, 0.0, n_ev)
                    continue

            best = -1
            n_valid_moves = 0
            free = False
            ka_best = _sign(da - ca)
            kb_best = _sign(db - cb)
            if greedy:
                # the obvious move (best step on each axis) has the least cost: try it first
                cand[0, 0] = _toward(ca, da, ka_best, step_deg, a_lo, a_hi)
                cand[0, 1] = _toward(cb, db, kb_best, step_deg, b_lo, b_hi)
                best = try_cand(0, i, ca, cb, bx, by, s1, md, step)
            if best < 0:
                # all 9 moves in {-d, 0, +d}^2, clipped
                for u in range(3):
                    na = _toward(ca, da, u - 1, step_deg, a_lo, a_hi)
                    nb = _toward(cb, db, u - 1, step_deg, b_lo, b_hi)
                    axis_val[u] = na
                    axis_val[3 + u] = nb
                    axis_err[u] = (na - da) * (na - da)
                    axis_err[3 + u] = (nb - db) * (nb - db)
                c = 0
                for ua in range(3):
                    for ub in range(3):
                        cand[c, 0] = axis_val[ua]
                        cand[c, 1] = axis_val[3 + ub]
                        cost[c] = axis_err[ua] + axis_err[3 + ub]
                        order[c] = c
                        c += 1
                obvious = 3 * (ka_best + 1) + kb_best + 1
            if greedy and best < 0:
                for p in range(1, 9):
                    q = order[p]
                    r = p - 1
                    while r >= 0 and cost[order[r]] > cost[q]:
                        order[r + 1] = order[r]
                        r -= 1
                    order[r + 1] = q
                for p in range(9):
                    q = order[p]
                    if q == obvious:
                        continue
                    if cand[q, 0] == ca and cand[q, 1] == cb:
                        break  # staying beats every remaining candidate
                    best = try_cand(q, i, ca, cb, bx, by, s1, md, step)
                    if best >= 0:
                        break
            elif not greedy:
                # Markov chain (Sect. 4.2): energy or cost; candidates in random order,
                # each that beats the best so far taken with probability greed
                use_energy = uniform() < phobia
                if step >= free_until[i]:
                    w = free_window(i, step)
                    if w > 0:
                        free_until[i] = step + w
                free = step < free_until[i]
                if use_energy:
                    e0, ga, gb = energy_gradient(i, s1, step)
                for q in range(9):
                    if use_energy:
                        score_of[q] = e0 + ga * (cand[q, 0] - ca) + gb * (cand[q, 1] - cb)
                    else:
                        score_of[q] = cost[q]
                if free:
                    best = mc_pick_free(greed[i])
                    if best >= 0:
                        try_cand(best, i, ca, cb, bx, by, s1, md, step, False)  # its state only
                else:
                    # a uniform random order of the 9 candidates from one draw: Fisher-Yates
                    # with the indices read as mixed-radix digits of one uniform double
                    # (9! needs 19 of its 53 bits; no integer division)
                    x = uniform()
                    for p in range(9):
                        order[p] = p
                    for p in range(8, 0, -1):
                        x *= p + 1
                        r = int(x)
                        x -= r
                        t = order[p]
                        order[p] = order[r]
                        order[r] = t
                    best_score = 1e300
                    for p in range(9):
                        q = order[p]
                        score = score_of[q]
                        take = False
                        if score < best_score:
                            take = uniform() < greed[i]
                        elif score == best_score:
                            take = uniform() < 0.5
                        # the step rule is checked only for a candidate that would be
                        # taken; the outcome is the same as checking every candidate first
                        if not take or try_cand(q, i, ca, cb, bx, by, s1, md, step) < 0:
                            continue
                        if not (cand[q, 0] == ca and cand[q, 1] == cb):
                            n_valid_moves += 1
                        best = q
                        best_score = score

            if best < 0 or (cand[best, 0] == ca and cand[best, 1] == cb):
                # stay. GC: the choice cannot change until a neighbour moves, so sleep.
                # MC: sleep only when no move at all passes the step rule.
                sleep = greedy
                if not greedy and n_valid_moves == 0 and not free:
                    sleep = True
                    for q in range(9):
                        if cand[q, 0] == ca and cand[q, 1] == cb:
                            continue
                        if try_cand(q, i, ca, cb, bx, by, s1, md, step) >= 0:
                            sleep = False
                            break
                if sleep:
                    asleep_at[i] = n_moves
                else:
                    n_awake += 1
                n_ev = record(i, step, ca, cb, 0.0, 0.0, n_ev)
                continue

            # commit the move (cand row holds the segment state computed by try_cand)
            na = cand[best, 0]
            nb = cand[best, 1]
            n_ev = record(i, step, ca, cb, na - ca, nb - cb, n_ev)
            cur[i, 0] = na
            cur[i, 1] = nb
            commit(i, best)
            n_moves += 1
            moved_at[i] = n_moves
            n_awake += 1
            now_home = abs(na - da) < ANGLE_EPS and abs(nb - db) < ANGLE_EPS
            if now_home and not home[i]:
                n_left -= 1
            elif home[i] and not now_home:
                n_left += 1
            home[i] = now_home
    return n_ev, step
