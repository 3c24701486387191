"""Deadlock resolution by greedy-first Markov re-runs (planners/rerun.py) and the kernel's
mixed runs it relies on; plans are declared clear only by the independent 2D checker."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.errors import SpecError
from rfp_twin.models.layout import Layout
from rfp_twin.models.robot import load_spec
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.planners.plan import REACHED, build_paths
from rfp_twin.planners.rerun import (EXTRA_ATTEMPTS, LADDER, PATIENCE, STEP_CAP, arrival_steps,
                                     grow_region, rerun_deadlocks)
from rfp_twin.planners.solver import PlannerSettings
from rfp_twin.planners.stepwise import StepRun, array_max_displacement, run_array
from rfp_twin.validation.checker2d import check_trajectory
from tests.planners.conftest import make_geom, plan_random


@pytest.fixture(scope="module")
def deadlock_547():
    """547 grid, 2.5 mm, 0.25 deg, seed 5: the greedy run leaves two groups (6 robots)."""
    geom = ArrayGeometry(load_spec("sdss-v"), Layout.sdss_v_grid(), 2.5)
    targets, first = plan_random(geom, 5, resolve=False, step_deg=0.25)
    _, plan = plan_random(geom, 5, resolver="search", step_deg=0.25)
    return geom, targets, first, plan


def test_the_rerun_keeps_every_target_without_the_search(deadlock_547):
    geom, targets, first, plan = deadlock_547
    m = plan.metrics
    assert first.metrics["n_deadlocked"] >= 2 and m["convergence"] < 1.0
    assert m["n_rerun_groups"] >= 2 and m["n_rerun_robots"] == first.metrics["n_deadlocked"]
    assert 1 <= m["rerun_attempts"] <= len(LADDER) and m["rerun_s"] > 0.0
    assert m["n_search_groups"] == 0 and m["search_s"] == 0.0 and m["n_replaced"] == 0
    assert plan.complete and np.all(plan.status == REACHED)
    np.testing.assert_allclose(plan.end(), targets, atol=1e-9)
    np.testing.assert_allclose(plan.start(), np.tile(geom.spec.fold_deg, (geom.n_robots, 1)))
    # the re-run's steps are bounded by the cap, measured from the deadlocked run's length
    assert plan.n_steps <= np.ceil(STEP_CAP * first.n_steps)
    assert m["tau_sr_s"] >= m["tau_pg_s"] + m["rerun_s"] - 1e-9
    report = check_trajectory(Trajectory.from_plan(plan), geom.spec, geom.layout, geom.buffer_mm)
    assert report.ok, report.table()


def test_grow_region_follows_the_neighbour_pairs():
    pairs = np.array([[0, 1], [1, 2], [2, 3], [3, 4]])     # a chain 0-1-2-3-4
    seed = np.zeros(5, bool)
    seed[2] = True
    assert grow_region(pairs, seed, 0).tolist() == seed.tolist()
    assert np.flatnonzero(grow_region(pairs, seed, 1)).tolist() == [1, 2, 3]
    assert grow_region(pairs, seed, 9).all()
    assert not seed[[0, 1, 3, 4]].any()        # the input is not modified


def _fake(n_steps: int, stuck: list[int], n: int = 8) -> StepRun:
    """A run of n robots whose goal is (0, 0): ``stuck`` ones end at (1, 1)."""
    final = np.zeros((n, 2))
    final[stuck] = 1.0
    return StepRun(final, n_steps, np.zeros(0, np.int64), np.zeros(0, np.int64),
                   np.zeros((0, 2)), 0.0)


def _ladder_of(runs: list[StepRun]):
    """A run function that hands out ``runs`` in turn and records its calls."""
    calls = []

    def run(greed, phobia, greedy_first, seed, max_steps):
        calls.append((greed.copy(), phobia.copy(), greedy_first.copy(), seed, max_steps))
        return runs[len(calls) - 1]
    return run, calls


PAIRS = np.array([[i, i + 1] for i in range(7)])     # a chain of 8 robots
GOAL = np.zeros((8, 2))
MOVABLE = np.ones(8, bool)


def test_the_first_complete_attempt_no_longer_than_the_plan_is_taken_at_once():
    first = _fake(100, [3])
    run, calls = _ladder_of([_fake(110, []), _fake(100, []), _fake(90, [])])
    rr = rerun_deadlocks(first, GOAL, MOVABLE, PAIRS, 1.0, 0.0, run, seed=7)
    assert rr.attempts == 2 and len(calls) == 2
    assert rr.solved.n_steps == 100 and rr.fewest is rr.solved
    greed, phobia, region, seed, max_steps = calls[0]
    hops = LADDER[0][0]
    assert np.flatnonzero(region).tolist() == list(range(3 - hops, 4 + hops))   # robot 3, grown
    assert np.all(greed[region] == LADDER[0][1]) and np.all(greed[~region] == 1.0)
    assert np.all(phobia[region] == LADDER[0][2]) and np.all(phobia[~region] == 0.0)
    assert max_steps == int(np.ceil(STEP_CAP * 100))
    assert len({c[3] for c in calls}) == 2                       # a new seed per attempt


def test_without_an_early_accept_the_shortest_complete_attempt_wins():
    first = _fake(100, [3])
    run, _ = _ladder_of([_fake(125, [2]), _fake(120, []), _fake(125, [2]), _fake(110, []),
                         _fake(105, [])])
    rr = rerun_deadlocks(first, GOAL, MOVABLE, PAIRS, 1.0, 0.0, run, seed=0, attempts=8)
    # EXTRA_ATTEMPTS more after the first complete one (the second attempt), then stop
    assert rr.attempts == 2 + EXTRA_ATTEMPTS == 4
    assert rr.solved.n_steps == 110 and rr.fewest is rr.solved


def test_when_nothing_completes_the_attempt_with_fewest_stuck_goes_on():
    first = _fake(100, [6, 7])
    runs = [_fake(125, [0, 6, 7]), _fake(125, [7]), _fake(125, [3, 7])]
    run, calls = _ladder_of(runs)
    rr = rerun_deadlocks(first, GOAL, MOVABLE, PAIRS, 0.9, 0.3, run, seed=0, attempts=3)
    assert rr.solved is None and rr.fewest is runs[1] and rr.attempts == 3
    # robot 0, stuck only in the first attempt, is in the region of the next ones
    assert not calls[0][2][0] and calls[1][2][0] and calls[2][2][0]
    # the plan's own Markov parameters stay outside the region
    greed, phobia, region, *_ = calls[0]
    assert np.all(greed[~region] == 0.9) and np.all(phobia[~region] == 0.3)


def test_attempts_that_make_no_progress_stop_the_ladder():
    first = _fake(100, [3, 4])
    runs = [_fake(125, [3]), _fake(125, [3]), _fake(125, [3, 4]), _fake(125, [])]
    run, calls = _ladder_of(runs)
    rr = rerun_deadlocks(first, GOAL, MOVABLE, PAIRS, 1.0, 0.0, run, seed=0, attempts=8)
    assert rr.attempts == 1 + PATIENCE == len(calls) and rr.solved is None
    assert rr.fewest is runs[0]


def test_nothing_better_than_the_first_run_returns_it():
    first = _fake(100, [3])
    run, _ = _ladder_of([_fake(125, [2, 3]), _fake(125, [1, 3])])
    rr = rerun_deadlocks(first, GOAL, MOVABLE, PAIRS, 1.0, 0.0, run, seed=0, attempts=2)
    assert rr.solved is None and rr.fewest is first


def test_reruns_must_not_be_negative():
    with pytest.raises(SpecError, match="'reruns'"):
        PlannerSettings(reruns=-1)


def test_a_free_greedy_first_robot_moves_as_a_greedy_one():
    """Nothing ever blocks a lone robot, so a greedy-first Markov robot with any greed and
    phobia takes the obvious move at every step: the greedy path, step for step."""
    geom = make_geom(1, 2.0)
    start = np.array([[30.0, 40.0]])
    dest = np.array([[250.0, 170.0]])
    kw = dict(step_deg=0.5, max_steps=2000, md=array_max_displacement(geom, 0.5), seed=3)
    greedy = run_array(geom, start, dest, np.ones(1, bool), greed=1.0, phobia=0.0, **kw)
    first = run_array(geom, start, dest, np.ones(1, bool), greed=0.2, phobia=0.9,
                      greedy_first=np.ones(1, bool), **kw)
    markov = run_array(geom, start, dest, np.ones(1, bool), greed=0.2, phobia=0.9, **kw)
    assert first.n_steps == greedy.n_steps
    np.testing.assert_array_equal(first.final, greedy.final)
    np.testing.assert_allclose(_states(first, start), _states(greedy, start), atol=1e-12)
    assert markov.n_steps > greedy.n_steps       # a plain Markov robot wanders


def _states(run: StepRun, start: np.ndarray) -> np.ndarray:
    """(n_steps + 1, 2) deg: robot 0's angles at every step, from the run's breakpoints."""
    ptr, steps, angles = build_paths(1, run.ev_robot, run.ev_step, run.ev_angles, start,
                                     run.final, run.n_steps)
    t = np.arange(run.n_steps + 1)
    st, an = steps[ptr[0]:ptr[1]], angles[ptr[0]:ptr[1]]
    return np.column_stack([np.interp(t, st, an[:, 0]), np.interp(t, st, an[:, 1])])


def test_robots_outside_a_markov_region_keep_the_greedy_rules():
    """A mixed run with every robot greedy (greed 1, phobia 0 as arrays) is the greedy run."""
    geom = make_geom(37, 2.0)
    targets, _ = plan_random(geom, 2, resolve=False, step_deg=0.5)
    fold = np.tile(np.asarray(geom.spec.fold_deg, float), (geom.n_robots, 1))
    kw = dict(step_deg=0.5, max_steps=2000, md=array_max_displacement(geom, 0.5), seed=1)
    mov = np.ones(geom.n_robots, bool)
    a = run_array(geom, targets, fold, mov, greed=1.0, phobia=0.0, **kw)
    b = run_array(geom, targets, fold, mov, greed=np.ones(geom.n_robots),
                  phobia=np.zeros(geom.n_robots), greedy_first=mov.copy(), **kw)
    assert a.n_steps == b.n_steps
    np.testing.assert_array_equal(a.ev_robot, b.ev_robot)
    np.testing.assert_array_equal(a.ev_angles, b.ev_angles)


def test_the_cap_counts_from_the_last_arrival_not_from_the_stuck_robots_moves():
    # robots 0, 1 arrive at steps 40 and 60; robot 2 (stuck) moves until step 90
    run = StepRun(np.zeros((3, 2)), 95, np.array([0, 1, 2, 2]), np.array([39, 59, 10, 89]),
                  np.zeros((4, 2)), 0.0)
    assert arrival_steps(run, np.array([False, False, True])) == 60
    assert arrival_steps(run, np.array([True, True, True])) == 95      # nobody arrived
