"""Reverse (and forward) GC/MC planning with deadlock resolution (Sayres 2021 Sect. 5).

:func:`plan_reconfiguration` plans the motion from the folded state to the targets.
In reverse mode (the default) it plans targets -> fold and plays that backwards; in
forward mode it plans fold -> targets directly (for comparison, Fig. 8).

When robots deadlock (groups connected through the Eq. 4 neighbour graph), two
resolvers (``PlannerSettings.resolve``):

* ``"search"`` (default): first, for the greedy planner, the stepwise run is repeated
  around each group, in a patch of a few hundred robots inside a ring replaying the
  first run, with greedy-first Markov robots (:mod:`rfp_twin.planners.rerun`, up to
  ``PlannerSettings.reruns`` attempts a group, a few hundredths of a second each; a deadlocked
  Markov run has gone on to its step limit, so a re-run of it costs that much and is
  not tried); then each group left is re-planned by the state-time search of
  :mod:`rfp_twin.planners.resolve_search` (Sabater 2018), keeping every target; the other robots'
  stepwise paths are its moving obstacles and the new paths are merged into the plan
  on the same step clock. A group the search cannot resolve goes on alone with Markov
  moves after the plan's end, everyone else standing still
  (:mod:`rfp_twin.planners.continuation`). Only groups both fail on get a replaced target, as
  below;
* ``"replace"``: one robot per group gets a new random target and everything is
  planned again (Sayres 2021 Sect. 5.2), until the array converges or ``max_rounds``
  is spent.

Metrics follow the paper: efficiency (Eq. 11, replaced robots counted once; robots
kept by the search are not replaced), convergence of the first run, tau_pg (wall time of
the first planner run: every kernel call of it, those repeated after a breakpoint-buffer
overflow and the fold-repair runs included; ``pg_retries`` counts such repeats over all runs, none below
:data:`rfp_twin.planners.stepwise.run.MAX_EVENTS`), tau_sr (all runs), ``planning_s``
(the whole call: runs, re-runs, searches, continuation, replacements, paths), fold time
(steps x step duration); and the resolution: ``n_rerun_groups`` / ``n_rerun_robots``
(deadlocked groups / robots of a run that a re-run resolved, over all rounds),
``rerun_attempts``, ``rerun_s`` (wall time of the re-runs, also in tau_sr),
``n_search_groups`` / ``n_search_robots`` (deadlocked groups / robots the
final plan resolves by search), ``n_search_replanned`` (robots whose paths the search
changed, recruited neighbours included), ``n_search_failed_groups`` (over all rounds),
``n_replace_groups`` (groups resolved by replacing a target), ``search_s`` (wall time of
the searches), ``n_continued_groups`` / ``n_continued_robots`` (groups the final plan
resolves by continuation), ``continuation_s``, ``n_local_groups`` (groups with a
replaced target that the search resolved in place, without a new round),
``n_fold_repair_runs`` (whole runs made by :mod:`rfp_twin.planners.fold_repair`).

Units: angles in deg, lengths in mm, plan time in planner steps (``step_s`` s each).
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import TYPE_CHECKING
from dataclasses import replace as _with

import numpy as np

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.errors import PlanningError, SpecError
from rfp_twin.planners.plan import DEADLOCKED, OFFLINE, REACHED, REPLACED, Plan, build_paths
from rfp_twin.planners.continuation import continue_groups
from rfp_twin.planners.offline import apply_offline
from rfp_twin.planners.replacement import replace_one, search_replaced
from rfp_twin.planners.rerun import clusters, rerun_deadlocks, stuck_mask
if TYPE_CHECKING:
    from rfp_twin.planners.resolve_search import SearchResolveSettings
from rfp_twin.planners.stepwise import StepRun, array_max_displacement, run_array
from rfp_twin.planners.targets import check_targets

ALGORITHMS = ("greedy", "markov", "roadmap")
DIRECTIONS = ("reverse", "forward")
RESOLVERS = ("search", "replace")


@dataclass(frozen=True)
class PlannerSettings:
    """Parameters of one planning job.

    algorithm : "greedy" | "markov" (the stepwise kernel) | "roadmap" (Sabater's
    prioritized planner on every robot, :mod:`rfp_twin.planners.roadmap.array`); step_deg :
    angular step (deg); greed, phobia : MC parameters in [0, 1]; direction : "reverse" | "forward"; max_steps : step limit
    (default 1000 deg / step, as in the paper); max_rounds : deadlock-resolution rounds.
    resolve : "search" (re-plan each deadlocked group with the state-time search of
    :mod:`rfp_twin.planners.resolve_search`, keeping its targets; replace a target only where the
    search fails) | "replace" (replace one target per group and re-plan, Sayres 2021
    Sect. 5.2). reruns : with ``resolve="search"`` and the greedy planner, local re-runs at
    most a group with greedy-first Markov robots around it before the search
    (:mod:`rfp_twin.planners.rerun`; 0 = none). search : options of the search (None =
    defaults). continuation :
    with ``resolve="search"``, Markov runs at most that let the groups the search could
    not resolve go on alone after the plan's end (:mod:`rfp_twin.planners.continuation`) before
    a target is replaced; 0 = none. local_replace : with ``resolve="search"``, after a
    group's robot gets a new target the search first plans that group alone again,
    against everyone else's paths of the plan so far; only if a group still fails does a
    whole new round (a new planner run of the array) follow, the same round as without
    this attempt; the same too when the groups' new paths would lengthen the plan.
    beta_first : float >= 0, 0 = off (the paper's GC/MC moves, as kaiju makes them). Else
    in every run of the whole array, the robots whose alpha and beta travel together
    (in steps) is at most this fraction of the run's longest alpha travel retract beta
    first: their obvious move holds alpha until beta is at its destination, and when
    that move is blocked they move as usual. A retracted arm leaves its neighbours room
    to turn, and those robots have the time to spare (on the Table 3 setting it shortens
    the fold with acceleration limits; benchmarks/RESULTS.md). fold_repairs : with
    ``beta_first``, whole runs at most
    per round that switch the rule of the robot blocking the last one's alpha, each
    kept if robots arrive sooner (:mod:`rfp_twin.planners.fold_repair`); 0 = none.
    """

    algorithm: str = "greedy"
    step_deg: float = 0.1
    greed: float = 0.9
    phobia: float = 0.3
    direction: str = "reverse"
    max_steps: int | None = None
    max_rounds: int = 50
    resolve: str = "search"
    search: SearchResolveSettings | None = None
    continuation: int = 8
    reruns: int = 8
    local_replace: bool = True
    beta_first: float = 0.0
    fold_repairs: int = 12

    def __post_init__(self) -> None:
        if self.resolve not in RESOLVERS:
            raise SpecError(f"field 'resolve' = {self.resolve!r}; allowed: {', '.join(RESOLVERS)}")
        if self.algorithm not in ALGORITHMS:
            raise SpecError(f"field 'algorithm' = {self.algorithm!r}; allowed: {', '.join(ALGORITHMS)}")
        if self.direction not in DIRECTIONS:
            raise SpecError(f"field 'direction' = {self.direction!r}; allowed: {', '.join(DIRECTIONS)}")
        if not (np.isfinite(self.step_deg) and 0.001 <= self.step_deg <= 10.0):
            raise SpecError(f"field 'step_deg' = {self.step_deg!r}; allowed: [0.001, 10] deg")
        for name in ("greed", "phobia"):
            v = getattr(self, name)
            if not (np.isfinite(v) and 0.0 <= v <= 1.0):
                raise SpecError(f"field '{name}' = {v!r}; allowed: [0, 1]")
        if self.max_steps is not None and self.max_steps < 1:
            raise SpecError(f"field 'max_steps' = {self.max_steps!r}; allowed: >= 1")
        if self.max_rounds < 0:
            raise SpecError(f"field 'max_rounds' = {self.max_rounds!r}; allowed: >= 0")
        if self.continuation < 0:
            raise SpecError(f"field 'continuation' = {self.continuation!r}; allowed: >= 0")
        if self.reruns < 0:
            raise SpecError(f"field 'reruns' = {self.reruns!r}; allowed: >= 0")
        if self.fold_repairs < 0:
            raise SpecError(f"field 'fold_repairs' = {self.fold_repairs!r}; allowed: >= 0")
        if not (np.isfinite(self.beta_first) and 0.0 <= self.beta_first <= 2.0):
            raise SpecError(f"field 'beta_first' = {self.beta_first!r}; allowed: [0, 2] "
                            "(0: off)")

    @property
    def steps_limit(self) -> int:
        return int(self.max_steps or round(1000.0 / self.step_deg))

    @property
    def greedy(self) -> bool:
        return self.algorithm == "greedy"


def run_once(geom: ArrayGeometry, start: np.ndarray, dest: np.ndarray, movable: np.ndarray,
             settings: PlannerSettings, seed: int, beta_first: np.ndarray | None = None) -> StepRun:
    """One planner run: the stepwise kernel (:func:`rfp_twin.planners.stepwise.run_array`), or for
    ``algorithm="roadmap"`` one prioritized roadmap pass. ``beta_first`` (n,) bool: the
    robots that retract beta first [default: :func:`beta_first_robots` of the settings]."""
    md = array_max_displacement(geom, settings.step_deg)
    if settings.algorithm == "roadmap":
        return _run_roadmap(geom, start, dest, movable, settings, md, seed)
    return run_array(geom, start, dest, movable, step_deg=settings.step_deg,
                     max_steps=settings.steps_limit, md=md,
                     greed=1.0 if settings.greedy else settings.greed,
                     phobia=0.0 if settings.greedy else settings.phobia, seed=seed,
                     beta_first=beta_first if beta_first is not None else
                     beta_first_robots(start, dest, movable, settings.beta_first))


def beta_first_robots(start: np.ndarray, dest: np.ndarray, movable: np.ndarray,
                      fraction: float) -> np.ndarray | None:
    """(n,) bool: the movable robots whose alpha and beta travel from ``start`` to
    ``dest`` ((n, 2) deg) together is at most ``fraction`` of the longest alpha travel
    (see ``PlannerSettings.beta_first``); None when ``fraction`` is 0 or nobody moves."""
    movable = np.asarray(movable, dtype=bool)
    if fraction <= 0.0 or not movable.any():
        return None
    travel = np.abs(np.asarray(dest, dtype=np.float64) - np.asarray(start, dtype=np.float64))
    return movable & (travel.sum(axis=1) <= fraction * travel[movable, 0].max())


def _run_roadmap(geom: ArrayGeometry, start: np.ndarray, dest: np.ndarray, movable: np.ndarray,
                 settings: PlannerSettings, md: float, seed: int) -> StepRun:
    """A roadmap pass (:func:`rfp_twin.planners.roadmap.array.roadmap_pass`) as a StepRun."""
    from rfp_twin.planners.resolve_search import SearchResolveSettings
    from rfp_twin.planners.roadmap.array import roadmap_pass

    res = roadmap_pass(geom, start, dest, movable, md, settings.step_deg,
                       settings.search or SearchResolveSettings(), np.random.default_rng(seed))
    ev_robot, ev_step, ev_angles = res.events()
    return StepRun(res.final, res.n_steps, ev_robot, ev_step, ev_angles, res.seconds)


def _rerun(geom: ArrayGeometry, first: StepRun, start: np.ndarray, goal: np.ndarray,
           movable: np.ndarray, settings: PlannerSettings, seed: int):
    """Local re-runs of the greedy run ``first`` with greedy-first Markov robots around its
    deadlocked groups (:func:`rfp_twin.planners.rerun.rerun_deadlocks`), each group's
    patch inside a ring of robots replaying ``first``."""
    md = array_max_displacement(geom, settings.step_deg)
    paths = build_paths(geom.n_robots, first.ev_robot, first.ev_step, first.ev_angles, start,
                        first.final, first.n_steps)

    def run(robots, script, mov, greed, phobia, greedy_first, s, max_steps):
        return run_array(geom, start[robots], goal[robots], mov, step_deg=settings.step_deg,
                         max_steps=min(max_steps, settings.steps_limit), md=md, greed=greed,
                         phobia=phobia, seed=s, greedy_first=greedy_first, robots=robots,
                         script=script)

    return rerun_deadlocks(first, goal, movable, geom.pairs, paths, run, seed + 104729,
                           settings.reruns)


def _continue(geom: ArrayGeometry, outcome, groups: list[np.ndarray], goal: np.ndarray,
              settings: PlannerSettings, seed: int):
    """Markov continuation of the groups the search left (:mod:`rfp_twin.planners.continuation`),
    appended to ``outcome.paths`` after ``outcome.n_steps`` (both updated in place)."""
    paths = outcome.paths
    now = np.array([a[-1] for a in paths.angles])

    def run(start, dest, movable, greed, phobia, s):
        return run_once(geom, start, dest, movable,
                        _with(settings, algorithm="markov", greed=greed, phobia=phobia), s)

    cont = continue_groups(geom.n_robots, now, goal, groups, run, seed + 7919,
                           settings.continuation)
    offset = float(outcome.n_steps)
    for i, (st, an) in cont.paths.items():
        keep = paths.steps[i] < offset          # i stands still from its last motion on
        paths.steps[i] = np.concatenate([paths.steps[i][keep], offset + st])
        paths.angles[i] = np.vstack([paths.angles[i][keep], an])
        outcome.n_steps = max(outcome.n_steps, int(np.ceil(offset + st[-1])))
    return cont


def _shorten(geom: ArrayGeometry, run: StepRun, start: np.ndarray, goal: np.ndarray,
             movable: np.ndarray, settings: PlannerSettings, seed: int):
    """The run with the robot that ends it freed where a beta-first switch of its blocker
    does it (:func:`rfp_twin.planners.fold_repair.shorten_run`): (run, runs made, their
    kernel seconds)."""
    from rfp_twin.planners.fold_repair import shorten_run

    flags = beta_first_robots(start, goal, movable, settings.beta_first)
    if flags is None:                    # nobody moves
        return run, 0, 0.0
    best, _, made, spent = shorten_run(
        geom, run, start, goal, movable, flags,
        lambda f: run_once(geom, start, goal, movable, settings, seed, beta_first=f),
        settings.step_deg, settings.fold_repairs)
    return best, made, spent


def deadlocked_groups(geom: ArrayGeometry, stuck: np.ndarray) -> list[np.ndarray]:
    """Connected components of the stuck robots through the Eq. 4 neighbour graph."""
    return clusters(geom.pairs, stuck, 0)


#: Largest fraction of the movable robots that may be stuck after the first run for
#: deadlock resolution to be tried: beyond it the planner itself failed (e.g. Markov with
#: phobia 0.6, whose arrived robots keep stepping aside), and resolving group by group
#: would run for hours.
MAX_STUCK_FRACTION = 0.5


def plan_reconfiguration(geom: ArrayGeometry, targets: np.ndarray, settings: PlannerSettings,
                         rng: np.random.Generator, *, offline: dict[int, tuple[float, float]] | None = None,
                         resolve: bool = True, progress=None) -> Plan:
    """Plan the array from the folded state to ``targets`` (executed direction).

    Parameters
    ----------
    geom : ArrayGeometry
    targets : (n, 2) deg, one row per robot (rows of offline robots are ignored)
    settings : PlannerSettings
    rng : numpy Generator; seeds the Markov kernel and draws replacement targets
    offline : {robot_id: (alpha, beta)}; robots that never move, at these angles
    resolve : resolve deadlocks as ``settings.resolve`` says (True), or stop after the
        first run (False: the plan then marks stuck robots DEADLOCKED)
    progress : optional callable(round, n_stuck) called after each planner run

    Returns
    -------
    Plan in the executed direction: step 0 is the folded state, the last step the targets.
    Robots that stayed deadlocked keep their path to where they stopped.
    """
    clock = time.perf_counter()
    spec = geom.spec
    n = geom.n_robots
    targets = np.array(targets, dtype=np.float64, copy=True)
    movable = apply_offline(geom, offline, targets)
    check_targets(geom, targets)
    fold = np.tile(np.asarray(spec.fold_deg, dtype=np.float64), (n, 1))
    fold[~movable] = targets[~movable]
    check_targets(geom, fold)

    original = targets.copy()
    replaced = np.zeros(n, dtype=bool)
    md = array_max_displacement(geom, settings.step_deg)
    use_search = resolve and settings.resolve == "search"
    tau_sr = 0.0
    tau_pg = 0.0
    pg_retries = 0
    search_s = 0.0
    convergence = None
    rounds = 0
    n_replace_groups = 0
    n_search_failed = 0
    outcome = None
    memo: dict = {}       # search results by group and surroundings, across rounds
    continuation_s = 0.0
    n_continued_groups = n_continued_robots = 0
    rerun_s = 0.0
    rerun_attempts = n_rerun_groups = n_rerun_robots = 0
    n_local_groups = 0
    n_repair_runs = 0
    search_settings = None
    while True:
        seed = int(rng.integers(0, 2**31 - 1))
        if settings.direction == "reverse":
            run = run_once(geom, targets, fold, movable, settings, seed)
            start, goal = targets, fold
        else:
            run = run_once(geom, fold, targets, movable, settings, seed)
            start, goal = fold, targets
        tau_sr += run.seconds
        pg_retries += run.retries
        round_s = run.seconds          # this round's path generation, repair runs included
        if settings.beta_first > 0 and settings.fold_repairs > 0 and settings.algorithm != "roadmap":
            run, repair_runs, repair_s = _shorten(geom, run, start, goal, movable, settings, seed)
            tau_sr += repair_s
            round_s += repair_s
            n_repair_runs += repair_runs
        stuck = stuck_mask(run, goal, movable)
        if convergence is None:
            tau_pg = round_s
            convergence = 1.0 - stuck.sum() / max(1, movable.sum())
            if resolve and stuck.sum() > MAX_STUCK_FRACTION * max(1, movable.sum()):
                raise PlanningError(
                    ("greedy" if settings.greedy else
                     f"markov (greed {settings.greed:g}, phobia {settings.phobia:g})")
                    + f": {int(stuck.sum())} of {int(movable.sum())} "
                    f"robots did not reach their destination in {run.n_steps} steps; deadlock "
                    "resolution handles groups, not most of the array; allowed: at most "
                    f"{MAX_STUCK_FRACTION:.0%} stuck (a lower phobia, e.g. the paper's 0.3, "
                    "a larger max_steps, or greedy)")
        if progress is not None:
            progress(rounds, int(stuck.sum()))
        outcome = None
        partial = False   # this round's search starts from a re-run that left robots stuck
        to_replace = deadlocked_groups(geom, stuck) if stuck.any() else []
        if use_search and to_replace and settings.reruns > 0 and settings.greedy:
            # cheapest first: the same run again, greedy-first Markov robots around the groups
            rr = _rerun(geom, run, start, goal, movable, settings, seed)
            rerun_s += rr.seconds
            tau_sr += rr.seconds
            rerun_attempts += rr.attempts
            run = rr.run
            partial = rr.partial
            left = stuck_mask(run, goal, movable)
            resolved_groups = [g for g in to_replace if not left[g].any()]
            n_rerun_groups += len(resolved_groups)
            n_rerun_robots += int(sum(len(g) for g in resolved_groups))
            stuck = left
            to_replace = deadlocked_groups(geom, stuck) if stuck.any() else []
        if use_search and to_replace:
            # keep targets: re-plan each deadlocked group by state-time search; its own
            # generator (from this round's seed) leaves ``rng`` as "replace" uses it
            ptr, steps, angles = build_paths(n, run.ev_robot, run.ev_step, run.ev_angles, start,
                                             run.final, run.n_steps)
            # imported here: the search and its roadmaps (~40 ms of imports) only when a
            # group is left
            from rfp_twin.planners.resolve_search import (PathSet, SearchResolveSettings,
                                                          resolve_groups)

            search_settings = settings.search or SearchResolveSettings()
            # after a partial whole-array re-run the stuck robots wandered until the cap:
            # keeping that motion as their lead-in would delay the fold, so search from step 0
            outcome = resolve_groups(geom, PathSet.from_csr(ptr, steps, angles), run.n_steps,
                                     to_replace, start, goal, movable, md, settings.step_deg,
                                     _with(search_settings, step0_first=True) if partial
                                     else search_settings, np.random.default_rng([seed, 1]),
                                     memo=memo if settings.greedy else None)
            search_s += outcome.seconds
            to_replace = outcome.failed
            n_search_failed += len(to_replace)
            resolved = outcome.resolved_robots
            stuck = stuck.copy()
            stuck[resolved] = False
            failed_hardest = outcome.failed_hardest
            if to_replace and settings.continuation > 0:
                # what the search could not untangle goes on alone, after the plan's end
                cont = _continue(geom, outcome, to_replace, goal, settings, seed)
                continuation_s += cont.seconds
                n_continued_groups = len(cont.solved)        # of the final round
                n_continued_robots = len(cont.paths)
                stuck[list(cont.paths)] = False
                to_replace = [g for k, g in enumerate(to_replace) if k not in cont.solved]
                failed_hardest = [h for k, h in enumerate(failed_hardest) if k not in cont.solved]
        if not to_replace or not resolve or rounds >= settings.max_rounds:
            break
        rounds += 1
        # after a failed search, the robot it could least plan is the first to replace
        firsts = failed_hardest if outcome is not None else [-1] * len(to_replace)
        round_targets = targets
        for group, first in zip(to_replace, firsts):
            before = targets
            targets = replace_one(geom, rng, targets, group, md, first)
            n_replace_groups += int(np.any(targets != before))
            replaced |= targets[:, 0] != original[:, 0]
            replaced |= targets[:, 1] != original[:, 1]
        if outcome is not None and settings.local_replace:
            # first the groups alone, with their new targets, against everyone else's
            # paths; only if one of them still fails, a whole new round
            new_start, new_goal = (targets, fold) if settings.direction == "reverse" else (fold, targets)
            local = search_replaced(geom, outcome, to_replace, round_targets, targets, new_start,
                                    new_goal, movable, md, settings.step_deg, search_settings,
                                    np.random.default_rng([seed, 2]))
            search_s += local.seconds
            # taken when every group is resolved without lengthening the plan it joins
            # (else a whole new round may find a shorter one)
            if all(g.success for g in local.groups) and local.n_steps <= outcome.n_steps:
                outcome = local
                n_local_groups += len(to_replace)
                stuck = stuck.copy()
                stuck[local.resolved_robots] = False
                break

    start = targets if settings.direction == "reverse" else fold
    n_steps = run.n_steps
    n_search_groups = n_search_robots = n_search_replanned = 0
    if outcome is not None:
        n_steps = outcome.n_steps
        ptr, steps, angles = outcome.paths.to_csr(n_steps)
        ok = [g for g in outcome.groups if g.success]
        n_search_groups = len(ok)
        n_search_robots = int(sum(len(g.group) for g in ok))
        n_search_replanned = int(sum(len(g.members) for g in ok))
    else:
        ptr, steps, angles = build_paths(n, run.ev_robot, run.ev_step, run.ev_angles, start,
                                         run.final, run.n_steps)
    status = np.where(replaced, REPLACED, REACHED).astype(object)
    status[stuck] = DEADLOCKED
    status[~movable] = OFFLINE
    n_mov = int(movable.sum())
    metrics = {
        "n_robots": n, "n_movable": n_mov, "n_offline": n - n_mov,
        "n_replaced": int(replaced.sum()), "n_deadlocked": int(stuck.sum()),
        "efficiency": (n_mov - int(replaced.sum())) / max(1, n_mov),
        "convergence": float(convergence), "rounds": rounds,
        "tau_pg_s": tau_pg, "tau_sr_s": tau_sr, "pg_retries": pg_retries,
        "fold_time_s": n_steps * spec.step_seconds(settings.step_deg),
        "n_steps": n_steps, "max_displacement_mm": md,
    }
    # deadlock resolution: groups kept by the search (final plan) vs groups given a new target
    metrics.update({
        "search_s": search_s, "n_search_groups": n_search_groups,
        "n_search_robots": n_search_robots, "n_search_replanned": n_search_replanned,
        "n_search_failed_groups": n_search_failed, "n_replace_groups": n_replace_groups,
        "continuation_s": continuation_s, "n_continued_groups": n_continued_groups,
        "n_continued_robots": n_continued_robots, "n_rerun_groups": n_rerun_groups,
        "n_rerun_robots": n_rerun_robots, "rerun_attempts": rerun_attempts, "rerun_s": rerun_s,
        "n_local_groups": n_local_groups, "n_fold_repair_runs": n_repair_runs,
        "planning_s": time.perf_counter() - clock,
    })
    plan = Plan(
        robot_ids=geom.robot_ids.copy(), step_deg=settings.step_deg,
        step_s=spec.step_seconds(settings.step_deg), n_steps=n_steps,
        path_ptr=ptr, path_step=steps, path_angles=angles, status=status,
        targets=targets, original_targets=original, metrics=metrics,
    )
    return plan.reversed() if settings.direction == "reverse" else plan
