"""The stepwise plan driver (Sayres 2021 Sects. 4-5): :func:`plan_reconfiguration`.

A plan goes through these stages: the targets and offline robots are checked; each
round runs the planner over the whole array (:func:`rfp_twin.planners.plan.runs.run_once`:
the GC/MC kernel, or Sabater's roadmap planner on every robot) in the planning frame
(reverse, the default: targets -> fold, played backwards; forward: fold -> targets, for
comparison, Fig. 8); the deadlock strategies of :mod:`rfp_twin.planners.deadlocks` are
tried on what the run left, in the order of :mod:`rfp_twin.planners.deadlocks.chain`;
a round with groups left replaces one target per group and plans again, until every
group is resolved or ``max_rounds`` is spent.

Metrics follow the paper: efficiency (Eq. 11, replaced robots counted once),
convergence of the first run, tau_pg (wall time of the first round's path generation:
its run, every kernel call of it, those repeated after a breakpoint-buffer overflow and
the fold-repair runs included; ``pg_retries`` counts such repeats over all rounds' runs,
none below :data:`rfp_twin.planners.stepwise.run.MAX_EVENTS`), tau_sr (every round's
runs, fold repairs and re-runs), ``planning_s`` (the whole call), fold time (steps x
step duration); then what each deadlock strategy did
(:func:`rfp_twin.planners.deadlocks.chain.resolution_metrics`).

Units: angles in deg, lengths in mm, plan time in planner steps (``step_s`` s each).
"""
from __future__ import annotations

import time
from typing import Callable

import numpy as np

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.errors import PlanningError
from rfp_twin.planners.deadlocks.chain import (path_generation_seconds, resolution_chain,
                                               resolution_metrics)
from rfp_twin.planners.deadlocks.resolver import Record, Round
from rfp_twin.planners.plan.offline import apply_offline
from rfp_twin.planners.plan.result import DEADLOCKED, OFFLINE, REACHED, REPLACED, Plan
from rfp_twin.planners.plan.runs import run_once
from rfp_twin.planners.plan.settings import PlannerSettings
from rfp_twin.planners.plan.targets import check_targets
from rfp_twin.planners.stepwise import StepRun, array_max_displacement

#: Largest fraction of the movable robots that may be stuck after the first run for
#: deadlock resolution to be tried: beyond it the planner itself failed (e.g. Markov with
#: phobia 0.6, whose arrived robots keep stepping aside), and resolving group by group
#: would run for hours.
MAX_STUCK_FRACTION = 0.5


def plan_reconfiguration(geom: ArrayGeometry, targets: np.ndarray, settings: PlannerSettings,
                         rng: np.random.Generator, *,
                         offline: dict[int, tuple[float, float]] | None = None,
                         resolve: bool = True,
                         progress: Callable[[int, int], None] | None = None,
                         start: np.ndarray | None = None) -> Plan:
    """Plan the array from the folded state (or ``start``) to ``targets`` (executed direction).

    geom : ArrayGeometry; targets : (n, 2) deg, one row per robot (rows of offline robots
    are ignored); rng : seeds each round's run and draws replacement targets; offline :
    {robot_id: (alpha, beta)}, robots that never move, at these angles; resolve : resolve
    deadlocks (True), or stop after the first run (False: stuck robots end DEADLOCKED);
    progress : ``progress(round, n_stuck)`` after each round's run; start : (n, 2) deg,
    where the robots stand before the motion [default: every robot folded]: a
    reconfiguration between two arbitrary clear configurations (the next pass of a
    field planned from the poses of the last one). The planner then works between the
    two sets of poses the way it works between the targets and the fold: reverse
    planning runs from ``targets`` to ``start`` and plays the run backwards; deadlock
    resolution is the same (a replaced robot gets a new target, never a new start).

    Returns the Plan in the executed direction (step 0 folded or ``start``, the last step
    the targets); robots left deadlocked keep their path to where they stopped.
    """
    clock = time.perf_counter()
    targets, fold, movable = _checked_inputs(geom, targets, offline, start)
    original, replaced = targets.copy(), np.zeros(geom.n_robots, dtype=bool)
    md = array_max_displacement(geom, settings.step_deg)
    chain = resolution_chain(settings, rng, resolve)
    runs: list[StepRun] = []                    # each round's run, as the planner made it
    records: list[Record] = []
    rounds = 0
    while True:
        seed = int(rng.integers(0, 2**31 - 1))
        start, goal = (targets, fold) if settings.direction == "reverse" else (fold, targets)
        runs.append(run_once(geom, start, goal, movable, settings, seed))
        rnd = Round(geom, settings, seed, targets, original, replaced, fold, movable, md, runs[-1])
        records += [resolver.resolve(rnd) for resolver in chain.on_run]
        rnd.settle()
        if len(runs) == 1:
            tau_pg = runs[0].seconds + path_generation_seconds(records)
            convergence = _convergence(rnd, resolve)
        if progress is not None:
            progress(rounds, int(rnd.stuck.sum()))
        for resolver in chain.on_groups:
            if rnd.groups and resolver.applies(rnd):
                records.append(resolver.resolve(rnd))
        if not rnd.groups or not resolve or rounds >= settings.max_rounds:
            break
        rounds += 1
        records.append(chain.between_rounds.resolve(rnd))
        if not rnd.groups:                      # the replaced groups resolved in place
            break
        targets = rnd.targets
    metrics = {"convergence": convergence, "rounds": rounds, "tau_pg_s": tau_pg,
               "tau_sr_s": sum(r.seconds for r in runs) + path_generation_seconds(records),
               "pg_retries": sum(r.retries for r in runs)}
    if settings.algorithm == "mdp2":
        metrics["mdp2_tries"] = runs[0].tries       # of the first round's run
    return _plan(rnd, records, metrics, clock)


