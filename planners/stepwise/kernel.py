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
  ``buffer_i + buffer_j + MD`` from every neighbour's (and ``buffer_i + fid_buffer_f
  + MD`` from every obstacle f: a fiducial's centre, a guide-camera edge's segment),
  MD = (l_alpha + l_beta) sin(2 d);
* per-robot geometry: robot i's capsule is the segment ``seg_start[i]``..``seg_end[i]``
  along its beta arm, which sits ``alpha_len[i]`` from its base, thickened by
  ``buffer[i]`` (a calibrated instrument's robots differ; a nominal array's agree);
* GC: the allowed candidate of least cost C = |theta - theta_dest| (Eq. 8);
* MC: a robot at its destination stays unless a neighbour is within
  ``2 sigma + 3 MD`` (Eq. 10); otherwise with probability ``phobia`` it minimises the
  energy E = sum 1/D^2 (Eq. 9) instead of the cost, visits the candidates in random
  order, and accepts an allowed candidate that beats the best so far with probability
  ``greed`` (a tie with probability 1/2). greed = 1, phobia = 0 is GC;
* greed and phobia are per robot, so one run may mix GC robots with MC ones; an MC robot
  marked ``greedy_first`` takes its obvious move whenever it passes the step rule and
  uses the MC rules only when that move is blocked or when it is home (the deadlock
  re-runs of :mod:`rfp_twin.planners.deadlocks.rerun`).

Why a stepwise plan is collision-free in continuous time: every pair satisfies
D > 2 sigma + MD at every step state (each mover is checked against its neighbours'
latest states, and the pair's state after a step is the one checked last). Within a step
a point at distance r along the beta arm moves at most (l_alpha + 2 r) d (radians), so
the pair distance cannot drop by more than (l_alpha + 2 r_max) d below the mean of its
two end values, which MD covers whenever r_max <= l_beta + l_alpha / 2.
:func:`rfp_twin.planners.stepwise.moves.max_displacement` takes the larger of Eq. 7 and that
bound, so the guarantee holds for any segment; with per-robot arms one MD must cover
every robot, so :func:`rfp_twin.planners.stepwise.moves.array_max_displacement` takes the
longest alpha arm and farthest segment point of the array. An obstacle does not move, so
the same margin covers it.

Speed (see benchmarks/RESULTS.md): the step loop (:func:`step_loop`) creates no arrays
and counts no references. :func:`run_stepwise` allocates the state first
(:mod:`~rfp_twin.planners.stepwise.state`); the loop is compiled without numba's runtime
(numba's ``_nrt=False`` option) and its helpers are ``inline="always"``: a helper called
as a function, or inlined into a function with the runtime, counts references to each
array it is passed on every call, which made the greedy planner 1.7-2.3 times slower. In
the loop, a robot whose best candidate is to stay sleeps until one of its neighbours
moves; candidates are tried in order of cost so the obvious move is checked first; each
robot keeps a short list of the neighbours that can matter in the next NEAR_HORIZON
steps, and two cheap disk bounds skip most pairs before the exact segment test; trig
functions of a candidate come from rotating the current ones by one step. MC ranks the
energy of its nine candidates by the energy gradient (one pass over the neighbours
instead of nine, no square roots). An MC robot whose neighbours are all farther than two
steps' motion beyond the step-rule threshold is *free* for a computed number of steps:
every candidate passes, so its choice is drawn in one go from the sequential rule's
closed form (``mc_pick_free``) and only the chosen candidate's geometry is computed;
about 97 % of MC visits are free on the SDSS-V layout. Random numbers come from an
inline splitmix64.

Where the helpers live (modules of :mod:`rfp_twin.planners.stepwise`):

* ``candidates``: the nine candidates and their cost (``fill_candidates``,
  ``sort_by_cost``), their geometry (``cand_trig``, ``cand_segment``, ``commit``) and
  the step rule (``try_cand``, ``any_move_passes``); it describes the state tuples;
* ``neighbours``: the short lists (``refresh_near``), the MC free window
  (``free_window``), Eq. 10 (``encroached``), the Eq. 9 energy gradient
  (``energy_gradient``), waking (``woken``);
* ``mc_choice``: splitmix64 (``uniform``) and MC's choice (``mc_pick_free``,
  ``random_order``, ``mc_pick_sequential``);
* ``state``: the state's allocation and initial values (``new_state``);
* ``moves``: the scalar helpers (``step_toward``, ``rotate_steps``, ``direction_sign``, ``segment_reach``);
* here: :func:`run_stepwise` (scalar geometry broadcast to per-robot arrays),
  :func:`run_stepwise_arrays` (the compiled kernel), :func:`step_loop` and ``record``.

After editing a helper, delete this folder's numba caches (``__pycache__/*.nbi``,
``*.nbc``): the cache of a function does not notice changes in the helpers it inlined.

