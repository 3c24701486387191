"""One study trial -> one row: the reconfiguration pipeline on a grid point, its metrics.

A trial is :class:`rfp_twin.twin.pipeline.Reconfiguration` with the point's options and
``raw=True``: seeded random targets, the plan (stepwise planner with deadlock resolution,
or a potential field) and, when the study checks, the independent 2D check of the
stepwise paths at the planning buffer (:attr:`rfp_twin.twin.outcome.Outcome.check`). The random
sequence is the pipeline's, i.e. ``rfp-twin plan --seed SEED``: targets drawn from
``numpy.random.default_rng(seed)``, then the planner driven by the same generator. A
design whose folded state already collides is recorded as an error row
(:func:`rfp_twin.twin.pipeline.folded_clearance_error`), as is any other :class:`RfpError` (e.g.
no clear random targets in a very dense array): a study maps where designs fail.

Design studies (``study.firmware``) post-process every plan into the firmware-ready
trajectory (``raw=False``): ``fold_fw_s`` is its duration plus the spec's path delay, and
the check is the pipeline's check of what is delivered (at buffer - budget); a failed
post-processing keeps the planning columns and says why in ``firmware_error``. Every row
records ``kept`` (robots at their own target / movable robots: replaced and still
deadlocked robots are lost), ``plan_s`` (wall time of planning, searches included) and
``targets_hash`` (equal hashes: the same targets, e.g. search and replace of one draw).

Yield points (a ``catalogue`` grid key) plan a mock catalogue through the plannable loop
instead (:func:`rfp_twin.twin.studies.yield_trial.yield_columns`): the same plan columns,
plus completeness, targets per pointing and per hour, the loop's rounds.

The functions here run on Dask workers (:func:`run_batch`) or in this process
(:func:`run_trial`). Row columns: :data:`rfp_twin.twin.studies.store.SCHEMA`; units mm, deg, s.
"""
from __future__ import annotations

import dataclasses
import functools
import hashlib
import math
import os
import socket
import time
from datetime import datetime, timezone
from typing import Any

import numpy as np

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.errors import RfpError
from rfp_twin.models.robot import RobotSpec
from rfp_twin.planners.plan import OFFLINE, REACHED
from rfp_twin.twin.pipeline import (FIELD_ALGORITHMS, PlanOptions, Reconfiguration,
                                    folded_clearance_error)
from rfp_twin.twin.studies.parse import parse_study
from rfp_twin.twin.studies.spec import PARAM_COLUMNS, YIELD_COLUMNS, StudyPoint, point_layout

__all__ = ["run_trial", "run_batch", "plan_columns", "targets_hash"]

#: A batch item: (point dict, spec, trial index, seed, key, ids: point / design / geometry).
BatchItem = tuple[dict, RobotSpec, int, int, str, dict]


@functools.lru_cache(maxsize=16)
def _geometry(spec: RobotSpec, kind: str, n_robots: int, n_rafts: int | None) -> ArrayGeometry:
    layout = point_layout(kind, n_robots, spec.pitch_mm, n_rafts)
    return ArrayGeometry(spec, layout, spec.buffer_mm)


def _plan_options(point: dict) -> PlanOptions:
    """The pipeline's options for a grid point (``StudyPoint.to_dict()``); raw stepwise
    paths (no post-processing), field gain and lambda3 at their defaults."""
    return PlanOptions(algorithm=point["algorithm"], step_deg=point["step_deg"],
                       greed=point["greed"], phobia=point["phobia"],
                       direction=point["direction"], resolve=point["resolution"],
                       max_steps=point["max_steps"], max_rounds=point["max_rounds"], raw=True)


#: The warm-up study: both stepwise planners on 7 robots.
_WARM_UP = "[grid]\nn_robots = 7\nbuffer_mm = 2.0\nstep_deg = 1.0\nmax_rounds = 5\n" \
           "algorithm = ['greedy', 'markov']\n"
_WARM = False


def _warm_up() -> None:
    """Load (or compile) every numba kernel once per process, so that the first trial's
    tau_pg measures planning and not the JIT cache."""
    global _WARM
    if _WARM:
        return
    for p in parse_study(_WARM_UP, source="warm-up").points:
        _trial_row(p.to_dict(), p.spec, 0, 0, True)
    _WARM = True


def run_trial(point: StudyPoint, index: int, base_seed: int, check: bool = True,
              study: str = "", firmware: bool = False, exposure_s: float = 900.0) -> dict:
    """Run one trial in this process; returns its row (a dict with the :data:`SCHEMA` columns)."""
    row = _trial_row(point.to_dict(), point.spec, point.trial_seed(base_seed, index), index, check,
                     firmware, exposure_s)
    row.update(key=point.trial_key(base_seed, index), study=study, base_seed=int(base_seed),
               **point.ids())
    return row