def _checked_inputs(geom: ArrayGeometry, targets: np.ndarray,
                    offline: dict[int, tuple[float, float]] | None,
                    start: np.ndarray | None = None):
    """(targets (n, 2) deg, fold (n, 2) deg, movable (n,) bool), checked: offline robots
    stand at their angles, in the targets and the folded state alike. ``fold`` is the
    other end of the motion: the folded state, or ``start`` when given."""
    targets = np.array(targets, dtype=np.float64, copy=True)
    movable = apply_offline(geom, offline, targets)
    check_targets(geom, targets)
    if start is None:
        fold = np.tile(np.asarray(geom.spec.fold_deg, dtype=np.float64), (geom.n_robots, 1))
    else:
        fold = np.array(start, dtype=np.float64, copy=True).reshape(geom.n_robots, 2)
    fold[~movable] = targets[~movable]
    check_targets(geom, fold)
    return targets, fold, movable


def _convergence(rnd: Round, resolve: bool) -> float:
    """Share of the movable robots the first run brought home; a PlanningError when too
    many are stuck for deadlock resolution (:data:`MAX_STUCK_FRACTION`)."""
    s, stuck, n_mov = rnd.settings, int(rnd.stuck.sum()), int(rnd.movable.sum())
    if resolve and stuck > MAX_STUCK_FRACTION * max(1, n_mov):
        raise PlanningError(
            ("greedy" if s.greedy else f"{s.algorithm} (greed {s.greed:g}, phobia {s.phobia:g})")
            + f": {stuck} of {n_mov} robots did not reach their destination in "
            f"{rnd.run.n_steps} steps; deadlock resolution handles groups, not most of the "
            f"array; allowed: at most {MAX_STUCK_FRACTION:.0%} stuck (a lower phobia, e.g. "
            "the paper's 0.3, a larger max_steps, or greedy)")
    return float(1.0 - rnd.stuck.sum() / max(1, rnd.movable.sum()))


def _plan(rnd: Round, records: list[Record], runs_metrics: dict, clock: float) -> Plan:
    """The Plan of the last round (executed direction) with every metric (those of the
    rounds' runs given in ``runs_metrics``)."""
    geom, settings, spec = rnd.geom, rnd.settings, rnd.geom.spec
    n, n_mov, n_replaced = geom.n_robots, int(rnd.movable.sum()), int(rnd.replaced.sum())
    n_steps, ptr, steps, angles = rnd.paths()
    status = np.where(rnd.replaced, REPLACED, REACHED).astype(object)
    status[rnd.stuck] = DEADLOCKED
    status[~rnd.movable] = OFFLINE
    metrics = {
        "n_robots": n, "n_movable": n_mov, "n_offline": n - n_mov, "n_replaced": n_replaced,
        "n_deadlocked": int(rnd.stuck.sum()), "efficiency": (n_mov - n_replaced) / max(1, n_mov),
        "convergence": runs_metrics["convergence"], "rounds": runs_metrics["rounds"],
        "tau_pg_s": runs_metrics["tau_pg_s"], "tau_sr_s": runs_metrics["tau_sr_s"],
        "pg_retries": runs_metrics["pg_retries"],
        "fold_time_s": n_steps * spec.step_seconds(settings.step_deg), "n_steps": n_steps,
        "max_displacement_mm": rnd.md,
        **resolution_metrics(records, rnd.search),
        **{k: runs_metrics[k] for k in ("mdp2_tries",) if k in runs_metrics},
        "planning_s": time.perf_counter() - clock,
    }
    plan = Plan(robot_ids=geom.robot_ids.copy(), step_deg=settings.step_deg,
                step_s=spec.step_seconds(settings.step_deg), n_steps=n_steps, path_ptr=ptr,
                path_step=steps, path_angles=angles, status=status, targets=rnd.targets,
                original_targets=rnd.original, metrics=metrics)
    return plan.reversed() if rnd.reverse else plan
