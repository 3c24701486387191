"""Target replacement when deadlock resolution fails (Sayres 2021 Sect. 5.2), and the
replaced group searched again in place.

:func:`replace_one` gives one robot of a deadlocked group a new random target;
:func:`search_replaced` then plans that group alone again with the state-time search
(:mod:`rfp_twin.planners.resolve_search`) against everyone else's paths of the plan made
so far, before the solver (:mod:`rfp_twin.planners.solver`) falls back to a whole new
round.

Units: deg; md in mm; time in planner steps.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.errors import TargetError
from rfp_twin.planners.targets import random_targets


def replace_one(geom: ArrayGeometry, rng: np.random.Generator, targets: np.ndarray,
                group: np.ndarray, margin_mm: float, first: int = -1) -> np.ndarray:
    """New random target for one robot of a deadlocked group (Sayres 2021 Sect. 5.2).

    Members are tried in random order (``first``, if given, before them: the robot the
    search could not plan); one whose neighbourhood leaves no clear spot is skipped.
    Returns the updated (n, 2) targets (unchanged if no member fits).
    """
    order = rng.permutation(group)
    if first >= 0:
        order = np.concatenate([[first], order[order != first]])
    for i in order:
        keep = np.ones(geom.n_robots, dtype=bool)
        keep[i] = False
        try:
            return random_targets(geom, rng, fixed=keep, initial=targets, margin_mm=margin_mm,
                                  robots=np.array([i]), attempts=1)
        except TargetError:
            continue
    return targets


def search_replaced(geom: ArrayGeometry, outcome, groups: list[np.ndarray],
                    old_targets: np.ndarray, targets: np.ndarray, start: np.ndarray,
                    goal: np.ndarray, movable: np.ndarray, md: float, step_deg: float,
                    search_settings, rng: np.random.Generator):
    """The search again on the groups it could not resolve, now that one robot of each has
    a new target, against the paths of ``outcome`` (everyone else keeps the plan made
    so far). A robot with a new target has no lead-in: its path is reset to standing at
    its start (``start``, ``goal`` : (n, 2) deg, the planning frame's, new targets in).
    Returns the search's SearchOutcome; ``groups`` without a new robot are not searched
    again and count as failed."""
    from rfp_twin.planners.resolve_search import GroupResult, PathSet, SearchOutcome, resolve_groups

    moved = np.any(targets != old_targets, axis=1)
    if not all(moved[g].any() for g in groups):
        return SearchOutcome(outcome.paths, outcome.n_steps,
                             [GroupResult(np.asarray(g), np.asarray(g), False, 0, 0.0)
                              for g in groups])
    paths = PathSet(list(outcome.paths.steps), list(outcome.paths.angles))
    for i in np.flatnonzero(moved):
        paths.steps[i] = np.zeros(1)
        paths.angles[i] = start[i][None, :].astype(np.float64)
    return resolve_groups(geom, paths, outcome.n_steps, groups, start, goal, movable, md,
                          step_deg, replace(search_settings, step0_first=True), rng)
