"""Sabater's prioritized planner on whole arrays (planners/roadmap/alpha_beta/array.py), checked by the
independent 2D checker (rfp_twin.validation.checker2d), never by the planner itself."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.errors import SpecError
from rfp_twin.models.layout import Layout
from rfp_twin.models.robot import load_spec
from rfp_twin.planners.plan import REACHED
from rfp_twin.planners.roadmap.alpha_beta import SearchResolveSettings
from rfp_twin.planners.roadmap.alpha_beta.array import roadmap_pass, travel_priority
from rfp_twin.planners.plan import PlannerSettings, plan_reconfiguration
from rfp_twin.planners.stepwise import max_displacement
from rfp_twin.models.trajectory import Trajectory
from tests.planners.conftest import make_geom, plan_random
from rfp_twin.validation.checker2d import check_trajectory


def assert_clear(geom: ArrayGeometry, plan) -> None:
    report = check_trajectory(Trajectory.from_plan(plan), geom.spec, geom.layout, geom.buffer_mm)
    assert report.ok, report.table()


def pair_geometry():
    """Two robots one pitch apart. A (index 0) points straight down; B (index 1) points
    at A's base, so that A cannot park folded while B sits at its target."""
    spec = load_spec("sdss-v")
    lay = Layout(ids=[1, 2], xy=[[0.0, 0.0], [spec.pitch_mm, 0.0]], kinds=["robot", "robot"],
                 name="pair")
    geom = ArrayGeometry(spec, lay, 2.5)
    targets = np.array([[270.0, 0.0], [180.0, 3.0]])
    return geom, targets


def test_priority_is_the_longest_direct_travel_first():
    start = np.array([[100.0, 20.0], [300.0, 20.0], [10.0, 170.0], [200.0, 100.0]])
    dest = np.tile([10.0, 170.0], (4, 1))
    assert list(travel_priority(start, dest, np.arange(4), 0.1)) == [1, 3, 0, 2]


def test_a_robot_whose_goal_is_blocked_is_deferred_and_planned_after_the_blocker():
    geom, targets = pair_geometry()
    spec = geom.spec
    step = 0.5
    md = max_displacement(spec.alpha_length_mm, spec.beta_length_mm, float(geom.seg_end.max()), step)
    fold = np.tile(np.asarray(spec.fold_deg, dtype=float), (2, 1))
    res = roadmap_pass(geom, targets, fold, np.ones(2, bool), md, step, SearchResolveSettings(),
                       np.random.default_rng(0))
    assert list(res.order) == [0, 1]            # A travels farther, so it goes first ...
    assert res.passes == 2                      # ... fails (B sits on its fold), and waits
    assert res.planned.all()
    np.testing.assert_allclose(res.final, fold)
    # A's last motion ends after B has left the place A parks in
    b_leaves = float(res.paths.steps[1][np.flatnonzero(np.any(
        np.abs(res.paths.angles[1] - targets[1]) > 1e-9, axis=1))[0]])
    assert res.paths.steps[0][-1] > b_leaves
    # with one pass only, A stays at its target (stuck) and B folds
    one = roadmap_pass(geom, targets, fold, np.ones(2, bool), md, step, SearchResolveSettings(),
                       np.random.default_rng(0), max_passes=1)
    assert list(one.planned) == [False, True]
    np.testing.assert_allclose(one.final[0], targets[0])
    with pytest.raises(SpecError, match="max_passes"):
        roadmap_pass(geom, targets, fold, np.ones(2, bool), md, step, SearchResolveSettings(),
                     np.random.default_rng(0), max_passes=0)


def test_the_pair_as_a_plan_passes_the_independent_check():
    geom, targets = pair_geometry()
    plan = plan_reconfiguration(geom, targets, PlannerSettings(algorithm="roadmap", step_deg=0.5),
                                np.random.default_rng(0))
    assert plan.complete and plan.metrics["convergence"] == 1.0
    np.testing.assert_allclose(plan.end(), targets, atol=1e-9)
    assert_clear(geom, plan)


@pytest.mark.parametrize("seed", [1, 2])
def test_a_crowded_array_keeps_every_target_and_is_clear(seed):
    """hex 19 at 3.0 mm: prioritized pass, stuck robots re-planned by the group search."""
    geom = make_geom(19, 3.0)
    targets, plan = plan_random(geom, seed, resolver="search", algorithm="roadmap", step_deg=0.2)
    m = plan.metrics
    assert m["efficiency"] == 1.0 and m["n_deadlocked"] == 0 and plan.complete
    assert np.all(plan.status == REACHED)
    np.testing.assert_allclose(plan.end(), targets, atol=1e-9)
    np.testing.assert_allclose(plan.start(), np.tile(geom.spec.fold_deg, (geom.n_robots, 1)))
    assert np.allclose(plan.path_step, np.round(plan.path_step))      # whole steps
    assert_clear(geom, plan)
