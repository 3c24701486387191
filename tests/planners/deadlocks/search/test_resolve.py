"""Deadlock resolution that keeps targets (planners/deadlocks/search/resolve.py) and its
fallbacks in the solver, checked by the independent 2D checker (rfp_twin.validation.checker2d),
never by the planner itself."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.kinematics import inverse
from rfp_twin.models.layout import Layout
from rfp_twin.models.robot import load_spec
from rfp_twin.planners.plan import DEADLOCKED, OFFLINE, REACHED, REPLACED
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.planners.deadlocks.search import PathSet, SearchResolveSettings
from rfp_twin.planners.plan import PlannerSettings, plan_reconfiguration
from tests.planners.conftest import make_geom, plan_random
from rfp_twin.validation.checker2d import check_trajectory


def assert_clear(geom: ArrayGeometry, plan) -> None:
    report = check_trajectory(Trajectory.from_plan(plan), geom.spec, geom.layout, geom.buffer_mm)
    assert report.ok, report.table()
    assert report.min_clearance_mm > 0.0


@pytest.fixture(scope="module")
def deadlock_547():
    """547 grid, 2.5 mm, 0.25 deg, seed 5: greedy leaves two deadlocked groups (6 robots).
    No re-runs (``reruns=0``, :mod:`rfp_twin.planners.deadlocks.rerun`): the search gets the groups."""
    geom = ArrayGeometry(load_spec("sdss-v"), Layout.sdss_v_grid(), 2.5)
    targets, plan = plan_random(geom, 5, resolver="search", step_deg=0.25, reruns=0)
    return geom, targets, plan


def test_a_real_deadlock_is_resolved_with_every_target_kept(deadlock_547):
    geom, targets, plan = deadlock_547
    m = plan.metrics
    assert m["convergence"] < 1.0                 # the first greedy run deadlocked ...
    assert m["n_search_groups"] >= 1 and m["n_search_robots"] >= 2
    assert m["n_replaced"] == 0 and m["n_replace_groups"] == 0 and m["rounds"] == 0
    assert m["efficiency"] == 1.0 and m["n_deadlocked"] == 0
    assert plan.complete and np.all(plan.status == REACHED)     # ... and nobody gave up
    np.testing.assert_array_equal(plan.targets, targets)
    np.testing.assert_allclose(plan.end(), targets, atol=1e-9)
    np.testing.assert_allclose(plan.start(), np.tile(geom.spec.fold_deg, (geom.n_robots, 1)))
    assert m["search_s"] > 0.0
    assert_clear(geom, plan)


def test_replacement_on_the_same_targets_gives_targets_away(deadlock_547):
    geom, targets, _ = deadlock_547
    _, plan = plan_random(geom, 5, resolver="replace", step_deg=0.25)
    assert plan.metrics["n_replaced"] >= 1 and plan.metrics["efficiency"] < 1.0
    assert plan.metrics["n_search_groups"] == 0


def test_search_paths_run_on_the_step_clock_at_the_robot_speed(deadlock_547):
    geom, _, plan = deadlock_547
    assert np.allclose(plan.path_step, np.round(plan.path_step))      # whole steps
    speed = Trajectory.from_plan(plan).max_speed()
    assert speed.max() <= max(geom.spec.max_speed_deg_s) * (1 + 1e-9)
    assert plan.metrics["fold_time_s"] == pytest.approx(plan.n_steps * plan.step_s)


def test_markov_deadlock_is_resolved_too():
    """547 grid, 3.5 mm, 0.1 deg, seed 5: the Markov planner leaves two robots stuck."""
    geom = ArrayGeometry(load_spec("sdss-v"), Layout.sdss_v_grid(), 3.5)
    targets, plan = plan_random(geom, 5, resolver="search", algorithm="markov", step_deg=0.1)
    m = plan.metrics
    assert m["convergence"] < 1.0 and m["n_search_robots"] >= 2
    assert m["rerun_attempts"] == 0          # re-runs are for greedy plans only
    assert m["n_replaced"] == 0 and plan.complete and np.all(plan.status == REACHED)
    np.testing.assert_allclose(plan.end(), targets, atol=1e-9)
    # the deadlocked Markov run went on to its step limit; the plan ends with its motion
    first = plan_reconfiguration(geom, targets, PlannerSettings(algorithm="markov", step_deg=0.1),
                                 np.random.default_rng(5), resolve=False)
    assert plan.n_steps < first.n_steps == PlannerSettings(step_deg=0.1).steps_limit
    assert_clear(geom, plan)


def walled_in_case():
    """7 robots at 2.5 mm: the centre robot must turn alpha from 200 deg down to 10 deg
    (no wrap: limits [0, 360]) and an offline neighbour's fiber sits 10 mm above its
    base, where its elbow passes at alpha = 90 deg: no plan can fold it. Returns
    (geom, targets, offline, centre index)."""
    geom = make_geom(7, 2.5)
    c = int(np.argmin(np.hypot(*geom.base_xy.T)))
    rel = geom.base_xy - geom.base_xy[c]
    o = int(np.argmin(np.hypot(rel[:, 0] - 11.2, rel[:, 1] - 19.4)))   # upper-right neighbour
    tip = geom.base_xy[c] + np.array([0.0, 10.0])
    spec = geom.spec
    o_ang = inverse(geom.base_xy[[o]], tip[None, :], spec.alpha_length_mm, spec.beta_length_mm)[0]
    targets = np.tile(np.asarray(spec.fold_deg, float), (geom.n_robots, 1))
    targets[c] = (200.0, 150.0)
    targets[o] = o_ang
    return geom, targets, {int(geom.robot_ids[o]): tuple(o_ang)}, c


def test_an_impossible_group_falls_back_to_replacing_its_target():
    geom, targets, offline, c = walled_in_case()
    settings = PlannerSettings(step_deg=0.5)
    plan = plan_reconfiguration(geom, targets, settings, np.random.default_rng(0), offline=offline)
    assert plan.metrics["rerun_attempts"] >= 1 and plan.metrics["n_rerun_groups"] == 0
    m = plan.metrics
    assert m["n_search_failed_groups"] >= 1       # the search could not fold it ...
    assert m["n_replace_groups"] >= 1 and m["n_replaced"] == 1      # ... so it got a new target
    assert plan.status[c] == REPLACED and plan.complete
    assert np.sum(plan.status == OFFLINE) == 1
    assert_clear(geom, plan)


def test_a_new_target_is_searched_in_place_before_a_whole_new_round():
    """After the search fails and the group's robot gets a new target, the group alone is
    searched again against everyone else's paths; it finds a way, so no new round runs.
    The same target is replaced as with a whole new round, and the checker finds the
    plan clear."""
    geom, targets, offline, c = walled_in_case()
    plans = {local: plan_reconfiguration(geom, targets, PlannerSettings(step_deg=0.5,
                                                                        local_replace=local),
                                         np.random.default_rng(0), offline=offline)
             for local in (True, False)}
    m = plans[True].metrics
    assert m["n_local_groups"] == 1 and plans[False].metrics["n_local_groups"] == 0
    assert plans[True].status[c] == REPLACED and plans[True].complete
    np.testing.assert_array_equal(plans[True].targets, plans[False].targets)
    np.testing.assert_allclose(plans[True].end(), plans[True].targets, atol=1e-9)
    assert_clear(geom, plans[True])


def test_a_search_in_place_that_lengthens_the_plan_gives_way_to_a_whole_round(monkeypatch):
    """The in-place result is taken only if it does not lengthen the plan it joins: made
    longer here, the plan is the one of a whole new round (as without the attempt)."""
    from rfp_twin.planners.deadlocks.search.strategy import SearchResolver

    geom, targets, offline, c = walled_in_case()
    without = plan_reconfiguration(geom, targets, PlannerSettings(step_deg=0.5, local_replace=False),
                                   np.random.default_rng(0), offline=offline)
    searched = SearchResolver.search_replaced

    def longer(*args, **kwargs):
        out = searched(*args, **kwargs)
        out.n_steps += 10**6
        return out

    monkeypatch.setattr(SearchResolver, "search_replaced", longer)
    plan = plan_reconfiguration(geom, targets, PlannerSettings(step_deg=0.5),
                                np.random.default_rng(0), offline=offline)
    assert plan.metrics["n_local_groups"] == 0
    for name in ("path_ptr", "path_step", "path_angles", "targets"):
        np.testing.assert_array_equal(getattr(plan, name), getattr(without, name))


STARVED = SearchResolveSettings(max_nodes=1, max_recruits=0)


def test_when_the_search_in_place_fails_the_whole_round_runs_as_without_it(deadlock_547):
    """A starved search also fails in place: the plan is then byte for byte the one made
    without the attempt (it draws nothing from the planner's generator)."""
    geom, targets, _ = deadlock_547
    plans = [plan_reconfiguration(geom, targets, PlannerSettings(
        step_deg=0.25, search=STARVED, continuation=0, reruns=0, local_replace=local),
        np.random.default_rng(5)) for local in (True, False)]
    assert plans[0].metrics["n_local_groups"] == 0 and plans[0].metrics["rounds"] >= 1
    for name in ("path_ptr", "path_step", "path_angles", "targets"):
        np.testing.assert_array_equal(getattr(plans[0], name), getattr(plans[1], name))


def test_search_budget_exhausted_also_falls_back(deadlock_547):
    geom, targets, _ = deadlock_547
    starved = PlannerSettings(step_deg=0.25, search=STARVED, continuation=0, reruns=0)
    plan = plan_reconfiguration(geom, targets, starved, np.random.default_rng(5))
    m = plan.metrics
    assert m["n_search_failed_groups"] >= 1 and m["n_replaced"] >= 1
    assert m["n_continued_groups"] == 0
    assert plan.complete
    assert_clear(geom, plan)


def test_groups_the_search_leaves_go_on_alone_after_the_plan(deadlock_547):
    """Search starved: the Markov continuation untangles the groups after everyone else
    has folded; targets kept, the plan is longer, and the checker finds it clear."""
    geom, targets, searched = deadlock_547
    starved = PlannerSettings(step_deg=0.25, search=STARVED, reruns=0)
    plan = plan_reconfiguration(geom, targets, starved, np.random.default_rng(5))
    m = plan.metrics
    assert m["n_search_failed_groups"] >= 1 and m["n_continued_groups"] >= 1
    assert m["n_continued_robots"] >= 2 and m["continuation_s"] > 0.0
    assert m["n_replaced"] == 0 and m["efficiency"] == 1.0 and plan.complete
    np.testing.assert_allclose(plan.end(), targets, atol=1e-9)
    np.testing.assert_allclose(plan.start(), np.tile(geom.spec.fold_deg, (geom.n_robots, 1)))
    # executed direction: the stuck robots unfold first, alone, while everyone else
    # stays folded; then the first run's motion follows
    first = plan_reconfiguration(geom, targets, starved, np.random.default_rng(5), resolve=False)
    stuck = first.status == DEADLOCKED
    # the first run's motion (the resolved plan ends with its last motion, the kernel's
    # run may have gone on a step longer before it found nothing moves)
    back = first.reversed()
    motion = PathSet.from_csr(back.path_ptr, back.path_step, back.path_angles)
    lead = int(np.ceil(max(motion.motion_end(i) for i in range(geom.n_robots))))
    c = plan.n_steps - lead
    assert c > 0 and stuck.sum() >= 2
    fold = np.tile(geom.spec.fold_deg, (geom.n_robots, 1))
    during = plan.angles_at(np.linspace(0.0, c, 50))
    np.testing.assert_allclose(during[:, ~stuck], np.broadcast_to(fold[~stuck], during[:, ~stuck].shape))
    assert np.any(np.abs(during[:, stuck] - fold[stuck]) > 1.0)
    np.testing.assert_allclose(plan.angles_at(np.array([float(c)]))[0],
                               first.angles_at(np.array([float(first.n_steps - lead)]))[0], atol=1e-9)
    assert_clear(geom, plan)
