"""Tests of the angular-error buffer (validation/buffer/montecarlo.py).

A toy model stands in for the 2D / 3D pair: ``required(c) = c0`` (deg as mm) and every
configuration is "colliding" whose first angle is at most 10, so shifting by an error
``e`` asks for ``B(e) = max (c'0 - e0) = 10 - e0`` over the colliding ``c'``.
"""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.validation.buffer.montecarlo import ErrorBuffer, corner_errors, error_buffers


def required(ang, dir_idx):
    return ang[:, 0] + 0.0 * dir_idx


def colliding(ang, dir_idx):
    return ang[:, 0] <= 10.0


def candidates():
    rng = np.random.default_rng(2)
    ang = np.column_stack([rng.uniform(5.0, 9.0, 20), rng.uniform(0, 1, (20, 3))])
    return ang, np.arange(20) % 3


def test_the_best_candidate_without_search_and_the_search_reaching_the_boundary():
    ang, dirs = candidates()
    b_of = ErrorBuffer(required, colliding, ang, dirs, np.random.default_rng(0))
    err = np.array([1.0, 0.0, 0.0, 0.0])
    b, c, d = b_of(err, starts=3, rounds=0)                # candidates only
    k = int(np.argmax(ang[:, 0]))
    assert b == ang[k, 0] - 1.0 and np.array_equal(c, ang[k]) and d == dirs[k]
    b, c, d = b_of(err, starts=3, rounds=60)               # local search from the best 3
    assert b > ang[k, 0] - 1.0 and b == pytest.approx(9.0, abs=0.05)
    assert colliding(c[None], 0)[0] and b == pytest.approx(c[0] - 1.0)
    assert ErrorBuffer(required, colliding, ang[:0], dirs[:0], None)(err, 3, 5) == (0.0, None,
                                                                                      -1)


def test_error_buffers_per_draw_and_at_the_corners():
    ang, dirs = candidates()
    b_of = ErrorBuffer(required, colliding, ang, dirs, np.random.default_rng(0))
    draws = np.array([[0.5, 0, 0, 0], [-0.5, 0, 0, 0], [0.0, 0, 0, 0]])
    seen = []
    free, samples, corner = error_buffers(b_of, draws, corner_errors(1.5, 1.0), 2, 30,
                                          lambda stage, frac: seen.append((stage, frac)))
    assert free[0] == pytest.approx(10.0, abs=0.05)         # no error: the boundary
    np.testing.assert_allclose(samples, 10.0 - draws[:, 0], atol=0.1)
    assert corner == pytest.approx(11.5, abs=0.1)           # e0 = -1.5 at the worst corner
    assert seen == [("monte carlo", 0.0)]


def test_corner_errors_are_the_sixteen_sign_combinations():
    c = corner_errors(1.5, 1.48)
    assert c.shape == (16, 4) and len({tuple(r) for r in c}) == 16
    np.testing.assert_array_equal(np.abs(c), np.tile([1.5, 1.48, 1.5, 1.48], (16, 1)))
