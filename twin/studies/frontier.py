"""Design studies: coverage and feasibility of each design point, and their Pareto frontiers.

A *design point* is a grid point but its deadlock resolution (its ``design_id``): robot
family, arm ratio, pitch / reach, buffer, ... Under each resolver (``search``: our best,
keeps targets; ``replace``: Sayres 2021's rule) it gets one :class:`DesignResult`, the
means over its trials joined with the coverage of its geometry (measured once,
:mod:`rfp_twin.twin.studies.coverage`):

- ``kept``: targets kept, the share of movable robots at their own target when the plan
  ends (replaced and still-deadlocked robots are lost); a trial that failed (folded state
  collides, no clear random targets, planner error) keeps none, i.e. counts 0;
- ``fold_s`` (stepwise plan), ``fold_fw_s`` (firmware-ready, ``study.firmware``), mean s;
- ``plan_s``: median wall time of planning, s (the search's long tail is in ``plan_s_max``).

:func:`pareto_mask` marks the designs no other design beats on both coverage (more is
better) and feasibility (more kept, or a shorter fold); :func:`frontier_section` is the
report's markdown (a table of every design, frontier marks, the figure of
:mod:`rfp_twin.twin.studies.frontier_plot`). Units: mm, s; coverage and kept in [0, 1].
"""
from __future__ import annotations

import math
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rfp_twin.twin.studies.coverage import read_coverage
from rfp_twin.twin.studies.frontier_plot import FRONTIER_PNG, draw_frontier, frontier_groups
from rfp_twin.twin.studies.store import read_results

__all__ = ["DesignResult", "design_results", "pareto_mask", "choose_cover_k", "mark_frontiers",
           "frontier_tags", "frontier_table", "frontier_section", "RESOLVER_ORDER"]

#: Resolvers in the order tables and legends show them.
RESOLVER_ORDER = ("search", "replace", "none")


@dataclass
class DesignResult:
    """One design point under one resolver.

    design_id, family, resolution : str (family "" without [[family]] tables)
    params : {preset, layout, n_robots, n_rafts, pitch_mm, alpha_length_mm,
        beta_length_mm, arm_ratio, pitch_over_reach, buffer_mm, step_deg, algorithm}
    cover : {1: share >= 1 fiber, 2: ..., 3: ...} (None: not measured)
    n_trials, n_failed, n_collision_trials : counts
    kept, kept_min, efficiency : mean / lowest targets kept, mean Eq. 11 efficiency
    fold_s, fold_fw_s : mean stepwise / firmware-ready fold time, s (NaN: none)
    plan_s, plan_s_max : median / largest planning wall time, s
    frontier : {"kept": on the kept frontier, "fold": on the fold-time frontier}
    """

    design_id: str
    family: str
    resolution: str
    params: dict
    cover: dict
    n_trials: int = 0
    n_failed: int = 0
    n_collision_trials: int = 0
    kept: float = math.nan
    kept_min: float = math.nan
    efficiency: float = math.nan
    fold_s: float = math.nan
    fold_fw_s: float = math.nan
    plan_s: float = math.nan
    plan_s_max: float = math.nan
    frontier: dict = field(default_factory=dict)

    def fold(self) -> float:
        """The fold time a designer reads: firmware-ready when measured, else stepwise, s."""
        return self.fold_fw_s if math.isfinite(self.fold_fw_s) else self.fold_s


def _mean(xs) -> float:
    xs = [x for x in xs if x is not None and math.isfinite(x)]
    return float(np.mean(xs)) if xs else math.nan


