"""Shortening a stepwise run where a neighbour holds up the last robot
(planners/deadlocks/fold_repair.py), on the Table 3 setting (547 grid, GC, 2.5 mm, 0.25 deg);
plans checked by the independent 2D checker."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.robot import load_spec
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.planners.deadlocks.fold_repair import alpha_blockers, last_robot, shorten_run
from rfp_twin.planners.deadlocks.groups import arrival_steps, stuck_mask
from rfp_twin.planners.plan import PlannerSettings
from rfp_twin.planners.plan.runs import beta_first_robots, run_once
from rfp_twin.validation.checker2d import check_trajectory
from tests.planners.conftest import plan_random


@pytest.fixture(scope="module")
def table3(sdss_547):
    """Seed 8's targets (after replacement): with beta-first robots the robot that ends
    the run still loses alpha steps to one neighbour."""
    geom = ArrayGeometry(load_spec("sdss-v"), sdss_547, 2.5)
    _, plan = plan_random(geom, 8, step_deg=0.25)
    fold = np.tile(np.asarray(geom.spec.fold_deg, float), (geom.n_robots, 1))
    movable = np.ones(geom.n_robots, bool)
    settings = PlannerSettings(step_deg=0.25, beta_first=0.85)
    flags = beta_first_robots(plan.targets, fold, movable, 0.85)

    def rerun(f):
        return run_once(geom, plan.targets, fold, movable, settings, 0, beta_first=f)

    return geom, plan.targets, fold, movable, flags, rerun


def test_the_blockers_of_the_last_robot_are_its_neighbours(table3):
    geom, targets, fold, movable, flags, rerun = table3
    run = rerun(flags)
    stuck = stuck_mask(run, fold, movable)
    r = last_robot(run, stuck)
    last = np.full(geom.n_robots, -1)
    np.maximum.at(last, run.ev_robot, run.ev_step)
    assert last[r] == last[~stuck].max() and not stuck[r]
    blockers = alpha_blockers(geom, run, targets, fold, r, 0.25)
    neighbours = set(geom.nbr_idx[geom.nbr_ptr[r]:geom.nbr_ptr[r + 1]].tolist())
    assert blockers and set(blockers) <= neighbours


def test_switching_the_blocker_brings_the_arrivals_forward(table3):
    geom, targets, fold, movable, flags, rerun = table3
    run = rerun(flags)
    before = arrival_steps(run, stuck_mask(run, fold, movable))
    best, new_flags, made, seconds = shorten_run(geom, run, targets, fold, movable, flags, rerun,
                                                 0.25, 12)
    left = stuck_mask(best, fold, movable)
    assert 1 <= made <= 12 and seconds > 0.0
    assert arrival_steps(best, left) < before
    assert left.sum() <= stuck_mask(run, fold, movable).sum()
    assert (new_flags != flags).sum() >= 1
    assert not shorten_run(geom, run, targets, fold, movable, flags, rerun, 0.25, 0)[2]


def test_plans_with_fold_repairs_are_shorter_and_clear(sdss_547):
    """The Table 3 setting with beta-first robots, with and without repair runs: the
    repaired plan is shorter and the checker finds it clear."""
    geom = ArrayGeometry(load_spec("sdss-v"), sdss_547, 2.5)
    _, repaired = plan_random(geom, 8, step_deg=0.25, beta_first=0.85)
    _, plain = plan_random(geom, 8, step_deg=0.25, beta_first=0.85, fold_repairs=0)
    assert repaired.metrics["n_fold_repair_runs"] >= 1
    assert plain.metrics["n_fold_repair_runs"] == 0
    assert repaired.n_steps < plain.n_steps and repaired.complete
    report = check_trajectory(Trajectory.from_plan(repaired), geom.spec, geom.layout,
                              geom.buffer_mm)
    assert report.ok, report.table()
