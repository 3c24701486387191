"""Breakpoint paths on the step clock (planners/roadmap/alpha_beta/paths.py)."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.errors import SpecError
from rfp_twin.planners.roadmap.alpha_beta.paths import PathSet


def two_robots() -> PathSet:
    """Robot 0 moves from step 0 to 10 and holds from 10 to 30; robot 1 never moves."""
    return PathSet([np.array([0.0, 10.0, 30.0]), np.array([0.0, 5.0])],
                   [np.array([[0.0, 0.0], [10.0, 20.0], [10.0, 20.0]]),
                    np.array([[5.0, 5.0], [5.0, 5.0]])])


def test_motion_end_is_the_last_change_of_angles():
    p = two_robots()
    assert p.motion_end(0) == 10.0
    assert p.motion_end(1) == 0.0


def test_sample_interpolates_and_holds_the_ends():
    p = two_robots()
    np.testing.assert_allclose(p.sample(0, np.array([-1.0, 5.0, 10.0, 50.0])),
                               [[0.0, 0.0], [5.0, 10.0], [10.0, 20.0], [10.0, 20.0]])


def test_prefix_ends_with_the_point_at_the_cut():
    steps, angles = two_robots().prefix(0, 4.0)
    np.testing.assert_array_equal(steps, [0.0, 4.0])
    np.testing.assert_allclose(angles, [[0.0, 0.0], [4.0, 8.0]])


def test_signature_ignores_holding_after_the_last_motion():
    a = two_robots()
    b = two_robots()
    b.steps[0] = np.array([0.0, 10.0, 99.0])
    assert a.signature(0) == b.signature(0)
    b.angles[0] = b.angles[0] + [0.0, 1e-3]
    assert a.signature(0) != b.signature(0)


def test_csr_round_trip_ends_every_path_at_the_plan_length():
    p = two_robots()
    ptr, steps, angles = p.to_csr(20)
    np.testing.assert_array_equal(ptr, [0, 3, 6])
    np.testing.assert_array_equal(steps, [0.0, 10.0, 20.0, 0.0, 5.0, 20.0])
    back = PathSet.from_csr(ptr, steps, angles)
    for i in range(2):
        np.testing.assert_allclose(back.sample(i, np.arange(0.0, 21.0)), p.sample(i, np.arange(0.0, 21.0)))
    with pytest.raises(SpecError, match="robot index 0 still moves"):
        p.to_csr(5)


def test_motion_end_follows_a_replaced_path():
    """The motion end is kept per robot while its path arrays are the same objects; a
    path replaced (as the search does) gets its own."""
    ps = PathSet([np.array([0.0, 5.0, 9.0])], [np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 0.0]])])
    assert ps.motion_end(0) == 5.0 and ps.motion_end(0) == 5.0
    ps.steps[0] = np.array([0.0, 7.0, 9.0])
    assert ps.motion_end(0) == 7.0          # new steps, same angles object: computed again
    ps.angles[0] = np.array([[0.0, 0.0], [0.0, 0.0], [0.0, 0.0]])
    assert ps.motion_end(0) == 0.0