Units: angles in deg, lengths in mm, time in steps; array shapes in :func:`run_stepwise`.
:mod:`rfp_twin.planners.stepwise.run` calls the kernel on an array geometry.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from rfp_twin.models.kernel_cache import call_kernel
from rfp_twin.planners.stepwise.candidates import (any_move_passes, commit, fill_candidates,
                                                   sort_by_cost, try_cand)
from rfp_twin.planners.stepwise.mc_choice import mc_pick_free, mc_pick_sequential, uniform
from rfp_twin.planners.stepwise.moves import ANGLE_EPS, direction_sign, step_toward
from rfp_twin.planners.stepwise.neighbours import (ENERGY_CUTOFF_MM, NEAR_HORIZON, encroached,
                                                   energy_gradient, free_window, refresh_near, woken)
from rfp_twin.planners.stepwise.state import new_state

__all__ = ["ENERGY_CUTOFF_MM", "NEAR_HORIZON", "run_stepwise", "run_stepwise_arrays",
           "step_loop"]


@njit(cache=True, inline="always")
def record(ev, last, i, step, ca, cb, ma, mb, n_ev):
    """Breakpoint at (step - 1, current angles) when robot i's move vector changes.

    ev = (ev_robot, ev_step, ev_angles), the output buffers; last (n, 2) deg, each
    robot's move vector at its latest breakpoint; (ma, mb) deg, the move vector now.
    Returns the new breakpoint count (-1 once the buffers have overflowed).
    """
    ev_robot, ev_step, ev_angles = ev
    if n_ev < 0:
        return n_ev
    if abs(ma - last[i, 0]) > ANGLE_EPS or abs(mb - last[i, 1]) > ANGLE_EPS:
        if n_ev >= ev_robot.shape[0]:
            return -1
        ev_robot[n_ev] = i
        ev_step[n_ev] = step - 1
        ev_angles[n_ev, 0] = ca
        ev_angles[n_ev, 1] = cb
        last[i, 0] = ma
        last[i, 1] = mb
        return n_ev + 1
    return n_ev


def _per_item(x, n: int, shape: tuple = ()) -> np.ndarray:
    """``x`` (a scalar or an array) as a C-contiguous float64 array of shape (n, *shape):
    ``x`` itself when it already is one, else a new array."""
    a = np.asarray(x, dtype=np.float64)
    if a.shape == (n, *shape) and a.flags.c_contiguous:
        return a
    return np.array(np.broadcast_to(a, (n, *shape)))


