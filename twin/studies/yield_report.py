"""The science yield of a study: per design, catalogue kind and density, and the report's section.

Rows of yield trials (:mod:`rfp_twin.twin.studies.yield_trial`) are grouped into one
:class:`YieldPoint` per (design, catalogue kind, density): the design is the grid point
but its catalogue keys (``design_id``). :func:`yield_section` writes the report's
markdown (the formulas, one table row per point, a replay command) and draws the two
figures of :mod:`rfp_twin.twin.studies.yield_plot`: completeness against density, one
line per design, and the yield frontier against robot count, pitch and arm ratio.

Completeness = targets kept by the plan / science targets within reach of a robot;
targets per hour = 3600 x targets per pointing / (reconfiguration s + exposure s).
Units: s; completeness in [0, 1].
"""
from __future__ import annotations

import json
import math
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rfp_twin.twin.studies.spec import FIXED_LAYOUTS
from rfp_twin.twin.studies.store import read_results

__all__ = ["YieldPoint", "yield_points", "design_label", "reference_density", "yield_section",
           "replay_command"]

#: Catalogue kinds in the order tables and panels show them.
KIND_ORDER = ("uniform", "clustered")


@dataclass
class YieldPoint:
    """The trials of one design under one catalogue kind and density.

    design_id, family, label : the design (label: what the figure's legend says)
    params : preset, layout, n_robots, n_rafts, pitch_mm, alpha / beta length, arm_ratio,
        pitch_over_reach, buffer_mm, density_unit, exposure_s
    catalogue, density : the catalogue kind and its density (in ``params['density_unit']``)
    values : {column: (k,) float array over the trials that did not fail}
    n_trials, n_failed, collisions, n_lost : counts (collisions: 2D check, all trials;
        n_lost: assigned targets the plan still lost after the last round, all trials)
    by_priority : {level: mean completeness}
    seeds, texts : seed and ``--catalogue`` text of each trial that did not fail
    """

    design_id: str
    family: str
    catalogue: str
    density: float
    params: dict
    label: str = ""
    values: dict = field(default_factory=dict)
    n_trials: int = 0
    n_failed: int = 0
    collisions: int = 0
    n_lost: int = 0
    by_priority: dict = field(default_factory=dict)
    seeds: list = field(default_factory=list)
    texts: list = field(default_factory=list)
    errors: list = field(default_factory=list)

    def mean(self, col: str) -> float:
        v = self.values.get(col, np.empty(0))
        return float(np.mean(v)) if v.size else math.nan

    def min(self, col: str) -> float:
        v = self.values.get(col, np.empty(0))
        return float(np.min(v)) if v.size else math.nan

    def sd(self, col: str) -> float:
        v = self.values.get(col, np.empty(0))
        return float(np.std(v, ddof=1)) if v.size > 1 else math.nan


#: Row columns averaged per point.
VALUE_COLUMNS = ("completeness", "completeness_top", "targets_per_pointing", "targets_per_hour",
                 "reconfig_s", "targets_per_robot", "n_available", "loop_rounds", "loop_lost",
                 "plan_s", "assign_s", "wall_s", "assign_gap", "missed_busy", "missed_parked",
                 "missed_neighbour", "missed_other")
#: Why targets within reach were missed: row column -> what the report calls it.
MISSED = {"missed_busy": "every robot that reaches them busy",
          "missed_parked": "blocked only by parked neighbours",
          "missed_neighbour": "blocked by a neighbour on another target",
          "missed_other": "other (forbidden by the loop, time limit)"}
PARAM_KEYS = ("preset", "layout", "n_robots", "n_rafts", "pitch_mm", "alpha_length_mm",
              "beta_length_mm", "arm_ratio", "pitch_over_reach", "buffer_mm", "step_deg",
              "resolution", "density_unit", "exposure_s")


