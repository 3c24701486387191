"""Assignment and planning as one loop: every assigned target is one the plan keeps.

:func:`plan_catalogue` assigns a catalogue (:func:`rfp_twin.planners.assignment.assign`,
final poses clear by the buffer plus the stepwise planners' margin), plans the fold ->
targets reconfiguration through the one pipeline (:meth:`Reconfiguration.run`) and looks
at what the planner did with each assigned target: a robot whose target the plan did
not keep (replaced or deadlocked) gives a forbidden (robot, target) pair, and the
assignment is made again without it, until the plan keeps every assigned target or
``max_rounds`` rounds have run. A round first tries the planner's first run alone (cheap):
targets it leaves deadlocked are forbidden at once, and only an assignment whose first
run keeps everything goes through the whole pipeline (deadlock search, post-processing,
2D check). Each round is reported: what was assigned, what the plan lost, how long it
took. The last round's :class:`Outcome` is returned with its rounds.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from rfp_twin.models.catalogue import Catalogue
from rfp_twin.planners.assignment import AssignSettings, Assignment, assign
from rfp_twin.twin.outcome import Outcome

#: Rounds of assign -> plan at most.
MAX_ROUNDS = 5
REACHED = "reached"


@dataclass
class CatalogueRun:
    """outcome : the last round's pipeline outcome; assignment : its assignment;
    rounds : one dict per round (assigned, objective, bound, lost, forbidden, seconds)."""

    outcome: Outcome
    assignment: Assignment
    rounds: list[dict]

    @property
    def n_lost(self) -> int:
        """Assigned targets the last plan did not keep."""
        return self.rounds[-1]["lost"]

    def summary(self, catalogue: Catalogue) -> dict:
        """The loop's figures for summary.json: rounds, yield, counts, bound."""
        a = self.assignment
        science = catalogue.kind == 0
        kept = (a.target >= 0) & (self.outcome.plan.status == REACHED)
        taken = np.zeros(catalogue.n_targets, dtype=bool)
        taken[a.target[kept]] = True
        return {"catalogue": catalogue.source, "n_targets": catalogue.n_targets,
                "rounds": self.rounds, "n_rounds": len(self.rounds),
                "assigned": a.n_assigned, "kept": int(kept.sum()), "lost": self.n_lost,
                "counts": a.counts(), "objective": a.objective, "bound": a.bound,
                "gap": a.gap, "status": a.status, "solver": a.solver,
                "science_completeness": (float(taken[science].sum() / science.sum())
                                         if science.any() else None)}


def lost_pairs(rc, assignment: Assignment, status: np.ndarray) -> set[tuple[int, int]]:
    """(robot id, target id) of each assigned target the plan did not keep."""
    bad = np.flatnonzero((assignment.target >= 0) & (status != REACHED))
    return {(int(rc.geom.robot_ids[i]), int(assignment.target_ids[i])) for i in bad}


def plan_catalogue(rc, catalogue: Catalogue, settings: AssignSettings, *, seed: int = 0,
                   max_rounds: int = MAX_ROUNDS, on_round=None, start: np.ndarray | None = None,
                   **run_kwargs) -> CatalogueRun:
    """Assign, plan, forbid what the plan lost, again (module docstring).

    rc : :class:`rfp_twin.twin.pipeline.Reconfiguration`; the assignment keeps the
    planner's margin (``rc.target_margin_mm()``) beyond the buffer, and offline robots
    keep their poses (no target; the others clear them). With a stepwise
    planner, every round but the last first plans with the planner's first run only (no
    deadlock resolution, no post-processing: a fraction of a second): robots it leaves
    deadlocked lose their targets to the next round at once; a round whose first run
    keeps every target is then run through the whole pipeline (the same seed gives the
    same first run). ``start`` ((n, 2) deg): where the robots stand (the last pass's
    poses), planned from directly [default: folded]. ``on_round(k, info)`` is called after
    each round; ``run_kwargs`` go to ``rc.run``."""
    from rfp_twin.twin.pipeline import Reconfiguration

    forbidden = set(settings.forbidden)
    rounds: list[dict] = []
    settings = replace(settings, margin_mm=max(settings.margin_mm, rc.target_margin_mm()),
                       fixed=tuple((int(r), float(a), float(b))
                                   for r, (a, b) in sorted(rc.offline.items())))
    quick = (Reconfiguration(rc.geom, replace(rc.options, resolve="none"), offline=rc.offline)
             if rc.options.stepwise and rc.options.resolve != "none" else None)
    outcome = assignment = None
    for k in range(max(1, max_rounds)):
        t0 = time.perf_counter()
        assignment = assign(rc.geom, catalogue, replace(settings, forbidden=frozenset(forbidden)))
        t1 = time.perf_counter()
        info = {"round": k + 1, "assigned": assignment.n_assigned,
                "objective": assignment.objective, "bound": assignment.bound,
                "status": assignment.status, "forbidden_before": len(forbidden),
                "assign_s": t1 - t0}
        lost: set = set()
        if quick is not None and k < max_rounds - 1:
            first, _ = quick.plan(assignment.angles, np.random.default_rng(seed), start=start)
            lost = lost_pairs(rc, assignment, first.status)
            info["first_run_lost"] = len(lost)
        if not lost:
            outcome = rc.run(seed=seed, targets=assignment.angles, start=start, **run_kwargs)
            lost = lost_pairs(rc, assignment, outcome.plan.status)
            info["fold_s"] = float(outcome.trajectory.duration)
        info.update({"lost": len(lost), "plan_s": time.perf_counter() - t1})
        rounds.append(info)
        if on_round is not None:
            on_round(k + 1, info)
        if not lost:
            break
        forbidden |= lost
    return CatalogueRun(outcome, assignment, rounds)
