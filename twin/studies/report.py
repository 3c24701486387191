"""Study reports: markdown and matplotlib figures in the style of Sayres 2021 Figs. 10-18.

:func:`write_report` reads a study folder (``results/`` written by
:func:`rfp_twin.twin.studies.run.run_study`, plus ``study.toml``) and writes ``report/report.md`` and
PNG figures (:mod:`rfp_twin.twin.studies.figures`). Which figures are drawn depends on what the study varies:

================================  ====================================  ===================
figure                            drawn when                            paper
================================  ====================================  ===================
``fig10_efficiency_mean``         buffer_mm has >= 2 values              Fig. 10
``fig11_efficiency_min``          "                                     Fig. 11
``fig12_efficiency_box``          "                                     Fig. 12
``fig13_fold_time_mean``          "                                     Fig. 13
``fig14_fold_time_box``           "                                     Fig. 14
``fig15_efficiency_vs_step``      step_deg has >= 2 values               Fig. 15
``fig16_runtime_vs_step``         "                                     Fig. 16
``fig17_efficiency_vs_grid``      n_robots has >= 2 values               Fig. 17
``fig18_runtime_vs_grid``         "                                     Fig. 18
``feasibility_map``               pitch / reach has >= 2 values          (new)
``frontier``                      the folder has ``coverage.parquet``    (new)
================================  ====================================  ===================

Design studies (``coverage = true``) also get the design frontier: coverage against
targets kept and fold time per design point, search vs replace, Pareto frontiers, and a
table of every design (:mod:`rfp_twin.twin.studies.frontier`). Yield studies (grid key
``catalogue``) get the science yield instead of the paper's figures: completeness against
density per design, the yield frontier and a table (:mod:`rfp_twin.twin.studies.yield_report`).

Lines follow the paper: MC blue solid, GC red dashed; box plots have whiskers at 1.5 IQR
and outliers as diamonds; grid-size plots shade the 95 % confidence interval of the mean
(Student t). Other parameters that vary (e.g. step in a buffer plot) become extra lines,
in lighter or darker shades of the algorithm's colour. Trials that failed (``status =
error``, e.g. no clear random targets in a very dense array) are counted, not averaged.

When the study has the conditions of the paper's Simulation 1 (547-robot hex grid, 7.4 /
15 mm arms, 22.4 mm pitch, 0.1 deg, reverse with target replacement), the report puts
the values the paper states for Figs. 10, 11, 13 and 14 beside ours; Table 3 rows are
compared wherever the study has their (algorithm, buffer, step) on that grid
(:mod:`rfp_twin.twin.studies.paper`).
"""
from __future__ import annotations

import math
import sys
from collections import defaultdict
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from rfp_twin.twin.studies.coverage import COVERAGE_FILE
from rfp_twin.twin.studies.figures import FIGURES, draw_figures
from rfp_twin.twin.studies.frontier import frontier_section
from rfp_twin.twin.studies.groups import (ALG_SHORT, CATALOGUE_PARAMS, SHORT, Group, fmt_num,
                                          fmt_val, load_groups, make_series, series_label,
                                          varied_params)
from rfp_twin.twin.studies.paper import PAPER_FIG10, paper_sections
from rfp_twin.twin.studies.spec import StudyError
from rfp_twin.twin.studies.store import RESULTS, replace_atomically
from rfp_twin.twin.studies.yield_report import yield_section

__all__ = ["Report", "write_report", "load_groups", "Group", "FIGURES", "PAPER_FIG10"]

REPORT_DIR = "report"
REPORT_MD = "report.md"


@dataclass
class Report:
    """What :func:`write_report` wrote: the markdown, the figures, the figures not drawn
    (with the reason), the trend checks (name -> holds) and the notes."""

    markdown: Path
    figures: list          # [Path]
    skipped: dict          # figure -> reason
    trends: dict           # name -> bool
    notes: list