def run_stepwise(base_xy, start, dest, movable, nbr_ptr, nbr_idx, nbr_dist,
                 fid_ptr, fid_idx, fid_xy, fid_buffer,
                 alpha_len, seg_start, seg_end, buffer, limits, step_deg, max_steps, md,
                 greed, phobia, seed, ev_robot, ev_step, ev_angles, cur, fid_end_xy=None,
                 greedy_first=None, script=None, beta_first=None):
    """Run GC/MC from ``start`` towards ``dest``: :func:`run_stepwise_arrays` on per-robot arrays.

    Parameters
    ----------
    base_xy : (n, 2) float64, mm
    start, dest : (n, 2) float64, (alpha, beta) deg
    movable : (n,) bool; robots that are False never move (offline robots)
    nbr_ptr, nbr_idx : CSR robot adjacency (Eq. 4), int64
    nbr_dist : (len(nbr_idx),) float64 base distance of each adjacency entry, mm
    fid_ptr, fid_idx : CSR robot -> obstacle index, int64; fid_xy (m, 2) mm, each
        obstacle's centre (a fiducial) or first end (a segment)
    fid_buffer : float or (m,) float64, keep-out radius of each obstacle, mm
    alpha_len, seg_start : float or (n,) float64, each robot's alpha arm and the start of
        its beta collision segment, mm
    seg_end, buffer : float or (n,) float64, end of each robot's segment and its buffer, mm
    limits : (4,) or (n, 4) float64 (alpha_lo, alpha_hi, beta_lo, beta_hi), deg: one
        range for all or each robot's (:attr:`rfp_twin.models.array.ArrayGeometry.limits`)
    step_deg : float; max_steps : int; md : float, step-rule margin MD, mm
        (:func:`rfp_twin.planners.stepwise.moves.array_max_displacement`)
    greed, phobia : (n,) float64 in [0, 1], each robot's Markov parameters; a robot with
        greed 1 and phobia 0 follows the deterministic greedy rules, the others the
        Markov chain's (one run may mix them)
    seed : int, seeds the kernel's splitmix64 generator (used by MC only)
    ev_robot, ev_step : (cap,) int64; ev_angles : (cap, 2) float64
        Output buffers for breakpoints: robot, step index, (alpha, beta).
    cur : (n, 2) float64, output: final configuration.
    fid_end_xy : (m, 2) float64 or None, second end of each obstacle, mm [default: the
        obstacles are points, ``fid_xy``]
    greedy_first : (n,) bool or None, Markov robots (greed < 1 or phobia > 0) that take
        their obvious move (one step towards the destination on each axis) whenever it
        passes the step rule, and make a Markov move only when it is blocked or when
        they are at their destination [default: none; greedy robots always do]
    script : (ptr (n+1,) int64, steps (k,) float64, angles (k, 2) float64) or None, a
        recorded path (CSR, :func:`rfp_twin.planners.plan.build_paths`) for each robot that
        *replays* one instead of planning: at step s it moves to its path's angles at s
        (linear between breakpoints, the last ones after the path's end), each move
        checked by the step rule against the robots around it, until the last replayed
        move (even past ``max_steps``, which then only bounds the planning); robots with
        an empty row plan as usual. A replayed robot must be given ``movable`` False (it
        is not waited for) and gets no breakpoints. [default: nobody replays]
    beta_first : (n,) bool or None, robots whose obvious move holds alpha while beta is
        away from its destination (greedy and greedy-first robots); when that beta-only
        move is blocked they move as usual [default: none]

    Returns
    -------
    n_events : int, number of breakpoints written (-1 if the buffers overflowed, -2 if
        a replayed move failed the step rule: the robots around it left no room)
    n_steps : int, steps taken
    """
    n = base_xy.shape[0]
    fid_xy = _per_item(fid_xy, fid_xy.shape[0], (2,))
    m = fid_xy.shape[0]
    fid_end_xy = fid_xy if fid_end_xy is None else _per_item(fid_end_xy, m, (2,))
    greedy_first = np.zeros(n, np.bool_) if greedy_first is None else \
        np.ascontiguousarray(greedy_first, dtype=np.bool_)
    beta_first = np.zeros(n, np.bool_) if beta_first is None else \
        np.ascontiguousarray(beta_first, dtype=np.bool_)
    if script is None:
        script = (np.zeros(n + 1, np.int64), np.zeros(0), np.zeros((0, 2)))
    script = (np.ascontiguousarray(script[0], dtype=np.int64),
              np.ascontiguousarray(script[1], dtype=np.float64),
              np.ascontiguousarray(script[2], dtype=np.float64))
    return call_kernel(
        run_stepwise_arrays, base_xy, start, dest, movable, nbr_ptr, nbr_idx, nbr_dist,
        fid_ptr, fid_idx, fid_xy, fid_end_xy, _per_item(fid_buffer, m), _per_item(alpha_len, n),
        _per_item(seg_start, n), _per_item(seg_end, n), _per_item(buffer, n),
        _per_item(limits, n, (4,)), step_deg, max_steps, md, _per_item(greed, n),
        _per_item(phobia, n), seed, ev_robot, ev_step, ev_angles, cur, greedy_first, script,
        beta_first)


