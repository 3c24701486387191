"""A plan against the joint limits before post-processing (planners/postprocess/limits.py)."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.errors import SpecError
from rfp_twin.planners.postprocess.limits import LIMIT_ROUNDING_DEG, within_limits
from tests.planners.path_builders import make_plan

LIMITS = np.array([[[0.0, 360.0], [0.0, 180.0]]] * 3)


def three_robots():
    return make_plan([([0, 50], [[10, 170], [50, 130]]),
                      ([0, 20, 40], [[0, 180], [5, 170], [20, 160]]),
                      ([0, 30], [[300, 100], [360, 0]])])


def test_a_plan_inside_is_returned_as_it_is():
    plan = three_robots()
    assert within_limits(plan, LIMITS) is plan


def test_rounding_is_clipped_and_nothing_else_changes():
    plan = three_robots()
    plan.path_angles[3, 0] = -0.1 * LIMIT_ROUNDING_DEG          # index 1, alpha
    plan.path_angles[6, 1] = 180.0 + 0.5 * LIMIT_ROUNDING_DEG    # index 2, beta
    out = within_limits(plan, LIMITS)
    assert out is not plan and out.path_angles[3, 0] == 0.0 and out.path_angles[6, 1] == 180.0
    keep = np.ones(plan.path_angles.shape, dtype=bool)
    keep[3, 0] = keep[6, 1] = False
    np.testing.assert_array_equal(out.path_angles[keep], plan.path_angles[keep])
    assert plan.path_angles[3, 0] < 0.0                          # the caller's plan is untouched


def test_an_excursion_names_the_axis_the_value_the_limits_and_the_robot():
    plan = three_robots()
    plan.path_angles[4, 1] = 181.0                               # index 1 (robot id 2), beta
    with pytest.raises(SpecError, match=r"robot 2: field 'plan beta' = '181.0000 deg'; "
                                        r"allowed: \[0, 180\] deg"):
        within_limits(plan, LIMITS)
    plan.path_angles[6, 0] = 361.0                               # index 2 (id 3), alpha: reported first
    with pytest.raises(SpecError, match=r"robot 3: field 'plan alpha' = '361.0000 deg'"):
        within_limits(plan, LIMITS)
