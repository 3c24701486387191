"""The Markov (MC) planner's random choice among a robot's nine candidates (Sayres 2021 Sect. 4.2).

The sequential rule of the paper: the candidates are visited in random order, and one
that beats the best score so far is taken with probability ``greed`` (one that ties it
with probability 1/2), provided it passes the step rule. :func:`mc_pick_free` draws the
rule's outcome in one go when every candidate passes (a *free* robot);
:func:`mc_pick_sequential` runs the rule itself, checking the step rule only for a
candidate that would be taken. Random numbers come from :func:`uniform`, a splitmix64
generator on a one-element state array.

Shapes: ``rng_state`` (1,) uint64; ``score_of`` (9,) float64, each candidate's score
(cost in deg^2, or linearised energy in mm^-2); ``order`` (9,) int64 scratch. The other
arrays and tuples are those of :mod:`rfp_twin.planners.stepwise.candidates`.

The functions are ``@njit(inline="always")``: numba inlines them into
:func:`rfp_twin.planners.stepwise.kernel.step_loop`, which runs without reference counting.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from rfp_twin.planners.stepwise.candidates import try_cand


@njit(cache=True, inline="always")
def uniform(rng_state):
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


@njit(cache=True, inline="always")
def mc_pick_free(rng_state, g, score_of):
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
    tests/planners/stepwise/test_kernel.py checks the kernel against the sequential rule.
    """
    u = uniform(rng_state)
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


@njit(cache=True, inline="always")
def random_order(rng_state, order):
    """A uniform random order of the 9 candidates in ``order``, from one draw.

    Fisher-Yates with the indices read as mixed-radix digits of one uniform double
    (9! needs 19 of its 53 bits; no integer division).
    """
    x = uniform(rng_state)
    for p in range(9):
        order[p] = p
    for p in range(8, 0, -1):
        x *= p + 1
        r = int(x)
        x -= r
        t = order[p]
        order[p] = order[r]
        order[r] = t


@njit(cache=True, inline="always")
def mc_pick_sequential(rng_state, g, score_of, order, cand, i, ca, cb, bx, by, s1,
                       arr, par, rs, near):
    """MC's sequential rule for robot i at (ca, cb) deg: (chosen candidate or -1, moves allowed).

    The candidates are visited in a random order (:func:`random_order`); one that beats
    the best score so far is taken with probability g, one that ties it with
    probability 1/2. The step rule is checked only for a candidate that would be
    taken; the outcome is the same as checking every candidate first. The second value
    counts the allowed candidates taken that move the robot (0: the caller checks
    whether any move at all passes before the robot sleeps).
    """
    step_deg, md, cd, sd, c2d, s2d, free_step, disp, near_ref = par
    random_order(rng_state, order)
    best = -1
    n_valid_moves = 0
    best_score = 1e300
    for p in range(9):
        q = order[p]
        score = score_of[q]
        take = False
        if score < best_score:
            take = uniform(rng_state) < g
        elif score == best_score:
            take = uniform(rng_state) < 0.5
        if not take or try_cand(cand, q, i, ca, cb, bx, by, s1, md, True,
                                arr, par, rs, near) < 0:
            continue
        if not (cand[q, 0] == ca and cand[q, 1] == cb):
            n_valid_moves += 1
        best = q
        best_score = score
    return best, n_valid_moves
