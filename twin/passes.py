"""Passes: the same field observed several times, each pass planned from the last one's poses.

:func:`observe_passes` runs the plannable loop (:func:`rfp_twin.twin.plannable.plan_catalogue`)
once per pass on what is left of the catalogue: science targets that had the exposures
they need (``Catalogue.exposures``, 1 unless the catalogue says more) are removed, the
others stay with their priorities; calibration targets (sky, standards) stay, since every
exposure needs its own. A target is complete once it had its exposures. Each pass's
assignment is one the planner keeps whole, checked from the fold, as in a single pointing.

The reconfiguration between two passes starts where the robots stand (the previous
pass's poses A) and ends at the next pass's targets B:

- ``direct``: the stepwise planner between A and B (reverse planning: a run from B to A,
  played backwards; :func:`rfp_twin.planners.plan.reconfigure.plan_reconfiguration` with
  ``start``). Tried first with the planner's first run alone (a fraction of a second);
  when that run leaves few robots stuck (at most :data:`DIRECT_MIN_STUCK` or the share
  ``direct_stuck``, ``rfp-twin plan --direct-stuck``) the whole pipeline runs (deadlock
  search, post-processing, 2D check), and its motion is used when it keeps every target,
  passes the check and is no slower than the motion via the fold.
- ``via fold``: otherwise, the fold of A (the previous pass's firmware-ready trajectory
  from the fold, played backwards) followed by the unfold of B (this pass's), every robot
  at rest in the folded state between them (as SDSS-V reconfigures between designs); the
  joined trajectory is verified again by the 2D checker, and its stepwise plan is the
  two plans on one step clock (:func:`rfp_twin.planners.plan.join.join_plans`). It always
  exists, since both halves keep every target; its time is the fold of A plus the
  unfold of B (``via_fold_s``, reported for every pass, for comparison with a direct
  motion).

Between two dense configurations the direct first run leaves many robots stuck, where
the planner folds the same configurations easily (the fold is clear of everything):
with the greedy planner on the calibrated APO instrument, from one random configuration
to another, 268 of 500 robots stuck on seed 0; between passes 1-2 and 2-3 of an APO
field at 300 targets/deg^2, 195 and 231 (those passes go via the fold). A DESI-like array
(3 + 3 mm arms at 10.4 mm) leaves 1-6 % stuck, which the search resolves.

Units: mm, deg, s.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np

from rfp_twin.models.catalogue import SCIENCE, Catalogue
from rfp_twin.models.errors import AssignmentError, PlanningError, RfpError
from rfp_twin.models.trajectory import join_trajectories
from rfp_twin.planners.assignment import AssignSettings, build_candidates
from rfp_twin.planners.assignment.completeness import (completeness, observed_rows,
                                                       reachable_rows)
from rfp_twin.planners.plan import OFFLINE, REACHED
from rfp_twin.planners.plan.join import join_plans
from rfp_twin.twin.outcome import Outcome
from rfp_twin.twin.pass_options import DIRECT_STUCK_SHARE, check_passes
from rfp_twin.twin.plannable import MAX_ROUNDS, CatalogueRun, plan_catalogue
from rfp_twin.validation.checker2d import check_trajectory

#: The direct motion goes through the whole pipeline (deadlock resolution) when its first
#: run leaves at most this many robots stuck, or the share ``direct_stuck`` of them
#: (:data:`rfp_twin.twin.pass_options.DIRECT_STUCK_SHARE` by default), whichever is more.
DIRECT_MIN_STUCK = 2
#: How the motion of a pass was made.
FROM_FOLD, DIRECT, VIA_FOLD = "from fold", "direct", "via fold"


@dataclass
class Pass:
    """One pass of a field.

    index : 1, 2, ...; run : the plannable loop of this pass (assignment, rounds, and
    its plan from the fold); run_catalogue : what was left of the catalogue for it (the
    rows ``run.assignment.target`` indexes); motion : the reconfiguration delivered for this pass (from
    the fold for the first, from the previous pass's poses after); mode : FROM_FOLD,
    DIRECT or VIA_FOLD; via_fold_s : fold of the previous poses + unfold of these
    (firmware-ready, each timed alone), s, None for the first pass; available : science
    targets left before the pass; observed : (k,) int64 ids of the science targets it
    observed; seconds : wall time of the pass.
    """

    index: int
    run: CatalogueRun
    run_catalogue: Catalogue
    motion: Outcome
    mode: str
    via_fold_s: float | None
    available: int
    observed: np.ndarray
    seconds: float
    direct_tried: dict = field(default_factory=dict)

    def row(self, catalogue: Catalogue, count_before: np.ndarray) -> dict:
        """The pass's figures: assigned, kept, rounds, completeness of the pass (science
        targets it completed) and cumulative (science, by priority), the motion's
        firmware-ready time. ``count_before`` (t,) int: exposures each catalogue row had
        before the pass."""
        a = self.run.assignment
        after = count_before + observed_rows(catalogue, self.observed)
        done_before = count_before >= catalogue.exposures
        done_after = after >= catalogue.exposures
        cum = completeness(catalogue, done_after)
        traj = self.motion.trajectory
        return {"pass": self.index, "start": "fold" if self.index == 1 else
                f"pass {self.index - 1} poses", "motion": self.mode,
                "available_science": self.available, "assigned": a.n_assigned,
                "counts": a.counts(), "kept": self.run.summary(self.run_catalogue)["kept"],
                "observed_science": int(self.observed.size), "lost": self.run.n_lost,
                "rounds": len(self.run.rounds),
                "lost_per_round": [r["lost"] for r in self.run.rounds],
                "completed_science": int(np.count_nonzero(done_after & ~done_before
                                                          & (catalogue.kind == SCIENCE))),
                "completeness": completeness(catalogue, done_after & ~done_before)["science"],
                "cumulative": cum["science"],
                "cumulative_by_priority": {p: v["completeness"]
                                           for p, v in cum["by_priority"].items()},
                "reconfiguration_s": traj.duration,
                "reconfiguration_with_delay_s": traj.duration + self.motion.reconfiguration.spec.path_delay_s,
                "via_fold_s": self.via_fold_s, "direct_first_run": self.direct_tried,
                "check2d_ok": bool(self.motion.check.ok),
                "objective": a.objective, "bound": a.bound, "solver": a.solver,
                "status": a.status, "wall_s": self.seconds}


def science_observed(catalogue: Catalogue, run: CatalogueRun) -> np.ndarray:
    """(k,) int64 ids of the science targets ``run``'s plan kept (``catalogue``: the one
    ``run`` assigned)."""
    a, status = run.assignment, run.outcome.plan.status
    kept = (a.target >= 0) & (status == REACHED)
    rows = a.target[kept]
    return catalogue.ids[rows[catalogue.kind[rows] == SCIENCE]].astype(np.int64)


def reconfigure_between(rc, previous: Outcome, current: Outcome, *, seed: int = 0,
                        direct: bool = True, direct_stuck: float = DIRECT_STUCK_SHARE
                        ) -> tuple[Outcome, str, dict]:
    """The motion from where ``previous`` (a plan fold -> A) leaves the robots to
    ``current``'s targets B (``current``: a plan fold -> B that keeps them all):
    ``(Outcome, mode, what the direct first run did)``, module docstring."""
    from rfp_twin.twin.pipeline import Reconfiguration

    A, B = previous.plan.end(), current.plan.end()
    tried: dict = {}
    direct_out = None
    if direct and rc.options.stepwise:
        quick = Reconfiguration(rc.geom, replace(rc.options, resolve="none"), offline=rc.offline)
        t0 = time.perf_counter()
        try:
            first, _ = quick.plan(B, np.random.default_rng(seed), start=A)
            done = np.isin(first.status, (REACHED, OFFLINE))
            tried = {"stuck": int((~done).sum()), "seconds": time.perf_counter() - t0}
        except PlanningError as e:          # most of the array stuck
            tried = {"stuck": None, "error": str(e), "seconds": time.perf_counter() - t0}
            done = None
        if done is not None and (~done).sum() <= max(DIRECT_MIN_STUCK,
                                                      direct_stuck * done.size):
            out = rc.run(seed=seed, targets=B, start=A)
            tried["kept_all"] = bool(np.isin(out.plan.status, (REACHED, OFFLINE)).all())
            if tried["kept_all"] and out.check.ok:
                direct_out = out
    t0 = time.perf_counter()
    plan = join_plans(previous.plan.reversed(), current.plan)
    traj = join_trajectories(previous.trajectory.reversed(), current.trajectory)
    buffer = (current.post.verify_buffer_mm if current.post is not None
              else rc.spec.buffer_mm)
    check = check_trajectory(traj, rc.spec, rc.layout, buffer)
    seconds = {"targets": 0.0, "plan": 0.0, "deliver": time.perf_counter() - t0}
    seconds["total"] = seconds["deliver"]
    via = Outcome(rc, seed, B, plan, None, traj, None, check, seconds)
    if direct_out is not None and (direct_out.trajectory.duration <= traj.duration
                                   or not check.ok):
        return direct_out, DIRECT, tried
    return via, VIA_FOLD, tried


def observe_passes(rc, catalogue: Catalogue, settings: AssignSettings, passes: int, *,
                   seed: int = 0, max_rounds: int = MAX_ROUNDS, direct: bool = True,
                   direct_stuck: float = DIRECT_STUCK_SHARE, on_pass=None,
                   **run_kwargs) -> list[Pass]:
    """Observe ``catalogue`` in ``passes`` passes (module docstring); ``on_pass(k, text)``
    is called as each pass starts and ends. Stops early when no target of what is left is
    within reach of a robot (nothing more can be observed). Pass k plans with seed
    ``seed + k - 1``."""
    passes = check_passes(passes)
    if not rc.options.stepwise:
        raise RfpError(f"--passes with --algorithm {rc.options.algorithm}; allowed: a stepwise "
                       "planner (greedy, markov, mdp2, roadmap)")
    count = np.zeros(catalogue.n_targets, dtype=np.int64)     # exposures taken so far
    keep = catalogue.kind != SCIENCE
    out: list[Pass] = []
    for k in range(1, passes + 1):
        t0 = time.perf_counter()
        left = catalogue.subset(keep | ((catalogue.kind == SCIENCE)
                                        & (count < catalogue.exposures)))
        available = int(np.count_nonzero(left.kind == SCIENCE))
        if on_pass is not None:
            on_pass(k, f"pass {k}: assigning {available} science targets left")
        try:
            run = plan_catalogue(rc, left, settings, seed=seed + k - 1, max_rounds=max_rounds,
                                 **run_kwargs)
        except AssignmentError:
            if k == 1 or available == 0:
                raise
            break                   # nothing left within reach: later passes observe nothing
        ids = science_observed(left, run)
        if k == 1:
            motion, mode, tried, via = run.outcome, FROM_FOLD, {}, None
        else:
            if on_pass is not None:
                on_pass(k, f"pass {k}: reconfiguring from pass {k - 1}")
            prev = out[-1].run.outcome
            motion, mode, tried = reconfigure_between(rc, prev, run.outcome, seed=seed + k - 1,
                                                      direct=direct, direct_stuck=direct_stuck)
            via = prev.trajectory.duration + run.outcome.trajectory.duration
        count += observed_rows(catalogue, ids)
        out.append(Pass(k, run, left, motion, mode, via, available, ids, time.perf_counter() - t0,
                        tried))
    return out


def within_reach(rc, catalogue: Catalogue, settings: AssignSettings) -> np.ndarray:
    """(t,) bool: the catalogue's targets that some robot reaches with a fiber the target
    accepts, clear of obstacles (the assigner's candidates, at the planner's margin)."""
    cands = build_candidates(rc.geom, catalogue,
                             margin_mm=max(settings.margin_mm, rc.target_margin_mm()),
                             arms=settings.arms,
                             fixed={int(r): (float(a), float(b))
                                    for r, (a, b) in rc.offline.items()})
    return reachable_rows(catalogue, cands)


def passes_summary(catalogue: Catalogue, done: list[Pass],
                   reachable: np.ndarray | None = None) -> dict:
    """Every pass's row (:meth:`Pass.row`) and the cumulative completeness by priority;
    with ``reachable`` ((t,) bool, :func:`within_reach`) each row's ``cumulative_within_reach``
    and the final completeness of the targets within reach too."""
    count = np.zeros(catalogue.n_targets, dtype=np.int64)
    rows = []
    for p in done:
        rows.append(p.row(catalogue, count))
        count = count + observed_rows(catalogue, p.observed)
        if reachable is not None:
            rows[-1]["cumulative_within_reach"] = completeness(
                catalogue, count >= catalogue.exposures, reachable)["within_reach"]
    seen = count >= catalogue.exposures
    return {"catalogue": catalogue.source, "n_targets": catalogue.n_targets,
            "counts": catalogue.counts(), "n_passes": len(done), "passes": rows,
            "completeness": completeness(catalogue, seen, reachable)}
