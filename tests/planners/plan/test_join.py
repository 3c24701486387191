"""Two plans on one step clock: a fold then an unfold."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.errors import PlanningError
from rfp_twin.models.layout import layout_by_name
from rfp_twin.models.robot import load_spec
from rfp_twin.planners.plan import PlannerSettings, plan_reconfiguration, random_targets
from rfp_twin.planners.plan.join import join_plans
from rfp_twin.planners.stepwise import array_max_displacement


@pytest.fixture(scope="module")
def two_plans():
    spec = load_spec("sdss-v")
    geom = ArrayGeometry(spec, layout_by_name("hex:7", spec.pitch_mm, ()), 2.0)
    md = array_max_displacement(geom, 0.1)
    rng = np.random.default_rng(3)
    a, b = (random_targets(geom, rng, margin_mm=md) for _ in range(2))
    s = PlannerSettings()
    return (plan_reconfiguration(geom, a, s, np.random.default_rng(1)),
            plan_reconfiguration(geom, b, s, np.random.default_rng(2)))


def test_a_fold_then_an_unfold_is_one_plan_through_the_fold(two_plans):
    to_a, to_b = two_plans
    joined = join_plans(to_a.reversed(), to_b)
    n1 = to_a.n_steps
    assert joined.n_steps == n1 + to_b.n_steps
    assert np.array_equal(joined.start(), to_a.end()) and np.array_equal(joined.end(), to_b.end())
    steps = np.linspace(0, n1, 17)
    assert np.allclose(joined.angles_at(steps), to_a.reversed().angles_at(steps))
    steps = np.linspace(0, to_b.n_steps, 17)
    assert np.allclose(joined.angles_at(steps + n1), to_b.angles_at(steps))
    assert np.array_equal(joined.targets, to_b.targets)
    assert np.all(np.diff(joined.path_ptr) >= 1)
    assert joined.metrics["first_steps"] == n1


def test_plans_that_do_not_meet_are_refused(two_plans):
    to_a, to_b = two_plans
    with pytest.raises(PlanningError, match="allowed: the same pose"):
        join_plans(to_a, to_b)                # ends at A, the other starts folded