@njit(cache=True, nogil=True)
def run_stepwise_arrays(base_xy, start, dest, movable, nbr_ptr, nbr_idx, nbr_dist,
                        fid_ptr, fid_idx, fid_xy, fid_end_xy, fid_buffer,
                        alpha_len, seg_start, seg_end, buffer, limits, step_deg, max_steps, md,
                        greed, phobia, seed, ev_robot, ev_step, ev_angles, cur, greedy_first,
                        script, beta_first):
    """The compiled kernel of :func:`run_stepwise`, every geometry argument an array.

    Arguments as in :func:`run_stepwise`, except: ``fid_end_xy`` (m, 2) float64 mm (equal
    to ``fid_xy`` for a point obstacle), ``fid_buffer`` (m,) float64 mm, ``alpha_len``,
    ``seg_start``, ``seg_end``, ``buffer`` (n,) float64 mm, ``limits`` (n, 4) float64 deg,
    ``greed``, ``phobia`` (n,) float64, ``greedy_first`` (n,) bool, ``script`` the
    3-tuple of arrays (an all-zero ptr: nobody replays).
    Returns (n_events, n_steps).
    """
    greedy, n_left, rng_state, par, rs, near, sched, scratch = new_state(
        base_xy, start, dest, movable, nbr_ptr, alpha_len, seg_start, seg_end,
        step_deg, md, greed, phobia, seed, cur)
    arr = (base_xy, nbr_ptr, nbr_idx, nbr_dist, fid_ptr, fid_idx, fid_xy, fid_end_xy, fid_buffer,
           alpha_len, seg_start, seg_end, buffer)
    s_ptr, s_step, s_angles = script
    return step_loop(dest, movable, cur, limits, max_steps, greed, phobia, greedy, greedy_first,
                     beta_first, n_left, rng_state, arr, par, rs, near, sched, scratch,
                     (ev_robot, ev_step, ev_angles), (s_ptr, s_step, s_angles, s_ptr[:-1].copy()))


@njit(cache=True, _nrt=False)
def replay_end(s_ptr, s_step, s_angles):
    """The last step at which a replayed robot moves (0 when none does)."""
    end = 0
    for i in range(s_ptr.shape[0] - 1):
        for k in range(s_ptr[i + 1] - 1, s_ptr[i], -1):
            if (abs(s_angles[k, 0] - s_angles[k - 1, 0]) >= ANGLE_EPS
                    or abs(s_angles[k, 1] - s_angles[k - 1, 1]) >= ANGLE_EPS):
                end = max(end, int(np.ceil(s_step[k])))
                break
    return end


@njit(cache=True, _nrt=False)
def replay_target(i, step, cur, s_ptr, s_step, s_angles, s_at, cand):
    """Replayed robot i's recorded angles at ``step`` (the path's last ones after its end)
    into ``cand[0, :2]``; ``s_at[i]`` follows its path segment. Returns True when they
    differ from where it stands (``cur``), i.e. it moves this step."""
    hi = s_ptr[i + 1] - 1
    k = s_at[i]
    while k < hi and s_step[k + 1] <= step:
        k += 1
    s_at[i] = k
    if k >= hi:
        ta = s_angles[hi, 0]
        tb = s_angles[hi, 1]
    else:
        f = (step - s_step[k]) / (s_step[k + 1] - s_step[k])
        ta = s_angles[k, 0] + f * (s_angles[k + 1, 0] - s_angles[k, 0])
        tb = s_angles[k, 1] + f * (s_angles[k + 1, 1] - s_angles[k, 1])
    cand[0, 0] = ta
    cand[0, 1] = tb
    return abs(ta - cur[i, 0]) >= ANGLE_EPS or abs(tb - cur[i, 1]) >= ANGLE_EPS