def design_results(study_dir: str | Path, point_ids: set[str] | None = None) -> list[DesignResult]:
    """One :class:`DesignResult` per (design point, resolver) of a study folder, sorted by
    family, pitch / reach, arm ratio, buffer, resolver. ``point_ids``: only these points."""
    cols = read_results(study_dir).to_pydict()
    cover = {r["geometry_id"]: r for r in read_coverage(study_dir).to_pylist()}
    groups: dict[tuple, list[int]] = defaultdict(list)
    for i, pid in enumerate(cols["point_id"]):
        if point_ids is None or pid in point_ids:
            did = cols["design_id"][i] or pid           # older rows: no design id
            groups[(did, cols["resolution"][i])].append(i)
    out = []
    for (did, res), idx in groups.items():
        first = idx[0]
        la, lb = cols["alpha_length_mm"][first], cols["beta_length_mm"][first]
        params = {k: cols[k][first] for k in ("preset", "layout", "n_robots", "n_rafts",
                                               "pitch_mm", "buffer_mm", "step_deg", "algorithm")}
        params.update(alpha_length_mm=la, beta_length_mm=lb, arm_ratio=la / lb,
                      pitch_over_reach=cols["pitch_mm"][first] / (la + lb))
        cov = cover.get(cols["geometry_id"][first]) or {}
        ok = [i for i in idx if cols["status"][i] != "error"]
        kept = [cols["kept"][i] if cols["kept"][i] is not None else
                cols["efficiency"][i] - cols["n_deadlocked"][i] / max(1, cols["n_robots"][i])
                for i in ok] + [0.0] * (len(idx) - len(ok))
        plan = [cols["plan_s"][i] for i in ok if cols["plan_s"][i] is not None]
        out.append(DesignResult(
            design_id=did, family=cols["family"][first] or "", resolution=res, params=params,
            cover={k: cov.get(f"cover_{k}") for k in (1, 2, 3)}, n_trials=len(idx),
            n_failed=len(idx) - len(ok),
            n_collision_trials=sum(bool(cols["collisions"][i]) for i in ok),
            kept=_mean(kept), kept_min=float(min(kept)) if kept else math.nan,
            efficiency=_mean(cols["efficiency"][i] for i in ok),
            fold_s=_mean(cols["fold_time_s"][i] for i in ok),
            fold_fw_s=_mean(cols["fold_fw_s"][i] for i in ok),
            plan_s=float(np.median(plan)) if plan else math.nan,
            plan_s_max=float(max(plan)) if plan else math.nan))
    out.sort(key=lambda d: (d.family, d.params["pitch_over_reach"], d.params["arm_ratio"],
                            d.params["buffer_mm"], RESOLVER_ORDER.index(d.resolution)
                            if d.resolution in RESOLVER_ORDER else 9))
    return out


def pareto_mask(x, y, maximize_y: bool = True) -> np.ndarray:
    """Which points no other point beats: ``x`` larger is better, ``y`` larger (or smaller
    with ``maximize_y=False``) is better; a point is dominated by one at least as good on
    both and better on one. NaN points are never on the frontier; equal points both are.

    Parameters
    ----------
    x, y : (n,) float

    Returns
    -------
    (n,) bool
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float) * (1.0 if maximize_y else -1.0)
    ok = np.isfinite(x) & np.isfinite(y)
    mask = ok.copy()
    for i in np.flatnonzero(ok):
        ge = ok & (x >= x[i]) & (y >= y[i])
        better = ge & ((x > x[i]) | (y > y[i]))
        mask[i] = not better.any()
    return mask


def choose_cover_k(designs: list[DesignResult]) -> int:
    """Coverage the frontier is drawn against: >= 2 fibers, unless that share is the
    same (within 0.005) at every design while the >= 1 share varies."""
    def spread(k: int) -> float:
        v = [d.cover[k] for d in designs if d.cover.get(k) is not None]
        return float(np.ptp(v)) if v else 0.0
    return 1 if spread(2) < 0.005 <= spread(1) else 2


def mark_frontiers(designs: list[DesignResult], k: int) -> None:
    """Set ``frontier["kept"]`` and ``frontier["fold"]`` of every design: Pareto-optimal
    among the designs of its family under its resolver (coverage >= ``k`` fibers)."""
    by: dict[tuple, list[DesignResult]] = defaultdict(list)
    for d in designs:
        by[(d.family, d.resolution)].append(d)
    for ds in by.values():
        x = [d.cover.get(k) if d.cover.get(k) is not None else math.nan for d in ds]
        for name, y, up in (("kept", [d.kept for d in ds], True),
                            ("fold", [d.fold() for d in ds], False)):
            for d, on in zip(ds, pareto_mask(x, y, maximize_y=up)):
                d.frontier[name] = bool(on)


def _f(x, nd: int = 3) -> str:
    return "-" if x is None or not math.isfinite(x) else f"{x:.{nd}f}"


def frontier_tags(designs: list[DesignResult], k: int) -> dict[tuple, list[str]]:
    """{(design_id, resolution): ["kept s1", "fold r2", ...]}: the tags the frontier figure
    gives the design's frontier points (:func:`~rfp_twin.twin.studies.frontier_plot.frontier_groups`)."""
    marks: dict[tuple, list[str]] = defaultdict(list)
    for fam in sorted({d.family for d in designs}):
        ds = [d for d in designs if d.family == fam]
        for metric in ("kept", "fold"):
            for tag, group in frontier_groups(ds, k, metric):
                for d in group:
                    marks[(d.design_id, d.resolution)].append(f"{metric} {tag}")
    return marks