def yield_points(study_dir: str | Path, point_ids: set[str] | None = None) -> list[YieldPoint]:
    """One :class:`YieldPoint` per (design, catalogue, density) of the yield rows of a study
    folder (``point_ids``: only these points), sorted by family, design, kind, density;
    labels set by :func:`design_label`."""
    cols = read_results(study_dir).to_pydict()
    groups: dict[tuple, list[int]] = defaultdict(list)
    for i, cat in enumerate(cols["catalogue"]):
        if cat is not None and (point_ids is None or cols["point_id"][i] in point_ids):
            groups[(cols["design_id"][i], cat, cols["density"][i])].append(i)
    out = []
    for (did, cat, dens), idx in groups.items():
        first = idx[0]
        params = {k: cols[k][first] for k in PARAM_KEYS if k in cols}
        p = YieldPoint(did, cols["family"][first] or "", cat, float(dens), params)
        ok = [i for i in idx if cols["status"][i] != "error"]
        p.n_trials, p.n_failed = len(idx), len(idx) - len(ok)
        p.errors = sorted({cols["error"][i] for i in idx if cols["error"][i]})
        for c in VALUE_COLUMNS:
            p.values[c] = np.array([cols[c][i] for i in ok if cols[c][i] is not None], dtype=float)
        p.collisions = int(sum(cols["collisions"][i] or 0 for i in ok))
        p.n_lost = int(sum(cols["n_lost"][i] or 0 for i in ok))
        levels: dict[str, list[float]] = defaultdict(list)
        for i in ok:
            for lvl, c in json.loads(cols["completeness_by_priority"][i] or "{}").items():
                levels[lvl].append(c)
        p.by_priority = {k: float(np.mean(v)) for k, v in sorted(levels.items(),
                                                                  key=lambda kv: float(kv[0]))}
        p.seeds = [int(cols["seed"][i]) for i in ok]
        p.texts = [cols["catalogue_text"][i] for i in ok]
        out.append(p)
    labels = design_label(out)
    for p in out:
        p.label = labels[p.design_id]
    out.sort(key=lambda p: (p.family, p.params["n_robots"], p.params["pitch_mm"],
                            p.params.get("pitch_over_reach") or 0.0, p.params.get("arm_ratio")
                            or 0.0, KIND_ORDER.index(p.catalogue)
                            if p.catalogue in KIND_ORDER else 9, p.density))
    return out


def _layout_name(params: dict) -> str:
    lay = params["layout"]
    if lay in FIXED_LAYOUTS:
        return lay
    if lay == "raft":
        return f"raft:{params['n_rafts']}"
    return f"hex:{params['n_robots']}"


def design_label(points: list[YieldPoint]) -> dict[str, str]:
    """{design_id: legend label}: the family (or preset) and layout, robots and pitch, and
    the arm ratio q = alpha/beta and pitch / reach p/r where they vary within the family."""
    by_fam: dict[str, dict[str, dict]] = defaultdict(dict)
    for p in points:
        by_fam[p.family][p.design_id] = p.params
    out = {}
    for fam, designs in by_fam.items():
        def varies(key: str) -> bool:
            return len({round(d.get(key) or 0.0, 4) for d in designs.values()}) > 1
        for did, d in designs.items():
            name = fam or d["preset"]
            text = f"{name}: {d['n_robots']} robots, pitch {d['pitch_mm']:g} mm"
            if varies("arm_ratio"):
                text += f", q {d['arm_ratio']:.3g}"
            if varies("pitch_over_reach"):
                text += f", p/r {d['pitch_over_reach']:.3g}"
            if varies("buffer_mm"):
                text += f", sigma {d['buffer_mm']:g}"
            out[did] = text
    return out


def reference_density(points: list[YieldPoint]) -> float:
    """The density the frontier compares designs at: the study's density closest to one
    target per robot (in log), among those every design has."""
    per: dict[str, set] = defaultdict(set)
    for p in points:
        per[p.design_id].add(p.density)
    common = set.intersection(*per.values()) if per else set()
    pool = sorted(common or {p.density for p in points})
    return min(pool, key=lambda d: abs(math.log(d))) if pool else math.nan


def replay_command(p: YieldPoint) -> str:
    """The ``rfp-twin plan --catalogue`` command that replays the point's first trial."""
    q = p.params
    return (f"rfp-twin plan --preset {q['preset']} --layout {_layout_name(q)} "
            f"--buffer {q['buffer_mm']:g} --step {q['step_deg']:g} --resolve {q['resolution']} "
            f"--catalogue {p.texts[0]} --seed {p.seeds[0]}")


def _f(x, nd: int = 3) -> str:
    return "-" if x is None or not math.isfinite(x) else f"{x:.{nd}f}"