def _trend_section(groups, varied) -> tuple[list[str], dict]:
    """Markdown: does efficiency fall with the buffer, and MC stay above GC; the checks."""
    lines, trends = [], {}
    if "buffer_mm" not in varied:
        return lines, trends
    series = make_series(groups, "buffer_mm", varied)
    lines += ["## Trends vs buffer", ""]
    lines.append("Efficiency should fall with the buffer (crowding), and MC should stay above "
                 "GC (Sayres 2021 Sect. 5.3). `non-increasing` allows ties (e.g. every trial at "
                 "1.0); `strict` means every step down.")
    lines.append("")
    lines.append("`within noise`: no rise from one buffer to the next larger than twice the "
                 "standard error of the difference of the two means (a single replaced target "
                 "in one of a few trials moves a 547-robot mean by 1/547/trials). Kendall tau: "
                 "rank correlation of every trial's efficiency with the buffer, one-sided p "
                 "for a fall.")
    lines.append("")
    lines.append("| series | mean efficiency by buffer | non-increasing | within noise | strict "
                 "| first > last | Kendall tau (p) |")
    lines.append("|---|---|---|---|---|---|---|")
    from scipy.stats import kendalltau

    for key, gs in series.items():
        ys = [g.mean("efficiency") for g in gs]
        values = ", ".join(f"{g.params['buffer_mm']:g}: {fmt_num(y)}" for g, y in zip(gs, ys))
        if len(ys) < 2:
            lines.append(f"| {series_label(*key)} | {values} | - | - | - | - | - |")
            continue
        nonincr = all(b <= a + 1e-12 for a, b in zip(ys, ys[1:]))
        strict = all(b < a for a, b in zip(ys, ys[1:]))
        noisy = []
        for ga, gb in zip(gs, gs[1:]):
            ea, eb = ga.v("efficiency"), gb.v("efficiency")
            se = math.sqrt((np.var(ea, ddof=1) / ea.size if ea.size > 1 else 0.0)
                           + (np.var(eb, ddof=1) / eb.size if eb.size > 1 else 0.0))
            noisy.append(eb.mean() - ea.mean() <= 2.0 * se + 1e-12)
        within = all(noisy)
        drop = ys[-1] < ys[0]
        xs = np.concatenate([np.full(g.v("efficiency").size, g.params["buffer_mm"]) for g in gs])
        es = np.concatenate([g.v("efficiency") for g in gs])
        tau, p = kendalltau(xs, es, alternative="less") if np.ptp(es) > 0 else (math.nan, math.nan)
        name = series_label(*key)
        trends[f"monotonic {name}"] = nonincr
        trends[f"monotonic within noise {name}"] = within
        trends[f"falls {name}"] = drop
        lines.append(f"| {name} | {values} | {'yes' if nonincr else 'NO'} | "
                     f"{'yes' if within else 'NO'} | {'yes' if strict else 'no'} | "
                     f"{'yes' if drop else 'NO'} | "
                     + (f"{tau:.2f} ({p:.2g})" if math.isfinite(tau) else "-") + " |")
    # MC above GC at every buffer, per slice
    by_slice: dict = defaultdict(dict)
    for (alg, sl), gs in series.items():
        sl2 = tuple((k, v) for k, v in sl if k not in ("greed", "phobia"))
        by_slice[sl2][alg] = {g.params["buffer_mm"]: g.mean("efficiency") for g in gs}
    rows = []
    for sl, d in by_slice.items():
        if "greedy" in d and "markov" in d:
            common = sorted(set(d["greedy"]) & set(d["markov"]))
            ge = [d["markov"][b] >= d["greedy"][b] for b in common]
            name = series_label("MC >= GC", sl)
            trends[name] = all(ge)
            rows.append(f"| {name} | {sum(ge)}/{len(ge)} buffers | "
                        f"{'yes' if all(ge) else 'NO'} |")
    if rows:
        lines += ["", "| comparison | buffers where it holds | every buffer |", "|---|---|---|"]
        lines += rows
    lines.append("")
    return lines, trends


def _grid_section(groups, varied) -> list[str]:
    """Least-squares lines of tau_pg / tau_sr over the grid size (paper: tau_pg linear)."""
    if "n_robots" not in varied:
        return []
    lines = ["## Runtime vs grid size", "",
             "Sayres 2021 Sect. 5.6: tau_pg grows linearly with the number of robots; tau_sr "
             "less tightly (more deadlocks in larger grids); efficiency is not strongly "
             "affected above ~500 robots. Least-squares lines over the grid points "
             "(per-point means):", "",
             "| series | quantity | intercept s | s per 1000 robots | R^2 | mean eff. range |",
             "|---|---|---|---|---|---|"]
    for key, gs in make_series(groups, "n_robots", varied).items():
        if len(gs) < 3:
            continue
        n = np.array([g.params["n_robots"] for g in gs], dtype=float)
        eff = [g.mean("efficiency") for g in gs]
        for metric in ("tau_pg_s", "tau_sr_s"):
            y = np.array([g.mean(metric) for g in gs])
            ok = np.isfinite(y)
            if ok.sum() < 3:
                continue
            b, a = np.polyfit(n[ok], y[ok], 1)
            fit = a + b * n[ok]
            ss = float(np.sum((y[ok] - y[ok].mean()) ** 2))
            r2 = 1.0 - float(np.sum((y[ok] - fit) ** 2)) / ss if ss > 0 else math.nan
            lines.append(f"| {series_label(*key)} | {metric[:-2]} | {a:.4f} | {1000 * b:.4f} | "
                         f"{fmt_num(r2, 3)} | {fmt_num(min(eff))}-{fmt_num(max(eff))} |")
    lines.append("")
    return lines