def frontier_table(designs: list[DesignResult], marks: dict | None = None) -> list[str]:
    """Markdown: one row per design point, the resolvers side by side; the last column
    lists its frontier points (``marks`` from :func:`frontier_tags`, else resolver (metric))."""
    res = [r for r in RESOLVER_ORDER if any(d.resolution == r for d in designs)]
    by: dict[str, dict[str, DesignResult]] = defaultdict(dict)
    for d in designs:
        by[d.design_id][d.resolution] = d
    head = ["family", "q = a/b", "p/r", "sigma mm", "cov >=1", ">=2", ">=3"]
    for r in res:
        head += [f"kept {r}", f"fold s {r}", f"fw fold s {r}", f"plan s {r}"]
    head += ["trials (failed)", "frontier"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for did, per in by.items():
        d0 = next(iter(per.values()))
        p = d0.params
        row = [d0.family or "-", f"{p['arm_ratio']:.3g}", f"{p['pitch_over_reach']:.3g}",
               f"{p['buffer_mm']:g}"] + [_f(d0.cover.get(k)) for k in (1, 2, 3)]
        on = []
        for r in res:
            d = per.get(r)
            row += ([_f(d.kept), _f(d.fold_s, 2), _f(d.fold_fw_s, 2), _f(d.plan_s, 2)] if d
                    else ["-"] * 4)
            if d is not None and marks is not None:
                on += marks.get((did, r), [])
            elif d is not None:
                on += [f"{r} ({m})" for m in ("kept", "fold") if d.frontier.get(m)]
        row += [" / ".join(f"{per[r].n_trials} ({per[r].n_failed})" if r in per else "-"
                           for r in res), ", ".join(on) or "-"]
        lines.append("| " + " | ".join(row) + " |")
    return lines


def frontier_section(study_dir: str | Path, out_dir: Path, point_ids: set[str] | None = None,
                     ) -> tuple[list[str], list[Path], str | None]:
    """The report's design section: (markdown lines, figures written, why not drawn).

    Drawn when the study folder has a coverage table (``coverage = true``)."""
    designs = design_results(study_dir, point_ids)
    if not designs or all(d.cover.get(1) is None for d in designs):
        return [], [], "no coverage measured for these points (set coverage = true in [study])"
    k = choose_cover_k(designs)
    mark_frontiers(designs, k)
    path = draw_frontier(designs, out_dir / FRONTIER_PNG, k)
    fw = any(math.isfinite(d.fold_fw_s) for d in designs)
    lines = ["## Design frontier: coverage and feasibility", "",
             f"![frontier]({path.name})", "",
             f"*{path.name}*: per robot family (one row each), targets kept (left) and "
             f"{'firmware-ready' if fw else 'stepwise'} fold time (middle) against the share of "
             f"the focal plane (convex hull of the bases) reached by >= {k} fibers; one marker "
             "per design point and resolver (small filled: search, large ring: replace; a "
             "filled marker in its ring: both alike; the pair joined by a grey line: the same "
             "targets); marker: q = alpha/beta, colour: sigma; markers of equal coverage are "
             "dodged sideways a little. Lines: Pareto frontiers (solid: search, dashed: "
             "replace); their points are tagged s1, s2, ... (search) and r1, ... (replace), "
             "spelled out in the key as q, pitch / reach (p/r) and sigma (and in the table's last "
             "column).", "",
             "Kept: share of robots at their own target when the plan ends (a failed trial "
             "keeps none); fold s: stepwise plan; fw fold s: firmware-ready trajectory plus "
             "path delay; plan s: median planning wall time (searches included; the longest: "
             + ", ".join(f"{r} {_f(max((d.plan_s_max for d in designs if d.resolution == r), default=math.nan), 1)} s"
                         for r in RESOLVER_ORDER if any(d.resolution == r for d in designs))
             + "). Frontier: no design of the same family and resolver has both more "
             f"coverage (>= {k}) and more kept (or a shorter fold).", ""]
    lines += frontier_table(designs, frontier_tags(designs, k)) + [""]
    return lines, [path], None