def yield_table(points: list[YieldPoint]) -> list[str]:
    """Markdown: one row per (design, catalogue, density)."""
    unit = points[0].params.get("density_unit") if points else ""
    head = ["design", "catalogue", f"density /{unit}", "available / robot", "trials (failed)",
            "completeness", "min", "top priority", "targets / pointing", "reconfig s",
            "targets / hour", "missed: busy / parked / neighbour / other", "rounds",
            "lost in loop", "lost at end", "collisions"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for p in points:
        lines.append("| " + " | ".join([
            p.label, p.catalogue, f"{p.density:g}", _f(p.mean("targets_per_robot"), 2),
            f"{p.n_trials} ({p.n_failed})", _f(p.mean("completeness")),
            _f(p.min("completeness")), _f(p.mean("completeness_top")),
            _f(p.mean("targets_per_pointing"), 1), _f(p.mean("reconfig_s"), 1),
            _f(p.mean("targets_per_hour"), 0),
            " / ".join(_f(p.mean(c), 1) for c in MISSED), _f(p.mean("loop_rounds"), 2),
            str(int(p.values["loop_lost"].sum())), str(p.n_lost), str(p.collisions)]) + " |")
    return lines


def yield_section(study_dir: str | Path, out_dir: Path, point_ids: set[str] | None = None,
                  exposure_s: float | None = None) -> tuple[list[str], list[Path]]:
    """The report's yield section: (markdown lines, figures written); empty without yield
    rows. ``exposure_s``: the study's (for the text; each row carries its own)."""
    from rfp_twin.twin.studies.yield_plot import (COMPLETENESS_PNG, FRONTIER_PNG,
                                                  draw_completeness, draw_yield_frontier)

    points = yield_points(study_dir, point_ids)
    if not points:
        return [], []
    ref = reference_density(points)
    figs = [draw_completeness(points, out_dir / COMPLETENESS_PNG),
            draw_yield_frontier(points, out_dir / FRONTIER_PNG, ref)]
    exp = sorted({p.params.get("exposure_s") for p in points if p.params.get("exposure_s")})
    unit = points[0].params.get("density_unit")
    n_trials = sum(p.n_trials for p in points)
    n_failed = sum(p.n_failed for p in points)
    n_coll = sum(p.collisions for p in points)
    n_lost = sum(p.n_lost for p in points)
    lost_loop = int(sum(p.values["loop_lost"].sum() for p in points))
    missed = {c: int(sum(p.values[c].sum() for p in points)) for c in MISSED}
    n_missed = sum(missed.values())
    lines = ["## Science yield", "",
             f"{n_trials} catalogue trials ({n_failed} failed) at {len(points)} (design, "
             f"catalogue, density) points. Each trial draws a mock science catalogue with its "
             "seed and runs the plannable loop: collision-aware assignment (HiGHS), plan fold "
             "-> targets keeping every assigned target, targets the plan lost forbidden and "
             "assigned again, at most the point's assign_rounds rounds.", "",
             "- **completeness** = targets assigned and kept by the plan / science targets "
             "within reach of a robot (a fiber that accepts them, clear of obstacles); "
             "*top priority*: the same for the highest priority level;",
             "- **targets per pointing** = targets assigned and kept;",
             "- **targets per hour** = 3600 x targets per pointing / (reconfiguration s + "
             f"exposure s), exposure {', '.join(f'{e:g}' for e in exp) or exposure_s} s; the "
             "reconfiguration is the fold -> targets trajectory the robots execute "
             "(firmware-ready: path delay + post-processed trajectory, when the study "
             "post-processes; else the stepwise fold time); no slew, acquisition or read-out;",
             f"- density: science targets per {unit} (robot: per hexagonal cell sqrt(3)/2 "
             "pitch^2 of the array's pitch); *available / robot*: targets within reach per "
             "robot, measured.", "",
             f"Targets lost between assignment and motion: {lost_loop} over every round of "
             f"every trial (each forbidden and assigned again), **{n_lost}** left after the "
             f"last round; 2D check of every final plan: **{n_coll}** collisions.", "",
             f"Targets within reach that no robot took ({n_missed} over every trial), by "
             "the most benign reason one of their candidate poses has: "
             + "; ".join(f"{text} {missed[c]}" for c, text in MISSED.items())
             + ". Per point, the table gives the mean per trial (busy / parked / neighbour / "
             "other): a design whose misses are *parked* loses them to idle robots' parking "
             "poses (the fold, or with clear parking its alpha turns too).", "",
             f"![completeness]({COMPLETENESS_PNG})", "",
             f"*{COMPLETENESS_PNG}*: completeness against density, one line per design (mean "
             "over the trials; bars: lowest and highest trial); left uniform (Poisson), right "
             "clustered (Thomas process) catalogues.", "",
             f"![yield frontier]({FRONTIER_PNG})", "",
             f"*{FRONTIER_PNG}*: the yield of each design at {ref:g} targets per {unit} "
             "(uniform catalogue) against its robot count, pitch and arm ratio; top: "
             "completeness, bottom: targets per hour per robot (the array's targets per "
             "hour / its robots; the table has the array's); the line in the robot-count panels "
             "joins the designs no other design beats with fewer robots (Pareto).", ""]
    lines += yield_table(points) + [""]
    first = next((p for p in points if p.seeds), None)
    if first is not None:
        lines += [f"The first trial of {first.label} ({first.catalogue}, {first.density:g} per "
                  f"{unit}) replays with", "", f"    {replay_command(first)}", "",
                  "(the plan command takes the preset's arms and pitch: a design point with "
                  "other arms needs a robot TOML with its geometry).", ""]
    return lines, figs