def _points_table(groups, varied) -> list[str]:
    """Markdown table: one row per grid point (varied parameters, counts, means)."""
    cols = [k for k in varied if k != "algorithm"]
    cols += [k for k in CATALOGUE_PARAMS if any(k in g.params for g in groups)]
    head = (["alg"] + [SHORT.get(k) or k for k in cols]
            + ["trials", "errors", "mean eff.", "95 % CI", "min eff.", "std", "conv. 1st run",
               "fold s", "tau_pg s", "tau_sr s", "replaced", "rounds", "deadlocked left",
               "collisions (trials)"])
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for g in groups:
        e = g.v("efficiency")
        lo, hi = g.ci95("efficiency")
        std = float(np.std(e, ddof=1)) if e.size > 1 else math.nan
        row = [ALG_SHORT.get(g.alg, g.alg)] + [fmt_val(k, g.params.get(k, "-")) for k in cols] + [
            str(g.n), str(g.n_error), fmt_num(g.mean("efficiency")),
            f"{fmt_num(lo)}-{fmt_num(hi)}", fmt_num(g.min("efficiency")), fmt_num(std),
            fmt_num(g.mean("convergence")), fmt_num(g.mean("fold_time_s"), 2),
            fmt_num(g.mean("tau_pg_s"), 3), fmt_num(g.mean("tau_sr_s"), 3),
            fmt_num(g.mean("n_replaced"), 2), fmt_num(g.mean("rounds"), 2), str(g.n_deadlocked),
            f"{g.collisions} ({g.n_collision_trials}/{g.n_checked})" if g.n_checked
            else "not checked"]
        lines.append("| " + " | ".join(row) + " |")
    return lines


def _reproduce_line(g: Group) -> str:
    """The ``rfp-twin plan`` command that replays the point's lowest-efficiency trial."""
    p = g.params
    if p["layout"] == "sdss-v-fps":
        lay = "sdss-v-fps"
    else:
        from rfp_twin.models.layout import hex_rings
        lay = f"hex:{p['n_robots']}" if p["n_robots"] >= 37 else f"hex:{hex_rings(p['n_robots'])}"
    seeds = g.v("seed")
    if not seeds.size:
        return ""
    eff = g.v("efficiency")
    k = int(np.argmin(eff))
    extra = ""
    if p["algorithm"] == "markov":
        extra = f" --greed {p['greed']:g} --phobia {p['phobia']:g}"
    extra += f" --resolve {p['resolution']}"
    if p["direction"] != "reverse":
        extra += f" --direction {p['direction']}"
    same_arms = (abs(p["pitch_mm"] - 22.4) < 1e-9 and abs(p["alpha_length_mm"] - 7.4) < 1e-9
                 and abs(p["beta_length_mm"] - 15.0) < 1e-9)
    cmd = (f"rfp-twin plan --preset {p['preset']} --layout {lay} --buffer {p['buffer_mm']:g} "
           f"--step {p['step_deg']:g} --algorithm {p['algorithm']}{extra} "
           f"--max-steps {p['max_steps']} --seed {int(seeds[k])}")
    note = "" if same_arms and p["preset"].startswith("sdss-v") else \
        "(the plan command takes the preset's pitch and arms: write a robot TOML with this " \
        "point's geometry to replay it)"
    if p["max_rounds"] != 50:
        note += (" (`rfp-twin plan` always allows 50 resolution rounds; this point: "
                 f"{p['max_rounds']})")
    return (f"The lowest-efficiency trial of the first point ({series_label(g.alg, ())}, "
            f"efficiency {fmt_num(float(eff[k]))}) replays with\n\n    {cmd}\n\n{note}").rstrip()



def _head_section(study_dir: Path, info: dict, groups: list[Group], varied: list[str]) -> list[str]:
    """Title, the study's description, and the counts of trials, failures and collisions."""
    st = info["study"]
    name = st.name if st else study_dir.name
    n_rows = sum(g.n for g in groups)
    n_err = sum(g.n_error for g in groups)
    n_checked = sum(g.n_checked for g in groups)
    n_coll = sum(g.n_collision_trials for g in groups)
    n_dead = sum(g.n_deadlocked for g in groups)
    wall = sum(float(g.v("wall_s").sum()) for g in groups)
    per_point = sorted({g.n for g in groups})
    per_range = f"{per_point[0]}-{per_point[-1]}" if len(per_point) > 1 else str(per_point[0])
    lines = [f"# Study report: {name}", ""]
    if st is not None:
        if st.description:
            lines += [st.description, ""]
        if st.reference:
            lines += [f"Reference: {st.reference}", ""]
        lines += [f"Base seed {st.seed}; {st.trials} trials per point asked, "
                  f"{len(st.points)} grid points; 2D check per trial: "
                  f"{'yes' if st.check else 'no'}.", ""]
    lines += [f"Generated {datetime.now(timezone.utc):%Y-%m-%d %H:%M UTC} from `{study_dir}` by "
              f"`rfp-twin study report` (Python {sys.version.split()[0]}).", ""]
    lines += ["## Trials", "",
              f"- {n_rows} trials at {len(groups)} grid points "
              f"({per_range} per point).",
              f"- Failed trials (no plan, e.g. no clear random targets): {n_err}.",
              f"- Trials left with deadlocked robots after the last resolution round: {n_dead}.",
              f"- Collisions found by the independent 2D checker: **{n_coll}** trials with "
              f"collisions out of {n_checked} checked"
              + (" (a collision is a planner bug: see the table)" if n_coll else "") + ".",
              f"- Worker time in trials: {wall:.0f} s ({wall / max(1, n_rows):.2f} s per trial), "
              f"{info['worker_processes']} worker process(es) on {', '.join(info['hosts'])}.",
              f"- Varied parameters: {', '.join(varied) if varied else 'none'}.", ""]
    errs = sorted({e for g in groups for e in g.errors})
    if errs:
        lines += ["Errors seen (first 5):", ""] + [f"- `{e}`" for e in errs[:5]] + [""]
    return lines


