"""Target replacement (planners/deadlocks/replacement.py): one robot of a group gets a new target,
clear of its neighbours; the in-place search after it is tested with the solver's
fallbacks (deadlocks/search/test_resolve.py)."""
from __future__ import annotations

import numpy as np

from rfp_twin.planners.deadlocks.replacement import replace_one
from rfp_twin.planners.plan.targets import random_targets
from tests.planners.conftest import make_geom


def test_one_robot_of_the_group_gets_a_new_target_the_first_named_first():
    geom = make_geom(37, 2.0)
    targets = random_targets(geom, np.random.default_rng(1), margin_mm=0.1)
    group = np.array([5, 6, 12])
    for first in (12, -1):
        new = replace_one(geom, np.random.default_rng(2), targets, group, 0.1, first)
        changed = np.flatnonzero(np.any(new != targets, axis=1))
        assert changed.size == 1 and changed[0] in group
        if first >= 0:
            assert changed[0] == first
        assert geom.pair_clearance(new).min() > 0.1 - 1e-9


def test_a_group_with_no_room_keeps_its_targets():
    geom = make_geom(7, 2.0)
    targets = random_targets(geom, np.random.default_rng(1), margin_mm=0.1)
    # a margin wider than the patrol zones leaves no clear spot for anyone
    new = replace_one(geom, np.random.default_rng(2), targets, np.array([0, 1]), 50.0)
    np.testing.assert_array_equal(new, targets)
