"""Numba kernels of the search's collision tests (planners/roadmap/alpha_beta/kernels.py),
against beta segments written out by hand."""
from __future__ import annotations

import numpy as np

from rfp_twin.planners.roadmap.alpha_beta.kernels import (moving_collisions, pair_conflict, reach_of,
                                             segments_at, static_collisions)

L_ALPHA, S0, S1 = 7.4, 0.0, 15.0
LIMITS = np.array([0.0, 360.0, 0.0, 180.0])


def segment(bx, by, a_deg, b_deg):
    a, ab = np.radians(a_deg), np.radians(a_deg + b_deg)
    ex, ey = bx + L_ALPHA * np.cos(a), by + L_ALPHA * np.sin(a)
    return np.array([ex + S0 * np.cos(ab), ey + S0 * np.sin(ab),
                     ex + S1 * np.cos(ab), ey + S1 * np.sin(ab)])


def test_segments_and_reach_follow_the_arm():
    ang = np.array([[0.0, 0.0], [90.0, 90.0], [30.0, 180.0]])
    seg = segments_at(1.0, 2.0, ang, L_ALPHA, S0, S1)
    np.testing.assert_allclose(seg, [segment(1.0, 2.0, *q) for q in ang], atol=1e-12)
    np.testing.assert_allclose(reach_of(seg, 1.0, 2.0),
                               [L_ALPHA + S1, np.hypot(L_ALPHA, S1), S1 - L_ALPHA], atol=1e-12)


def test_pair_conflict_is_per_step():
    # robot b (base 30 mm to the right) turns its stretched arm towards robot a's
    a = segments_at(0.0, 0.0, np.array([[0.0, 0.0]] * 3), L_ALPHA, S0, S1)
    b = segments_at(30.0, 0.0, np.array([[90.0, 0.0], [180.0, 0.0], [90.0, 0.0]]), L_ALPHA, S0, S1)
    # at step 1 the tips are 30 - 2 * 22.4 < 0 apart: overlap; else far apart
    assert pair_conflict(a, b, 1.0)
    assert not pair_conflict(a[[0, 2]], b[[0, 2]], 1.0)


def test_moving_obstacle_table_is_read_at_the_query_step():
    """One obstacle (base 30 mm right) stretched towards the robot at step 1 only; steps
    outside the table are clamped to its ends; hits count the colliding queries."""
    obs = np.stack([segments_at(30.0, 0.0, np.array([[90.0, 0.0], [180.0, 0.0], [90.0, 0.0]]),
                                L_ALPHA, S0, S1)], axis=1)          # (T + 1, 1, 4)
    rho = reach_of(obs[:, 0, :], 30.0, 0.0)[:, None]
    q = np.zeros((5, 2))                                               # robot stretched to +x
    t = np.array([0.0, 1.0, 2.0, -3.0, 9.0])
    out = np.empty(5, dtype=np.bool_)
    hits = np.zeros(1, dtype=np.int64)
    moving_collisions(q, t, 0.0, 0.0, L_ALPHA, S0, S1, obs, rho, np.array([30.0]),
                      np.array([1.0]), out, hits)
    np.testing.assert_array_equal(out, [False, True, False, False, False])
    assert hits[0] == 1


def test_static_test_holds_limits_segments_and_points():
    st_seg = segment(30.0, 0.0, 180.0, 0.0)[None, :]                  # reaches to x = 7.6
    q = np.array([[0.0, 0.0], [180.0, 0.0], [0.0, 181.0], [90.0, 0.0]])
    out = np.empty(4, dtype=np.bool_)
    static_collisions(q, 0.0, 0.0, L_ALPHA, S0, S1, LIMITS, st_seg, np.array([1.0]),
                      np.zeros((0, 2)), np.zeros(0), out)
    np.testing.assert_array_equal(out, [True, False, True, False])
    # a point (fiducial) on the arm at alpha = 90 deg
    static_collisions(q, 0.0, 0.0, L_ALPHA, S0, S1, LIMITS, np.zeros((0, 4)), np.zeros(0),
                      np.array([[0.0, 15.0]]), np.array([1.0]), out)
    np.testing.assert_array_equal(out, [False, False, True, True])


def test_edge_checks_that_skip_clear_points_answer_as_checking_every_point():
    """``edges_forbidden`` skips points that the clearance of a clear one proves clear;
    on 2,000 random edges around a point and a segment obstacle (thresholds drawn so
    that many edges graze them, some edges leaving the joint limits) every answer is
    that of checking each point with ``static_collisions``."""
    from rfp_twin.planners.roadmap.alpha_beta.kernels import edges_forbidden

    rng = np.random.default_rng(7)
    pts = np.array([[12.0, 9.0]])
    st_seg = np.array([[-20.0, -5.0, -8.0, -14.0]])
    n_hit = 0
    for trial in range(20):
        pt_th = rng.uniform(0.5, 4.0, 1)
        st_th = rng.uniform(0.5, 4.0, 1)
        q0 = rng.uniform([-10.0, -10.0], [370.0, 190.0], size=(100, 2))
        q1 = q0 + rng.normal(0.0, 40.0, size=(100, 2))
        step = np.array([0.1, 0.1]) * (1 + trial % 3)
        out = np.empty(100, dtype=np.bool_)
        counts = np.empty(100, dtype=np.int64)
        edges_forbidden(q0, q1, step, 0.0, 0.0, L_ALPHA, S0, S1, LIMITS, st_seg, st_th, pts,
                        pt_th, out, counts)
        for e in range(100):
            n = counts[e] - 1
            f = np.arange(n + 1) * (1.0 / n)
            f[-1] = 1.0
            q = q0[e] + f[:, None] * (q1[e] - q0[e])
            each = np.empty(n + 1, dtype=np.bool_)
            static_collisions(q, 0.0, 0.0, L_ALPHA, S0, S1, LIMITS, st_seg, st_th, pts, pt_th,
                              each)
            assert out[e] == each.any(), (trial, e)
            n_hit += int(each.any())
    assert 200 < n_hit < 1800


def test_block_discs_hold_every_segment_of_their_steps():
    """The discs that let the sweep skip far obstacles hold each obstacle's beta segment
    at every step of their block (a gone obstacle, far away, included)."""
    from rfp_twin.planners.roadmap.alpha_beta.kernels import DISC_BLOCK, block_discs

    rng = np.random.default_rng(3)
    ang = np.cumsum(rng.normal(0.0, 2.0, size=(101, 2)), axis=0)
    obs = np.stack([segments_at(0.0, 0.0, ang, L_ALPHA, S0, S1),
                    segments_at(22.4, 0.0, ang[::-1], L_ALPHA, S0, S1)], axis=1)
    obs[90:, 1, :] = 1.0e7                     # the second one gone after step 89
    discs = block_discs(obs)
    assert discs.shape == ((101 + DISC_BLOCK - 1) // DISC_BLOCK, 2, 3)
    for k in range(101):
        for o in range(2):
            cx, cy, r = discs[k // DISC_BLOCK, o]
            for e in range(2):
                assert np.hypot(obs[k, o, 2 * e] - cx, obs[k, o, 2 * e + 1] - cy) <= r
    assert discs[0, 0, 2] < L_ALPHA + S1 + 1.0   # a block's disc is not the whole reach
