"""Probe arms end to end: targets -> prioritized plan -> independent 2D check -> run folder.

The probe-arm counterpart of :class:`rfp_twin.twin.pipeline.Reconfiguration` for kinds
other than alpha/beta (MIRADAS, Sabater et al. 2018): :func:`plan_probe_bench` draws or
takes the targets, plans with :func:`rfp_twin.planners.roadmap.probe.plan_probe_arms` and checks
the plan with :func:`rfp_twin.validation.probe.check_probe_plan`; :func:`write_probe_run`
writes ``plan.json`` (per arm and motor, ``[[deg, s], ...]`` breakpoints: the straight
segments the start-stop controllers execute), ``summary.json`` and ``tables.txt`` into a
new folder, atomically. Units: deg, mm, s.
"""
from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from rfp_twin.models.errors import KindError, LayoutError, RfpError, TargetError
from rfp_twin.models.files import atomic_folder
from rfp_twin.models.kinds import MIRADAS_PROBE, load_kind
from rfp_twin.planners.plan.kinds import require_planner_kind
from rfp_twin.planners.roadmap.probe import (RECOVERING, ProbePlan, ProbePlanSettings, plan_probe_arms,
                                     random_target_set, typical_scenario)
from rfp_twin.validation.probe import ProbeCheckReport, check_probe_plan

#: Sample spacing of the independent check, s.
CHECK_DT_S = 0.01


@dataclass
class ProbeRun:
    """A planned and checked probe-arm bench: the plan, the check, the seed."""

    plan: ProbePlan
    check: ProbeCheckReport | None
    seed: int
    scenario: str
    preset: str = ""

    def summary(self) -> dict:
        out = {"kind": MIRADAS_PROBE, "preset": self.preset or self.plan.kind.spec.source,
               "seed": self.seed,
               "scenario": self.scenario, **self.plan.summary()}
        if self.check is not None:
            out["check2d"] = {k: v for k, v in asdict(self.check).items()}
        return out


def plan_probe_bench(preset: str = "miradas-probe", layout: str | None = None, *, seed: int = 0,
                     n_targets: int | None = None, algorithm: str = "roadmap",
                     priority: str = "travel-time", targets: Path | None = None,
                     settings: ProbePlanSettings | None = None) -> ProbeRun:
    """Plan the bench of a probe-arm preset from park: the targets of CSV ``targets``
    (:func:`rfp_twin.twin.probe_files.read_probe_targets`), else the typical scenario
    (``n_targets`` None) or ``n_targets`` random targets drawn with ``seed``; then check it
    in 2D (``settings``: the paper's with ``priority``, then our recovery,
    :data:`~rfp_twin.planners.roadmap.probe.RECOVERING`, by default).

    ``layout`` may be ``miradas-N`` (N arms on the preset's bench) or None (the preset's
    own count). Any ``algorithm`` but ``roadmap`` raises :class:`KindError`.
    """
    kind = load_kind(preset)
    require_planner_kind(algorithm, kind.name)
    if kind.name != MIRADAS_PROBE:
        raise KindError(f"preset {preset}: robot kind {kind.name!r}; allowed here: "
                        f"{MIRADAS_PROBE!r} (alpha/beta arrays: rfp-twin plan)")
    if layout is not None:
        if not layout.startswith("miradas-"):
            raise LayoutError(f"--layout {layout!r}; allowed for probe arms: miradas-N")
        from rfp_twin.models.kinds import ProbeArmKind
        from rfp_twin.models.layout import layout_by_name

        n = len(layout_by_name(layout, 1.0).robot_ids)
        kind = ProbeArmKind(kind.spec.with_overrides(n_arms=n))
    rng = np.random.default_rng(seed)
    if targets is not None and n_targets is not None:
        raise TargetError(f"--targets {str(targets)!r} and --n-targets {n_targets}; allowed: "
                          "one of them")
    if targets is not None:
        from rfp_twin.twin.probe_files import read_probe_targets

        start = kind.park()
        goal = read_probe_targets(targets, kind, start)
        scenario = f"targets {targets}"
    elif n_targets is None:
        start, goal = typical_scenario(kind)
        scenario = "typical"
    else:
        start = kind.park()
        goal = random_target_set(kind, rng, n_targets, start)
        scenario = f"random {n_targets} targets"
    settings = settings or ProbePlanSettings(priority=priority, **RECOVERING)
    plan = plan_probe_arms(kind, start, goal, settings, rng)
    check = None
    if plan.success:
        check = check_probe_plan(kind.spec, plan.breakpoints(), buffer_mm=0.0, dt_s=CHECK_DT_S,
                                 max_start_stop=plan.settings.max_start_stop)
    return ProbeRun(plan, check, seed, scenario, str(preset))


def write_probe_run(run: ProbeRun, out: Path, overwrite: bool = False) -> Path:
    """Write ``plan.json``, ``summary.json`` and ``tables.txt`` into folder ``out``
    (a temp folder renamed into place: nothing half-written is left)."""
    out = Path(out)
    if out.exists() and not overwrite:
        raise RfpError(f"output folder {out} exists; allowed: a new folder, or --force")
    with atomic_folder(out) as tmp:
        plan = {str(i): {"theta1": [[float(q[0]), float(t)] for t, q in zip(ts, qs)],
                         "theta2": [[float(q[1]), float(t)] for t, q in zip(ts, qs)]}
                for i, (ts, qs) in run.plan.breakpoints().items()}
        (tmp / "plan.json").write_text(json.dumps(plan), encoding="utf-8")
        (tmp / "summary.json").write_text(json.dumps(run.summary(), indent=2, default=_plain),
                                          encoding="utf-8")
        (tmp / "tables.txt").write_text(run.plan.tables() + "\n", encoding="utf-8")
    return out


def _plain(obj):
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    raise TypeError(type(obj))
