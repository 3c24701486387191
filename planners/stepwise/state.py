"""The stepwise kernel's state: every array the step loop works in, allocated and set up once.

:func:`new_state` allocates the state before the step loop (which itself creates no
arrays) and sets each robot's trig functions, beta segment and reach from ``start``.
It returns the state as tuples, described in :mod:`rfp_twin.planners.stepwise.candidates`
(``par``, ``rs``, ``near``) and here:

sched : the robots' bookkeeping, (last (n, 2) deg, the move vector at the latest
    breakpoint; home (n,) bool, at the destination; asleep_at (n,) int64, move counter
    when the robot fell asleep, -1 = awake; moved_at (n,) int64, move counter of its
    last move; home_until (n,) int64, MC: step before which a parked robot needs no
    Eq. 10 check; free_until (n,) int64, MC: step before which every candidate passes)
scratch : one robot's candidates, (cand (9, 13), see candidates.py; cost (9,) deg^2;
    score_of (9,), MC scores; order (9,) int64)

Units: angles in deg, lengths in mm, time in steps.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from rfp_twin.planners.stepwise.candidates import cand_segment, cand_trig, commit
from rfp_twin.planners.stepwise.moves import ANGLE_EPS, DEG
from rfp_twin.planners.stepwise.neighbours import ENERGY_CUTOFF_MM


@njit(cache=True)
def new_state(base_xy, start, dest, movable, nbr_ptr, alpha_len, seg_start, seg_end,
              step_deg, md, greed, phobia, seed, cur):
    """The kernel's state for a run from ``start`` (copied to ``cur``) towards ``dest``.

    Arguments as in :func:`rfp_twin.planners.stepwise.kernel.run_stepwise_arrays`
    (``alpha_len``, ``seg_start``, ``seg_end`` (n,) mm: each robot's alpha arm and
    collision segment). The bounds ``free_step`` and ``disp`` are the largest over the
    robots. Returns
    (greedy, n_left, rng_state, par, rs, near, sched, scratch): greedy (n,) bool, True
    for a robot with greed 1 and phobia 0 (it follows the deterministic GC rules; the
    others the Markov chain's, so one run may mix the two planners); n_left
    counts the movable robots away from their destination; rng_state (1,) uint64 is
    the splitmix64 state seeded from ``seed``.
    """
    rng_state = np.empty(1, dtype=np.uint64)
    rng_state[0] = np.uint64(seed) * np.uint64(0x9E3779B97F4A7C15) + np.uint64(0x2545F4914F6CDD1D)
    n = base_xy.shape[0]
    greedy = np.empty(n, dtype=np.bool_)
    all_greedy = True
    for i in range(n):
        greedy[i] = greed[i] >= 1.0 and phobia[i] <= 0.0
        all_greedy = all_greedy and greedy[i]

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
    near_ref = 0.0 if all_greedy else ENERGY_CUTOFF_MM  # MC energy needs neighbours to the cutoff
    home_until = np.zeros(n, dtype=np.int64)          # MC: parked robot needs no Eq. 10 check
    free_until = np.zeros(n, dtype=np.int64)          # MC: every candidate passes the step rule
    s1_max = 0.0     # farthest segment point along any beta arm, mm
    la_max = 0.0     # longest alpha arm, mm
    for i in range(n):
        s1_max = max(s1_max, seg_end[i], seg_start[i])
        la_max = max(la_max, alpha_len[i])
    # most a base-disk bound |b_i - b_j| - rho_i - rho_j shrinks in one step, mm
    free_step = 2.0 * s1_max * step_deg * DEG * 1.001
    # largest displacement of any point of a beta segment in one step (both axes), mm
    disp = (la_max + 2.0 * s1_max) * step_deg * DEG * 1.001
    cand = np.empty((9, 13))  # na, nb, cos a, sin a, cos ab, sin ab, cos b, sin b, segment, reach
    cost = np.empty(9)
    score_of = np.empty(9)   # MC: each candidate's score (cost or linearised energy)
    order = np.empty(9, dtype=np.int64)

    par = (float(step_deg), float(md),
           math.cos(step_deg * DEG), math.sin(step_deg * DEG),
           math.cos(2.0 * step_deg * DEG), math.sin(2.0 * step_deg * DEG),
           free_step, disp, near_ref)
    rs = (trig, seg, rho)

    # initial state: each robot's trig, segment and reach, as for a candidate
    n_left = 0
    for i in range(n):
        cur[i, 0] = start[i, 0]
        cur[i, 1] = start[i, 1]
        cand_trig(cand, 0, cur[i, 0], cur[i, 1])
        cand_segment(cand, 0, base_xy[i, 0], base_xy[i, 1], seg_end[i], alpha_len[i], seg_start[i])
        commit(rs, cand, i, 0)
        home[i] = abs(cur[i, 0] - dest[i, 0]) < ANGLE_EPS and abs(cur[i, 1] - dest[i, 1]) < ANGLE_EPS
        if movable[i] and not home[i]:
            n_left += 1
    return (greedy, n_left, rng_state, par, rs, (near_k, near_col, near_cnt, near_until),
            (last, home, asleep_at, moved_at, home_until, free_until),
            (cand, cost, score_of, order))
