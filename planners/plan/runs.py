"""One planner run of the whole array: :func:`run_once`.

The stepwise kernel (:func:`rfp_twin.planners.stepwise.run_array`, greedy or Markov),
MDP2 (:func:`rfp_twin.planners.stepwise.mdp2_run.run_mdp2`, its tries in one run), or
for ``algorithm="roadmap"`` one prioritized roadmap pass
(:func:`rfp_twin.planners.roadmap.alpha_beta.array.roadmap_pass`), as a
:class:`rfp_twin.planners.stepwise.StepRun` in the planning frame. The driver makes the
first run of each round with it; deadlock strategies that run the array again are handed
it.

Units: angles in deg, time in planner steps.
"""
from __future__ import annotations

import numpy as np

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.planners.plan.settings import PlannerSettings
from rfp_twin.planners.stepwise import StepRun, array_max_displacement, run_array
from rfp_twin.planners.stepwise.mdp2_run import run_mdp2


def run_once(geom: ArrayGeometry, start: np.ndarray, dest: np.ndarray, movable: np.ndarray,
             settings: PlannerSettings, seed: int, beta_first: np.ndarray | None = None) -> StepRun:
    """One planner run from ``start`` to ``dest`` ((n, 2) deg) of the ``movable`` ((n,)
    bool) robots. ``beta_first`` (n,) bool: the robots that retract beta first [default:
    :func:`beta_first_robots` of the settings]."""
    md = array_max_displacement(geom, settings.step_deg)
    if settings.algorithm == "roadmap":
        return run_roadmap(geom, start, dest, movable, settings, md, seed)
    if settings.algorithm == "mdp2":
        return run_mdp2(geom, start, dest, movable, step_deg=settings.step_deg,
                        max_steps=settings.steps_limit, md=md, seed=seed, greed=settings.greed,
                        phobia=settings.phobia, tries=settings.tries)
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


def run_roadmap(geom: ArrayGeometry, start: np.ndarray, dest: np.ndarray, movable: np.ndarray,
                settings: PlannerSettings, md: float, seed: int) -> StepRun:
    """A roadmap pass (:func:`rfp_twin.planners.roadmap.alpha_beta.array.roadmap_pass`) as a StepRun;
    ``md`` mm, the step rule's margin."""
    from rfp_twin.planners.roadmap.alpha_beta import SearchResolveSettings
    from rfp_twin.planners.roadmap.alpha_beta.array import roadmap_pass

    res = roadmap_pass(geom, start, dest, movable, md, settings.step_deg,
                       settings.search or SearchResolveSettings(), np.random.default_rng(seed))
    ev_robot, ev_step, ev_angles = res.events()
    return StepRun(res.final, res.n_steps, ev_robot, ev_step, ev_angles, res.seconds)