def run_batch(batch: list[BatchItem], check: bool, study: str, base_seed: int,
              firmware: bool = False, exposure_s: float = 900.0) -> list[dict]:
    """Dask task: a few trials, in order; their rows (``exposure_s``: yield points)."""
    _warm_up()
    rows = []
    for point, spec, index, seed, key, ids in batch:
        row = _trial_row(point, spec, seed, index, check, firmware, exposure_s)
        row.update(key=key, study=study, base_seed=int(base_seed), **ids)
        rows.append(row)
    return rows


def _trial_row(point: dict, spec: RobotSpec, seed: int, index: int, check: bool,
               firmware: bool = False, exposure_s: float = 900.0) -> dict:
    t0, c0 = time.perf_counter(), time.thread_time()
    row: dict[str, Any] = {k: point[k] for k in PARAM_COLUMNS}
    la, lb = point["alpha_length_mm"], point["beta_length_mm"]
    row.update(trial=int(index), seed=int(seed), reach_mm=la + lb,
               pitch_over_reach=point["pitch_mm"] / (la + lb), checked=bool(check),
               worker=f"{socket.gethostname()}:{os.getpid()}", error=None,
               family=point.get("family"), n_rafts=point.get("n_rafts"), arm_ratio=la / lb)
    try:
        geom = _geometry(spec, point["layout"], int(point["n_robots"]), point.get("n_rafts"))
        row["n_fiducials"] = geom.layout.n_fiducials
        if point.get("catalogue") is not None:
            from rfp_twin.twin.studies.yield_trial import yield_columns

            row.update({k: point[k] for k in YIELD_COLUMNS}, exposure_s=float(exposure_s))
            row.update(yield_columns(geom, _plan_options(point), point, int(seed), firmware,
                                     exposure_s))
        else:
            row.update(_plan_and_check(geom, _plan_options(point), int(seed), check, firmware))
    except RfpError as exc:  # e.g. no clear random targets in a very dense array
        row.update(status="error", error=f"{type(exc).__name__}: {exc}")
    row["wall_s"] = time.perf_counter() - t0
    row["cpu_s"] = time.thread_time() - c0
    row["finished_utc"] = datetime.now(timezone.utc)
    return row


def targets_hash(targets: np.ndarray) -> str:
    """16 hex digits of the SHA-256 of a target array ``(n_robots, 2)`` deg (float64)."""
    data = np.ascontiguousarray(targets, dtype=np.float64).tobytes()
    return hashlib.sha256(data).hexdigest()[:16]


def _plan_and_check(geom: ArrayGeometry, options: PlanOptions, seed: int, check: bool,
                    firmware: bool = False) -> dict:
    """The metric columns of one pipeline run: the steps of ``Reconfiguration.run`` (its
    random sequence), delivering (raw paths, or firmware-ready ones when ``firmware``)
    only when the study checks or wants the firmware fold time."""
    if options.algorithm not in FIELD_ALGORITHMS:
        # fields start where their barrier allows; they report a colliding fold themselves
        error = folded_clearance_error(geom)
        if error is not None:
            raise error
    rc = Reconfiguration(geom, dataclasses.replace(options, raw=not firmware))
    rng = np.random.default_rng(seed)
    targets = rc.random_targets(rng)
    t0 = time.perf_counter()
    plan, _ = rc.plan(targets, rng)
    cols: dict[str, Any] = {"plan_s": time.perf_counter() - t0,
                            "targets_hash": targets_hash(targets)}
    if check or firmware:
        t0 = time.perf_counter()
        try:
            traj, _, rep = rc.deliver(plan)
        except RfpError as exc:
            if not firmware:
                raise
            cols["firmware_error"] = f"{type(exc).__name__}: {exc}"
        else:
            if check:
                cols.update(collisions=len(rep.collisions), check_s=time.perf_counter() - t0,
                            min_clearance_mm=float(rep.min_clearance_mm)
                            if math.isfinite(rep.min_clearance_mm) else None)
            if firmware:
                cols["fold_fw_s"] = float(geom.spec.path_delay_s + traj.duration)
    cols.update(plan_columns(plan))
    return cols


def plan_columns(plan) -> dict:
    """The row columns of a Plan's metrics: efficiency, convergence, fold and planner
    times (s), replaced / deadlocked robots, rounds, steps, status, ``kept`` (robots at
    their own target / movable robots)."""
    m = plan.metrics
    status = np.asarray(plan.status)
    movable = int(np.sum(status != OFFLINE))
    return dict(efficiency=float(m["efficiency"]), convergence=float(m["convergence"]),
                fold_time_s=float(m["fold_time_s"]), tau_pg_s=float(m["tau_pg_s"]),
                tau_sr_s=float(m["tau_sr_s"]), n_replaced=int(m["n_replaced"]),
                n_deadlocked=int(m["n_deadlocked"]), rounds=int(m["rounds"]),
                n_steps=int(m["n_steps"]), status="deadlocked" if m["n_deadlocked"] else "ok",
                kept=float(np.sum(status == REACHED)) / max(1, movable),
                search_s=float(m["search_s"]) if "search_s" in m else None)