def write_report(study_dir: str | Path, out_dir: str | Path | None = None, *,
                 all_points: bool = False) -> Report:
    """Write ``report.md`` and the figures for a study folder.

    Parameters
    ----------
    study_dir : the folder ``rfp-twin study run`` wrote (``study.toml`` + ``results/``).
    out_dir : where to write (default ``study_dir/report``).
    all_points : report rows of grid points no longer in ``study.toml`` too.

    Returns
    -------
    Report (paths of the markdown and figures, skipped figures with the reason, the trend
    checks).
    """
    study_dir = Path(study_dir)
    if not (study_dir / RESULTS).is_dir() and not study_dir.name == RESULTS:
        raise StudyError(f"{study_dir}: no {RESULTS}/ folder; allowed: a folder written by "
                         "`rfp-twin study run`")
    groups, info = load_groups(study_dir, all_points=all_points)
    if not groups:
        raise StudyError(f"{study_dir}: no trials in {RESULTS}/ yet; run the study first")
    out = Path(out_dir) if out_dir is not None else study_dir / REPORT_DIR
    out.mkdir(parents=True, exist_ok=True)
    varied = varied_params(groups)
    notes: list[str] = []
    if info["note"]:
        notes.append(info["note"])
    if info["ignored_rows"]:
        notes.append(f"{info['ignored_rows']} rows of grid points that are not in study.toml "
                     "were left out (use --all-points to include them).")
    yield_lines, yield_figs = yield_section(study_dir, out, {g.point_id for g in groups},
                                            info["study"].exposure_s if info["study"] else None)
    if yield_lines:
        drawn, skipped = [], {"paper figures (Sayres 2021 Figs. 10-18)":
                              "a yield study: see the science yield section"}
    else:
        drawn, skipped = draw_figures(groups, varied, out, notes)
    design_lines: list[str] = []
    design_figs: list[Path] = []
    if (study_dir / COVERAGE_FILE).is_file():
        design_lines, design_figs, why = frontier_section(study_dir, out,
                                                          {g.point_id for g in groups})
        if why:
            skipped["frontier"] = why
    ok_groups = [g for g in groups if g.v("efficiency").size]

    lines = _head_section(study_dir, info, groups, varied)
    rep = _reproduce_line(ok_groups[0]) if ok_groups and not yield_lines else ""
    if rep:
        lines += [rep, ""]
    lines += yield_lines
    lines += design_lines
    trends: dict = {}
    if not yield_lines:
        lines += paper_sections(ok_groups)
        tl, trends = _trend_section(ok_groups, varied)
        lines += tl
        lines += _grid_section(ok_groups, varied)
    lines += ["## Figures", ""]
    for n in drawn:
        lines += [f"![{n}]({n}.png)", "", f"*{n}.png*: {FIGURES[n]}", ""]
    if skipped:
        lines += ["Not drawn:", ""] + [f"- {n}: {r}" for n, r in skipped.items()] + [""]
    lines += ["## Results per grid point", "", "Efficiency: Sayres 2021 Eq. 11 (replaced targets "
              "counted once); convergence: share of robots home after the first planner run; "
              "fold time: steps x step / speed; tau_pg: kernel time of the final planner run; "
              "tau_sr: all runs.", ""]
    lines += _points_table(groups, varied)
    lines.append("")
    if notes:
        lines += ["## Notes", ""] + [f"- {n}" for n in notes] + [""]
    md = replace_atomically(out / REPORT_MD,
                            lambda tmp: tmp.write_text("\n".join(lines), encoding="utf-8"))
    return Report(md, yield_figs + design_figs + [out / f"{n}.png" for n in drawn], skipped,
                  trends, notes)