@njit(cache=True, _nrt=False)
def step_loop(dest, movable, cur, limits, max_steps, greed, phobia, greedy, greedy_first,
              beta_first, n_left,
              rng_state, arr, par, rs, near, sched, scratch, ev, script):
    """The step loop of :func:`run_stepwise`: every robot, step after step, until all are home.

    Arguments as in :func:`run_stepwise_arrays`, and the state of
    :func:`rfp_twin.planners.stepwise.state.new_state`; ``cur`` (n, 2) deg is updated in
    place and ``ev`` = (ev_robot, ev_step, ev_angles) receives the breakpoints.
    ``script`` = (ptr, steps, angles, at (n,) int64 each robot's current path segment).
    Compiled without numba's runtime: it must not create arrays. Returns (n_events, n_steps).
    """
    (base_xy, nbr_ptr, nbr_idx, nbr_dist, fid_ptr, fid_idx, fid_xy, fid_end_xy, fid_buffer,
     alpha_len, seg_start, seg_end, buffer) = arr
    step_deg, md, cd, sd, c2d, s2d, free_step, disp, near_ref = par
    near_k, near_col, near_cnt, near_until = near
    last, home, asleep_at, moved_at, home_until, free_until = sched
    cand, cost, score_of, order = scratch
    s_ptr, s_step, s_angles, s_at = script
    n = base_xy.shape[0]
    s_until = replay_end(s_ptr, s_step, s_angles)
    n_moves = 1
    n_ev = 0
    step = 0
    n_awake = 1
    moves_before = -1
    # replays go on to their end, even once every planned robot is home and past
    # max_steps: each of their moves is checked against where the planned robots stand
    limit = max(max_steps, s_until)
    while step < limit and (n_left > 0 or step < s_until):
        # quiescent: nothing moved, nobody awake and no replay to come -> nothing can change
        if n_moves == moves_before and n_awake == 0 and step >= s_until:
            break
        moves_before = n_moves
        n_awake = 0
        step += 1
        for i in range(n):
            gc = greedy[i]
            replayed = s_ptr[i + 1] > s_ptr[i]
            if replayed:
                # its recorded move of this step goes to cand[0] and is checked as an
                # obvious move is (below); nothing to do while it stands
                if step > s_until or not replay_target(i, step, cur, s_ptr, s_step, s_angles,
                                                       s_at, cand):
                    continue
            elif not movable[i] or (gc and home[i]) or step < home_until[i]:
                continue
            if asleep_at[i] >= 0:
                if not woken(i, asleep_at[i], nbr_ptr, nbr_idx, moved_at):
                    continue
                asleep_at[i] = -1
            if step >= near_until[i]:
                refresh_near(i, step, arr, par, rs, near)
            ca = cur[i, 0]
            cb = cur[i, 1]
            da = dest[i, 0]
            db = dest[i, 1]
            # beta first: while beta is away from its destination the obvious move
            # holds alpha; when that move is blocked the robot plans as usual
            bf = beta_first[i] and abs(cb - db) >= ANGLE_EPS and not replayed and (
                gc or (greedy_first[i] and not home[i]))
            if bf:
                da = ca
            bx = base_xy[i, 0]
            by = base_xy[i, 1]
            s1 = seg_end[i]
            a_lo = limits[i, 0]
            a_hi = limits[i, 1]
            b_lo = limits[i, 2]
            b_hi = limits[i, 3]

            if home[i] and not replayed:
                # MC only (Eq. 10): stay unless a neighbour encroaches
                if not encroached(i, 3.0 * md, step, arr, par, rs, home_until):
                    asleep_at[i] = n_moves
                    n_ev = record(ev, last, i, step, ca, cb, 0.0, 0.0, n_ev)
                    continue

            best = -1
            n_valid_moves = 0
            free = False
            ka_best = direction_sign(da - ca)
            kb_best = direction_sign(db - cb)
            if gc or (greedy_first[i] and not home[i]) or replayed:
                # the obvious move (best step on each axis) has the least cost: try it first
                if not replayed:
                    cand[0, 0] = step_toward(ca, da, ka_best, step_deg, a_lo, a_hi)
                    cand[0, 1] = step_toward(cb, db, kb_best, step_deg, b_lo, b_hi)
                best = try_cand(cand, 0, i, ca, cb, bx, by, s1, md, True, arr, par, rs, near)
            if bf and best < 0:
                da = dest[i, 0]
                ka_best = direction_sign(da - ca)
            if replayed:
                if best < 0:
                    return -2, step      # the robots around it left its recorded move no room
                cur[i, 0] = cand[0, 0]
                cur[i, 1] = cand[0, 1]
                commit(rs, cand, i, 0)
                n_moves += 1
                moved_at[i] = n_moves
                continue
            if best < 0:
                fill_candidates(cand, cost, order, ca, cb, da, db, step_deg, a_lo, a_hi, b_lo, b_hi)
                # (a beta-first robot tried the beta-only move: its obvious one is untried)
                obvious = -1 if bf else 3 * (ka_best + 1) + kb_best + 1
            if gc and best < 0:
                sort_by_cost(order, cost)
                for p in range(9):
                    q = order[p]
                    if q == obvious:
                        continue
                    if cand[q, 0] == ca and cand[q, 1] == cb:
                        break  # staying beats every remaining candidate
                    best = try_cand(cand, q, i, ca, cb, bx, by, s1, md, True, arr, par, rs, near)
                    if best >= 0:
                        break
            elif not gc and best < 0:
                # Markov chain (Sect. 4.2): energy or cost; candidates in random order,
                # each that beats the best so far taken with probability greed (a
                # greedy-first robot gets here only when its obvious move is blocked)
                use_energy = uniform(rng_state) < phobia[i]
                if step >= free_until[i]:
                    w = free_window(i, step, arr, par, rs, near)
                    if w > 0:
                        free_until[i] = step + w
                free = step < free_until[i]
                if use_energy:
                    e0, ga, gb = energy_gradient(i, s1, arr, par, rs, near)
                    for q in range(9):
                        score_of[q] = e0 + ga * (cand[q, 0] - ca) + gb * (cand[q, 1] - cb)
                else:
                    for q in range(9):
                        score_of[q] = cost[q]
                if free:
                    best = mc_pick_free(rng_state, greed[i], score_of)
                    if best >= 0:   # its state only: a free robot's candidates all pass
                        try_cand(cand, best, i, ca, cb, bx, by, s1, md, False, arr, par, rs, near)
                else:
                    best, n_valid_moves = mc_pick_sequential(rng_state, greed[i], score_of, order,
                                                             cand, i, ca, cb, bx, by, s1,
                                                             arr, par, rs, near)

            if best < 0 or (cand[best, 0] == ca and cand[best, 1] == cb):
                # stay. GC: the choice cannot change until a neighbour moves, so sleep.
                # MC: sleep only when no move at all passes the step rule.
                sleep = gc
                if not gc and n_valid_moves == 0 and not free:
                    sleep = not any_move_passes(cand, i, ca, cb, bx, by, s1, arr, par, rs, near)
                if sleep:
                    asleep_at[i] = n_moves
                else:
                    n_awake += 1
                n_ev = record(ev, last, i, step, ca, cb, 0.0, 0.0, n_ev)
                continue

            # commit the move (cand row holds the segment state computed by try_cand)
            na = cand[best, 0]
            nb = cand[best, 1]
            n_ev = record(ev, last, i, step, ca, cb, na - ca, nb - cb, n_ev)
            cur[i, 0] = na
            cur[i, 1] = nb
            commit(rs, cand, i, best)
            n_moves += 1
            moved_at[i] = n_moves
            n_awake += 1
            now_home = abs(na - dest[i, 0]) < ANGLE_EPS and abs(nb - db) < ANGLE_EPS
            if now_home and gc:
                # a greedy robot at home never moves again and is never visited: its
                # arrival is its last breakpoint (without it, interpolation to the plan's
                # last step would spread its last moves over the steps it waits)
                n_ev = record(ev, last, i, step + 1, na, nb, 0.0, 0.0, n_ev)
            if now_home and not home[i]:
                n_left -= 1
            elif home[i] and not now_home:
                n_left += 1
            home[i] = now_home
    return n_ev, step
