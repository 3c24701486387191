"""One yield trial: a mock catalogue planned through the plannable loop -> the yield columns.

A grid point with a ``catalogue`` (:mod:`rfp_twin.twin.studies.yield_options`) draws a mock
science catalogue with the trial seed, exactly as ``rfp-twin plan --catalogue TEXT --seed
SEED`` does (the row's ``catalogue_text``; SDSS-V layouts take their telescope's field and
plate scale, other arrays the disc that covers every patrol area), then runs the
plannable loop (:func:`rfp_twin.twin.plannable.plan_catalogue`): assign (collision-aware,
HiGHS), plan fold -> targets keeping every assigned target, forbid what the plan lost,
again, at most ``assign_rounds`` rounds. The last round's plan went through the whole
pipeline, so its independent 2D check is recorded (``collisions``, ``min_clearance_mm``).

What the row records (science targets only; calibration targets are not drawn):

- ``n_available``: targets within reach of at least one robot, with a fiber the target
  accepts and clear of obstacles (the candidates of the assigner); targets of the field
  that no robot reaches are not counted against the design;
- ``targets_per_pointing``: targets assigned and kept by the plan;
- ``completeness = targets_per_pointing / n_available``, overall and per priority level
  (``completeness_by_priority``, ``completeness_top`` for the highest level);
- ``reconfig_s``: the fold -> targets reconfiguration the robots execute, firmware-ready
  (the spec's path delay + the post-processed trajectory) when the study post-processes
  (``firmware = true``), else the stepwise fold time;
- ``targets_per_hour = 3600 * targets_per_pointing / (reconfig_s + exposure_s)``: one
  pointing per reconfiguration plus exposure (no slew, acquisition or read-out time);
- why the targets within reach that nobody took were missed
  (:func:`rfp_twin.planners.assignment.miss_reasons`): ``missed_busy`` (every robot that
  reaches it holds another target), ``missed_parked`` (blocked only by parked neighbours'
  parking poses), ``missed_neighbour`` (by a neighbour on another target), ``missed_other``;
- the loop: ``loop_rounds``, ``loop_lost`` (assigned targets the plan lost over all
  rounds, each then forbidden), ``n_lost`` (left in the last round), assignment time,
  status and gap.

Units: s; completeness in [0, 1].
"""
from __future__ import annotations

import dataclasses
import json
import time

import numpy as np

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.catalogue import SCIENCE
from rfp_twin.planners.assignment import AssignSettings, build_candidates, miss_reasons
from rfp_twin.planners.plan import REACHED
from rfp_twin.twin.catalogue_source import load_catalogue, telescope_for
from rfp_twin.twin.pipeline import PlanOptions, Reconfiguration
from rfp_twin.twin.plannable import plan_catalogue
from rfp_twin.twin.studies.runner import plan_columns, targets_hash
from rfp_twin.twin.studies.yield_options import YieldOptions, mock_text

__all__ = ["yield_columns", "completeness_by_level", "targets_per_hour"]


def targets_per_hour(targets_per_pointing: float, reconfig_s: float, exposure_s: float) -> float:
    """``3600 * targets_per_pointing / (reconfig_s + exposure_s)`` (s in, targets per hour
    out; NaN when the denominator is not positive)."""
    t = float(reconfig_s) + float(exposure_s)
    return 3600.0 * float(targets_per_pointing) / t if t > 0 else float("nan")


def completeness_by_level(priority: np.ndarray, available: np.ndarray,
                          taken: np.ndarray) -> dict[str, float]:
    """{priority level (as text, ``%g``): taken / available at that level}.

    priority : (t,) float; available, taken : (t,) bool (taken implies available)."""
    out = {}
    for level in np.unique(priority[available]):
        at = available & (priority == level)
        out[f"{level:g}"] = float(np.count_nonzero(taken & at) / np.count_nonzero(at))
    return out


def yield_columns(geom: ArrayGeometry, options: PlanOptions, point: dict, seed: int,
                  firmware: bool, exposure_s: float) -> dict:
    """The row columns of a yield trial (module docstring) on ``geom`` with the pipeline
    ``options``; ``point`` holds the yield keys (``StudyPoint.to_dict()``)."""
    yo = YieldOptions(**{k: point[k] for k in ("catalogue", "density", "density_unit",
                                                "priority_levels", "assign_rounds")},
                      exposure_s=float(exposure_s))
    rc = Reconfiguration(geom, dataclasses.replace(options, raw=not firmware))
    text = mock_text(yo.catalogue, yo.density, yo.density_unit, yo.priority_levels)
    telescope = telescope_for("auto", point["layout"], geom.spec.name)
    cat = load_catalogue(text, geom, telescope=telescope, field_centre=None, seed=seed)
    settings = AssignSettings(workers=1)      # one thread per Dask worker
    t0 = time.perf_counter()
    loop = plan_catalogue(rc, cat, settings, seed=seed, max_rounds=yo.assign_rounds)
    wall = time.perf_counter() - t0
    outcome, a = loop.outcome, loop.assignment

    science = cat.kind == SCIENCE
    cands = build_candidates(geom, cat, margin_mm=rc.target_margin_mm(), arms=settings.arms,
                             parking=settings.parking)
    reachable = np.zeros(cat.n_targets, dtype=bool)
    reachable[cands.target[cands.target >= 0]] = True
    available = science & reachable
    kept = (a.target >= 0) & (np.asarray(outcome.plan.status) == REACHED)
    taken = np.zeros(cat.n_targets, dtype=bool)
    taken[a.target[kept]] = True
    taken &= available
    assigned = np.zeros(cat.n_targets, dtype=bool)
    assigned[a.target[a.target >= 0]] = True
    n_avail = int(available.sum())
    n_taken = int(taken.sum())
    levels = completeness_by_level(cat.priority, available, taken)
    top = levels[max(levels, key=float)] if levels else None
    if firmware and outcome.post is not None:
        reconfig = float(geom.spec.path_delay_s + outcome.trajectory.duration)
    else:
        reconfig = float(outcome.plan.metrics["fold_time_s"])
    missed = miss_reasons(geom, cands, a, rc.target_margin_mm(), available)
    check = outcome.check
    cols = plan_columns(outcome.plan)
    cols.update(missed_busy=missed["robot_busy"], missed_parked=missed["parked_neighbour"],
                missed_neighbour=missed["assigned_neighbour"], missed_other=missed["other"])
    cols.update(
        catalogue_text=text, n_targets=int(science.sum()), n_available=n_avail,
        targets_per_robot=n_avail / max(1, geom.n_robots),
        n_assigned=int((assigned & science).sum()), targets_per_pointing=n_taken,
        completeness=n_taken / n_avail if n_avail else None, completeness_top=top,
        completeness_by_priority=json.dumps(levels, sort_keys=True), reconfig_s=reconfig,
        targets_per_hour=targets_per_hour(n_taken, reconfig, yo.exposure_s),
        loop_rounds=len(loop.rounds), loop_lost=int(sum(r["lost"] for r in loop.rounds)),
        n_lost=int(loop.n_lost), assign_s=float(sum(r["assign_s"] for r in loop.rounds)),
        assign_status=a.status, assign_gap=float(a.gap), plan_s=wall,
        targets_hash=targets_hash(a.angles), checked=True,
        collisions=len(check.collisions),
        min_clearance_mm=(float(check.min_clearance_mm)
                          if np.isfinite(check.min_clearance_mm) else None))
    if firmware:
        cols["fold_fw_s"] = reconfig
    if loop.n_lost:
        cols["status"] = "deadlocked"
    return cols
