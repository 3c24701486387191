"""Study reports: markdown and matplotlib figures in the style of Sayres 2021 Figs. 10-18.

:func:`write_report` reads a study folder (``results/`` written by
:func:`twin.studies.run_study`, plus ``study.toml``) and writes ``report/report.md`` and
PNG figures. Which figures are drawn depends on what the study varies:

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
================================  ====================================  ===================

Lines follow the paper: MC blue solid, GC red dashed; box plots have whiskers at 1.5 IQR
and outliers as diamonds; grid-size plots shade the 95 % confidence interval of the mean
(Student t). Other parameters that vary (e.g. step in a buffer plot) become extra lines,
in lighter or darker shades of the algorithm's colour. Trials that failed (``status =
error``, e.g. no clear random targets in a very dense array) are counted, not averaged.

When the study has the conditions of the paper's Simulation 1 (547-robot hex grid, 7.4 /
15 mm arms, 22.4 mm pitch, 0.1 deg, reverse with target replacement), the report puts
the values the paper states for Figs. 10, 11, 13 and 14 beside ours; Table 3 rows are
compared wherever the study has their (algorithm, buffer, step) on that grid.
"""
from __future__ import annotations

import math
import os
import sys
from collections import defaultdict
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from models.errors import RfpError
from twin.studies import (PARAM_COLUMNS, RESULTS, STUDY_COPY, StudyError, parse_study,
                          read_results)

__all__ = ["Report", "write_report", "load_groups", "Group", "PAPER_FIG10", "PAPER_FIG11",
           "PAPER_FOLD", "PAPER_TABLE3", "FIGURES"]

REPORT_DIR = "report"
REPORT_MD = "report.md"

#: Figure files and captions.
FIGURES = {
    "fig10_efficiency_mean": "Mean efficiency vs collision buffer (Sayres 2021 Fig. 10).",
    "fig11_efficiency_min": "Lowest efficiency seen vs collision buffer (Fig. 11).",
    "fig12_efficiency_box": "Efficiency distribution vs collision buffer; whiskers 1.5 IQR, "
                            "outliers as diamonds (Fig. 12).",
    "fig13_fold_time_mean": "Mean fold time vs collision buffer (Fig. 13).",
    "fig14_fold_time_box": "Fold time distribution vs collision buffer (Fig. 14).",
    "fig15_efficiency_vs_step": "Mean efficiency vs step size, one line per buffer (Fig. 15).",
    "fig16_runtime_vs_step": "Mean runtimes tau_pg (one converging planner run) and tau_sr "
                             "(with target replacement) vs step size; points with mean "
                             "efficiency > 0.9 only (Fig. 16).",
    "fig17_efficiency_vs_grid": "Mean efficiency vs grid size, shaded 95 % CI of the mean "
                                "(Fig. 17).",
    "fig18_runtime_vs_grid": "Mean runtimes vs grid size, shaded 95 % CI of the mean (Fig. 18).",
    "feasibility_map": "Feasibility map for denser arrays: mean efficiency over (pitch / "
                       "reach, buffer), counting robots still deadlocked after the last "
                       "resolution round as lost targets (equal to Eq. 11 when every trial "
                       "converges); outlined: mean >= 0.99 with no failed, unresolved or "
                       "colliding trial; hatched: every trial failed (folded state collides, "
                       "or no clear random targets).",
}

# -- the paper's numbers (Sayres et al. 2021, text of Sect. 5.3-5.4 and Table 3) -------------
#: Conditions of Simulation 1 (Table 1).
SIM1_CONDITIONS = {"layout": "hex", "n_robots": 547, "pitch_mm": 22.4, "alpha_length_mm": 7.4,
                   "beta_length_mm": 15.0, "fold_alpha_deg": 10.0, "fold_beta_deg": 170.0,
                   "step_deg": 0.1, "resolution": "replace", "direction": "reverse"}
#: Fig. 10, mean efficiency: (relation, value) per (algorithm, buffer) the text states.
#: "GC mean efficiency is > 0.998 for sigma < 2 mm. MC mean efficiency is > 0.998 for
#: sigma < 3 mm"; "at 3.5 mm mean efficiencies of 0.993 and 0.968 (MC, GC)".
PAPER_FIG10 = {
    **{("greedy", b): (">", 0.998) for b in (1.5, 1.75)},
    ("greedy", 3.5): ("=", 0.968),
    **{("markov", b): (">", 0.998) for b in (1.5, 1.75, 2.0, 2.25, 2.5, 2.75)},
    ("markov", 3.5): ("=", 0.993),
}
#: Fig. 11, lowest efficiency: "> 0.98 for sigma <= 2 mm"; "around 0.92 (GC), 0.97 (MC)"
#: at the largest buffer.
PAPER_FIG11 = {
    **{(a, b): (">", 0.98) for a in ("greedy", "markov") for b in (1.5, 1.75, 2.0)},
    ("greedy", 3.5): ("~", 0.92),
    ("markov", 3.5): ("~", 0.97),
}
#: Figs. 13-14 and Table 3, fold time s: GC "total reconfiguration < 30 s" (fold < 15 s);
#: MC "closer to 45 s for the lower half of sigma, nearing a minute for the upper half"
#: (medians, Fig. 14; fold = half); Table 3 at 3.5 mm / 0.1 deg: 13.17 (GC), 27.90 (MC).
PAPER_FOLD = {
    **{("greedy", b): ("<", 15.0) for b in (1.5, 1.75, 2.0, 2.25, 2.5, 2.75, 3.0, 3.25)},
    ("greedy", 3.5): ("=", 13.17),
    **{("markov", b): ("~", 22.5) for b in (1.5, 1.75, 2.0, 2.25)},
    **{("markov", b): ("~", 30.0) for b in (2.75, 3.0, 3.25)},
    ("markov", 3.5): ("=", 27.90),
}
#: Table 3: (algorithm, buffer, step) -> (tau_pg s, tau_sr s, fold s, efficiency); kaiju
#: 0.5.0 on one thread of a 2.9 GHz i9, 547 robots.
PAPER_TABLE3 = {
    ("greedy", 1.5, 1.0): (1.10, 2.10, 12.32, 0.9980),
    ("greedy", 2.5, 0.25): (4.34, 14.67, 12.55, 0.9918),
    ("greedy", 3.5, 0.1): (11.32, 107.11, 13.17, 0.9688),
    ("markov", 1.5, 1.0): (2.14, 2.55, 22.94, 0.9997),
    ("markov", 2.5, 0.25): (8.74, 14.71, 24.29, 0.9987),
    ("markov", 3.5, 0.1): (24.04, 105.82, 27.90, 0.9925),
}

#: Parameters that define a series (the resolved grid keys minus derived ones).
SERIES_PARAMS = ("preset", "layout", "n_robots", "pitch_mm", "alpha_length_mm",
                 "beta_length_mm", "fold_alpha_deg", "fold_beta_deg", "buffer_mm", "step_deg",
                 "greed", "phobia", "resolution", "direction", "max_rounds")
SHORT = {"preset": "", "layout": "", "n_robots": "n", "pitch_mm": "pitch",
         "alpha_length_mm": "l_a", "beta_length_mm": "l_b", "fold_alpha_deg": "fold a",
         "fold_beta_deg": "fold b", "buffer_mm": "sigma",
         "step_deg": "step", "greed": "greed", "phobia": "phobia", "resolution": "resolve",
         "direction": "", "max_rounds": "rounds"}
ALG_SHORT = {"greedy": "GC", "markov": "MC", "apf": "APF", "capf": "CAPF"}
ALG_STYLE = {"markov": dict(color="tab:blue", linestyle="-", cmap="Blues"),
             "greedy": dict(color="tab:red", linestyle="--", cmap="Reds"),
             "capf": dict(color="tab:green", linestyle="-.", cmap="Greens"),
             "apf": dict(color="tab:purple", linestyle=":", cmap="Purples")}
ALG_ORDER = ("markov", "greedy", "capf", "apf")   # the paper's panels: MC first (top), GC second
METRICS = ("efficiency", "convergence", "fold_time_s", "tau_pg_s", "tau_sr_s", "n_replaced",
           "rounds", "wall_s")
#: Mean efficiency at which a feasibility-map cell counts as feasible.
FEASIBLE_EFFICIENCY = 0.99
#: Lower end of the feasibility map's colour scale.
MAP_VMIN = 0.9
#: Most series (lines / box groups) one figure draws.
MAX_SERIES = 12


# =====================================================================================
# Data: one Group per grid point
# =====================================================================================
@dataclass
class Group:
    """All trials of one grid point."""

    point_id: str
    params: dict
    n: int = 0                 # trials (rows)
    n_error: int = 0
    n_deadlocked: int = 0      # trials left with deadlocked robots
    n_checked: int = 0
    n_collision_trials: int = 0
    collisions: int = 0
    values: dict = field(default_factory=dict)   # metric -> (k,) array, non-error trials
    errors: list = field(default_factory=list)

    @property
    def alg(self) -> str:
        return self.params["algorithm"]

    @property
    def pitch_over_reach(self) -> float:
        return self.params["pitch_mm"] / (self.params["alpha_length_mm"]
                                          + self.params["beta_length_mm"])

    def v(self, metric: str) -> np.ndarray:
        return self.values.get(metric, np.empty(0))

    def mean(self, metric: str) -> float:
        x = self.v(metric)
        return float(np.mean(x)) if x.size else math.nan

    def min(self, metric: str) -> float:
        x = self.v(metric)
        return float(np.min(x)) if x.size else math.nan

    def ci95(self, metric: str) -> tuple[float, float]:
        """95 % confidence interval of the mean (Student t); NaN with fewer than 2 trials."""
        x = self.v(metric)
        if x.size < 2:
            return math.nan, math.nan
        from scipy.stats import t

        half = float(t.ppf(0.975, x.size - 1) * np.std(x, ddof=1) / math.sqrt(x.size))
        m = float(np.mean(x))
        return m - half, m + half


def load_groups(study_dir: str | Path, all_points: bool = False) -> tuple[list[Group], dict]:
    """Rows of a study folder grouped by grid point.

    Returns (groups, info); info holds the parsed study (or None), the number of rows
    read and of rows left out because their point is not in ``study.toml``.
    """
    study_dir = Path(study_dir)
    table = read_results(study_dir)
    info: dict = {"study": None, "rows": table.num_rows, "ignored_rows": 0, "note": ""}
    copy = study_dir / STUDY_COPY
    keep: set[str] | None = None
    if copy.is_file():
        try:
            info["study"] = parse_study(copy.read_text(encoding="utf-8"), source=str(copy),
                                        base_dir=study_dir, default_name=study_dir.name)
            keep = {p.point_id for p in info["study"].points}
        except RfpError as exc:
            info["note"] = f"study.toml could not be read ({exc}); every row is reported."
    cols = table.to_pydict()
    n = table.num_rows
    workers = {w for w in cols["worker"] if w}
    info["worker_processes"] = len(workers)
    info["hosts"] = sorted({w.rsplit(":", 1)[0] for w in workers})
    by_point: dict[str, list[int]] = defaultdict(list)
    for i in range(n):
        by_point[cols["point_id"][i]].append(i)
    groups = []
    for pid, idx in by_point.items():
        if keep is not None and not all_points and pid not in keep:
            info["ignored_rows"] += len(idx)
            continue
        first = idx[0]
        g = Group(pid, {k: cols[k][first] for k in PARAM_COLUMNS})
        g.n = len(idx)
        ok = [i for i in idx if cols["status"][i] != "error"]
        g.n_error = g.n - len(ok)
        g.errors = sorted({cols["error"][i] for i in idx if cols["status"][i] == "error"})
        g.n_deadlocked = sum(cols["status"][i] == "deadlocked" for i in idx)
        for m in METRICS:
            g.values[m] = np.array([cols[m][i] for i in ok if cols[m][i] is not None], dtype=float)
        # targets kept: Eq. 11, with robots still deadlocked after the last round counted lost
        g.values["kept"] = np.array([cols["efficiency"][i] - cols["n_deadlocked"][i]
                                     / max(1, cols["n_robots"][i]) for i in ok
                                     if cols["efficiency"][i] is not None], dtype=float)
        checked = [i for i in ok if cols["checked"][i] and cols["collisions"][i] is not None]
        g.n_checked = len(checked)
        g.collisions = int(sum(cols["collisions"][i] for i in checked))
        g.n_collision_trials = sum(cols["collisions"][i] > 0 for i in checked)
        g.values["trial"] = np.array([cols["trial"][i] for i in ok], dtype=float)
        g.values["seed"] = np.array([cols["seed"][i] for i in ok], dtype=np.int64)
        groups.append(g)
    groups.sort(key=lambda g: tuple(_sort_key(g.params[k]) for k in SERIES_PARAMS)
                + (ALG_ORDER.index(g.alg),))
    return groups, info


def _sort_key(v):
    return (0, v, "") if isinstance(v, (int, float)) else (1, 0, str(v))


def varied_params(groups: list[Group]) -> list[str]:
    """Series parameters with more than one value (greed / phobia over MC points only)."""
    out = []
    for k in SERIES_PARAMS:
        gs = [g for g in groups if g.alg == "markov"] if k in ("greed", "phobia") else groups
        if len({g.params[k] for g in gs}) > 1:
            out.append(k)
    return out


def _fmt_val(k: str, v) -> str:
    if isinstance(v, float):
        return f"{v:g}"
    return str(v)


def _series(groups: list[Group], x: str, varied: list[str], extra_exclude=()) -> dict:
    """{(alg, slice): [groups sorted by x]}; slice = values of the other varied params."""
    others = [k for k in varied if k not in (x, "algorithm", *extra_exclude)]
    out: dict = defaultdict(list)
    for g in groups:
        sl = tuple((k, g.params[k]) for k in others
                   if not (g.alg == "greedy" and k in ("greed", "phobia")))
        out[(g.alg, sl)].append(g)
    xkey = (lambda g: g.pitch_over_reach) if x == "pitch_over_reach" else (lambda g: g.params[x])
    for k in out:
        out[k].sort(key=xkey)
    order = sorted(out, key=lambda s: (ALG_ORDER.index(s[0]),
                                       tuple(_sort_key(v) for _, v in s[1])))
    return {k: out[k] for k in order}


def _label(alg: str, sl: tuple) -> str:
    parts = [ALG_SHORT.get(alg, alg)]
    for k, v in sl:
        short = SHORT.get(k, k)
        parts.append(f"{short} {_fmt_val(k, v)}".strip())
    return ", ".join(parts)


def _styles(series: dict) -> dict:
    """Colour / line style per series: the algorithm's colour, shaded per slice."""
    import matplotlib

    per_alg: dict = defaultdict(list)
    for key in series:
        per_alg[key[0]].append(key)
    out = {}
    markers = "osD^v<>ph*X"
    for alg, keys in per_alg.items():
        st = ALG_STYLE.get(alg, dict(color="k", linestyle="-", cmap="Greys"))
        cmap = matplotlib.colormaps[st["cmap"]]
        for i, key in enumerate(keys):
            color = st["color"] if len(keys) == 1 else cmap(0.4 + 0.55 * i / max(1, len(keys) - 1))
            out[key] = dict(color=color, linestyle=st["linestyle"],
                            marker=markers[i % len(markers)])
    return out


# =====================================================================================
# Figures
# =====================================================================================
def _setup_mpl():
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    plt.rcParams.update({
        "font.family": "serif", "font.size": 10, "axes.labelsize": 11,
        "xtick.direction": "in", "ytick.direction": "in", "xtick.top": True,
        "ytick.right": True, "axes.grid": True, "grid.alpha": 0.25, "legend.fontsize": 8,
        "legend.frameon": False, "savefig.dpi": 130, "figure.dpi": 100,
    })
    return plt


def _save(plt, fig, path: Path) -> None:
    fig.tight_layout()
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.tmp.png")
    fig.savefig(tmp)
    plt.close(fig)
    os.replace(tmp, path)


def _limit(series: dict, notes: list, name: str) -> dict:
    """At most MAX_SERIES series, shared evenly between the algorithms."""
    if len(series) <= MAX_SERIES:
        return series
    algs = sorted({k[0] for k in series}, key=ALG_ORDER.index)
    per = max(1, MAX_SERIES // len(algs))
    keep = {}
    for alg in algs:
        keep.update(list((k, v) for k, v in series.items() if k[0] == alg)[:per])
    notes.append(f"{name}: {len(series)} series; the first {per} of each algorithm are drawn.")
    return {k: v for k, v in series.items() if k in keep}


def _legend(ax, n: int) -> None:
    """Legend inside for a few series, outside on the right for many."""
    if n <= 4:
        ax.legend(loc="best")
    else:
        ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0)


def _line_plot(plt, series, styles, metric, stat, xname, xlabel, ylabel, path, *,
               refline=None, paper=None, ci=False, logy=False, title=None):
    fig, ax = plt.subplots(figsize=(6.0 if len(series) <= 4 else 8.5, 4.0))
    for key, gs in series.items():
        xs = np.array([g.pitch_over_reach if xname == "pitch_over_reach" else g.params[xname]
                       for g in gs], dtype=float)
        if stat == "mean":
            ys = np.array([g.mean(metric) for g in gs])
        else:
            ys = np.array([g.min(metric) for g in gs])
        st = styles[key]
        ax.plot(xs, ys, color=st["color"], linestyle=st["linestyle"], marker=st["marker"],
                markersize=4, label=_label(*key))
        if ci:
            lo_hi = np.array([g.ci95(metric) for g in gs])
            ax.fill_between(xs, lo_hi[:, 0], lo_hi[:, 1], color=st["color"], alpha=0.18,
                            linewidth=0)
    if refline is not None:
        ax.axhline(refline[0], color="0.5", linewidth=0.8, linestyle=":", label=refline[1])
    if paper:
        first = True
        for (alg, x), (rel, val) in sorted(paper.items()):
            if not any(k[0] == alg for k in series):
                continue
            mk = {"=": "*", "~": "*", ">": "^", "<": "v"}[rel]
            ax.plot([x], [val], linestyle="none", marker=mk, markersize=8,
                    markerfacecolor="none", color=ALG_STYLE[alg]["color"],
                    label="paper (text: * value, ^ lower / v upper bound)" if first else None)
            first = False
    if logy:
        ax.set_yscale("log")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    if title:
        ax.set_title(title, fontsize=10)
    _legend(ax, len(series) + bool(paper) + (refline is not None))
    _save(plt, fig, path)


def _grouped_boxes(ax, series, styles, metric, xname, xvals):
    k = len(series)
    width = 0.8 / max(1, k)
    pos_of = {x: i for i, x in enumerate(xvals)}
    for j, (key, gs) in enumerate(series.items()):
        st = styles[key]
        data, pos = [], []
        for g in gs:
            x = g.params[xname]
            vals = g.v(metric)
            if vals.size:
                data.append(vals)
                pos.append(pos_of[x] - 0.4 + width * (j + 0.5))
        if not data:
            continue
        bp = ax.boxplot(data, positions=pos, widths=width * 0.85, whis=1.5, patch_artist=True,
                        manage_ticks=False,
                        flierprops=dict(marker="D", markersize=3, markerfacecolor=st["color"],
                                        markeredgecolor=st["color"], alpha=0.7),
                        medianprops=dict(color="k", linewidth=1.0))
        for box in bp["boxes"]:
            box.set_facecolor(st["color"])
            box.set_alpha(0.45)
        ax.plot([], [], color=st["color"], linewidth=6, alpha=0.45, label=_label(*key))
    ax.set_xticks(range(len(xvals)))
    ax.set_xticklabels([_fmt_val(xname, x) for x in xvals])
    ax.set_xlim(-0.6, len(xvals) - 0.4)


def _box_figure(plt, groups, varied, metric, ylabel, path, notes, per_alg_panels: bool):
    xvals = sorted({g.params["buffer_mm"] for g in groups})
    series = _limit(_series(groups, "buffer_mm", varied), notes, path.stem)
    styles = _styles(series)
    algs = [a for a in ALG_ORDER if any(k[0] == a for k in series)]
    wide = 6.5 if len(series) <= 4 else 9.0
    if per_alg_panels and len(algs) > 1:
        fig, axes = plt.subplots(len(algs), 1, figsize=(wide, 2.8 * len(algs)), sharex=True)
        for ax, alg in zip(axes, algs):
            sub = {k: v for k, v in series.items() if k[0] == alg}
            _grouped_boxes(ax, sub, styles, metric, "buffer_mm", xvals)
            ax.set_ylabel(f"{ylabel} ({ALG_SHORT[alg]})")
            _legend(ax, len(series))
        axes[-1].set_xlabel("collision buffer sigma_cb (mm)")
    else:
        fig, ax = plt.subplots(figsize=(wide, 4.0))
        _grouped_boxes(ax, series, styles, metric, "buffer_mm", xvals)
        ax.set_ylabel(ylabel)
        ax.set_xlabel("collision buffer sigma_cb (mm)")
        _legend(ax, len(series))
    _save(plt, fig, path)


def _step_figures(plt, groups, varied, fig_dir, notes) -> list[str]:
    import matplotlib.ticker  # noqa: F401 (matplotlib.ticker below)
    import matplotlib
    series = _series(groups, "step_deg", varied)
    algs = [a for a in ("greedy", "markov") if any(k[0] == a for k in series)]  # GC left
    styles = _styles(series)
    # Fig. 15: efficiency vs step, one panel per algorithm
    fig, axes = plt.subplots(1, len(algs), figsize=(5.0 * len(algs), 3.8), squeeze=False,
                             sharey=True)
    for ax, alg in zip(axes[0], algs):
        sub = _limit({k: v for k, v in series.items() if k[0] == alg}, notes,
                     f"fig15 ({ALG_SHORT[alg]})")
        for key, gs in sub.items():
            st = styles[key]
            ax.plot([g.params["step_deg"] for g in gs], [g.mean("efficiency") for g in gs],
                    color=st["color"], linestyle=st["linestyle"], marker=st["marker"],
                    markersize=4, label=_label(*key))
        ax.set_title(ALG_SHORT[alg], fontsize=10)
        ax.set_xlabel("step size Delta_theta (deg)")
        ax.legend(loc="lower left")
    axes[0][0].set_ylabel("mean efficiency")
    _save(plt, fig, fig_dir / "fig15_efficiency_vs_step.png")
    # Fig. 16: tau_pg and tau_sr vs step, rows = algorithms, points with mean eff > 0.9
    fig, axes = plt.subplots(len(algs), 2, figsize=(9.0, 3.3 * len(algs)), squeeze=False)
    for r, alg in enumerate(algs):
        sub = _limit({k: v for k, v in series.items() if k[0] == alg}, notes,
                     f"fig16 ({ALG_SHORT[alg]})")
        for c, (metric, name) in enumerate((("tau_pg_s", "tau_pg"), ("tau_sr_s", "tau_sr"))):
            ax = axes[r][c]
            for key, gs in sub.items():
                keep = [g for g in gs if g.mean("efficiency") > 0.9 and g.v(metric).size]
                if not keep:
                    continue
                st = styles[key]
                ax.plot([g.params["step_deg"] for g in keep], [g.mean(metric) for g in keep],
                        color=st["color"], linestyle=st["linestyle"], marker=st["marker"],
                        markersize=4, label=_label(*key))
            ax.set_yscale("log")
            plain = matplotlib.ticker.FuncFormatter(lambda v, _: f"{v:g}")
            ax.yaxis.set_major_locator(matplotlib.ticker.LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
            ax.yaxis.set_major_formatter(plain)
            ax.yaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
            ax.set_title(f"{ALG_SHORT[alg]}: mean {name}", fontsize=10)
            ax.set_ylabel(f"{name} (s)")
            if r == len(algs) - 1:
                ax.set_xlabel("step size Delta_theta (deg)")
            if ax.lines:
                ax.legend(loc="best")
    _save(plt, fig, fig_dir / "fig16_runtime_vs_step.png")
    return ["fig15_efficiency_vs_step", "fig16_runtime_vs_step"]


def _grid_figures(plt, groups, varied, fig_dir, notes) -> list[str]:
    series = _limit(_series(groups, "n_robots", varied), notes, "fig17/18")
    styles = _styles(series)
    _line_plot(plt, series, styles, "efficiency", "mean", "n_robots", "number of robots",
               "mean efficiency", fig_dir / "fig17_efficiency_vs_grid.png", ci=True)
    fig, axes = plt.subplots(1, 2, figsize=(10.0, 3.8))
    for ax, (metric, name) in zip(axes, (("tau_pg_s", "tau_pg"), ("tau_sr_s", "tau_sr"))):
        for key, gs in series.items():
            st = styles[key]
            xs = np.array([g.params["n_robots"] for g in gs], dtype=float)
            ys = np.array([g.mean(metric) for g in gs])
            ci = np.array([g.ci95(metric) for g in gs])
            ax.plot(xs, ys, color=st["color"], linestyle=st["linestyle"], marker=st["marker"],
                    markersize=4, label=_label(*key))
            ax.fill_between(xs, ci[:, 0], ci[:, 1], color=st["color"], alpha=0.18, linewidth=0)
        ax.set_xlabel("number of robots")
        ax.set_ylabel(f"mean {name} (s)")
        ax.legend(loc="upper left")
    _save(plt, fig, fig_dir / "fig18_runtime_vs_grid.png")
    return ["fig17_efficiency_vs_grid", "fig18_runtime_vs_grid"]


def _feasibility_map(plt, groups, varied, fig_dir, notes) -> list[str]:
    import matplotlib
    from matplotlib.patches import Rectangle

    others = [k for k in varied if k not in ("pitch_mm", "alpha_length_mm", "beta_length_mm",
                                             "buffer_mm", "algorithm")]
    slices: dict = defaultdict(list)
    for g in groups:
        sl = tuple((k, g.params[k]) for k in others
                   if not (g.alg == "greedy" and k in ("greed", "phobia")))
        slices[(g.alg, sl)].append(g)
    keys = sorted(slices, key=lambda s: (ALG_ORDER.index(s[0]),
                                         tuple(_sort_key(v) for _, v in s[1])))
    if len(keys) > 8:
        notes.append(f"feasibility_map: {len(keys)} panels; the first 8 are drawn.")
        keys = keys[:8]
    ncol = min(2, len(keys))
    nrow = math.ceil(len(keys) / ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(5.4 * ncol + 1.0, 4.2 * nrow), squeeze=False,
                             layout="constrained")
    # the interesting range is near 1: colours span [MAP_VMIN, 1], lower values get the darkest
    cmap = matplotlib.colormaps["viridis"]
    norm = matplotlib.colors.Normalize(vmin=MAP_VMIN, vmax=1.0, clip=True)
    for ax, key in zip(axes.flat, keys):
        gs = slices[key]
        xs = sorted({round(g.pitch_over_reach, 6) for g in gs})
        ys = sorted({g.params["buffer_mm"] for g in gs})
        cell: dict = defaultdict(list)
        for g in gs:
            ij = (xs.index(round(g.pitch_over_reach, 6)), ys.index(g.params["buffer_mm"]))
            cell[ij].append(g)
        for (i, j), cg in cell.items():
            eff = np.concatenate([g.v("kept") for g in cg])
            n = sum(g.n for g in cg)
            n_err = sum(g.n_error for g in cg)
            n_dead = sum(g.n_deadlocked for g in cg)
            coll = sum(g.n_collision_trials for g in cg)
            if eff.size:
                m = float(eff.mean())
                ax.add_patch(Rectangle((i - 0.5, j - 0.5), 1, 1, color=cmap(norm(m))))
                txt = f"{m:.3f}"
                good = m >= FEASIBLE_EFFICIENCY and n_err == 0 and coll == 0 and n_dead == 0
                if good:
                    ax.add_patch(Rectangle((i - 0.46, j - 0.46), 0.92, 0.92, fill=False,
                                           edgecolor="white", linewidth=2.0))
                color = "k" if norm(m) > 0.6 else "w"
            else:
                ax.add_patch(Rectangle((i - 0.5, j - 0.5), 1, 1, facecolor="0.85",
                                       hatch="xx", edgecolor="0.6"))
                errs = " ".join(e for g in cg for e in g.errors)
                txt = ("fold collides" if "folded state" in errs else
                       "no targets" if "TargetError" in errs else "failed")
                color = "k"
            if n_err and eff.size:
                txt += f"\n{n_err}/{n} fail"
            if n_dead:
                txt += f"\n{n_dead}/{n} unresolved"
            if coll:
                txt += f"\n{coll} COLL"
            ax.text(i, j, txt, ha="center", va="center", fontsize=7, color=color)
        ax.set_xlim(-0.5, len(xs) - 0.5)
        ax.set_ylim(-0.5, len(ys) - 0.5)
        ax.set_xticks(range(len(xs)))
        ax.set_xticklabels([f"{x:.3g}" for x in xs])
        ax.set_yticks(range(len(ys)))
        ax.set_yticklabels([f"{y:g}" for y in ys])
        ax.set_xlabel("pitch / reach (reach = l_alpha + l_beta)")
        ax.set_ylabel("collision buffer sigma_cb (mm)")
        ax.set_title(_label(*key), fontsize=10)
        ax.grid(False)
    for ax in list(axes.flat)[len(keys):]:
        ax.set_visible(False)
    sm = matplotlib.cm.ScalarMappable(norm=norm, cmap=cmap)
    fig.colorbar(sm, ax=axes.ravel().tolist(), shrink=0.85, extend="min",
                 label="mean efficiency (unresolved robots lost)")
    fig.savefig(fig_dir / ".feasibility_map.tmp.png")
    plt.close(fig)
    os.replace(fig_dir / ".feasibility_map.tmp.png", fig_dir / "feasibility_map.png")
    return ["feasibility_map"]


# =====================================================================================
# Markdown
# =====================================================================================
@dataclass
class Report:
    markdown: Path
    figures: list          # [Path]
    skipped: dict          # figure -> reason
    trends: dict           # name -> bool
    notes: list


def _f(x, nd=4) -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "-"
    return f"{x:.{nd}f}"


def _is_sim1(g: Group) -> bool:
    p = g.params
    for k, v in SIM1_CONDITIONS.items():
        if p.get(k) is None:
            return False
        if isinstance(v, float):
            if abs(p[k] - v) > 1e-9:
                return False
        elif p[k] != v:
            return False
    return p["algorithm"] == "greedy" or (abs(p["greed"] - 0.9) < 1e-9
                                          and abs(p["phobia"] - 0.3) < 1e-9)


def _paper_cell(ref, ours: float, lo: float, hi: float) -> tuple[str, str]:
    """(paper text, agreement) for one reference value."""
    if ref is None:
        return "-", ""
    rel, val = ref
    text = {"=": f"{val:g}", "~": f"~{val:g}", ">": f"> {val:g}", "<": f"< {val:g}"}[rel]
    if not math.isfinite(ours):
        return text, ""
    if rel == ">":
        return text, "yes" if ours > val else "no"
    if rel == "<":
        return text, "yes" if ours < val else "no"
    diff = ours - val
    inside = math.isfinite(lo) and lo <= val <= hi
    return text, f"{diff:+.4f}" + (" (in 95 % CI)" if inside else "")


def _trend_section(groups, varied) -> tuple[list[str], dict]:
    lines, trends = [], {}
    if "buffer_mm" not in varied:
        return lines, trends
    series = _series(groups, "buffer_mm", varied)
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
        values = ", ".join(f"{g.params['buffer_mm']:g}: {_f(y)}" for g, y in zip(gs, ys))
        if len(ys) < 2:
            lines.append(f"| {_label(*key)} | {values} | - | - | - | - | - |")
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
        name = _label(*key)
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
            name = _label("MC >= GC", sl)
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
    for key, gs in _series(groups, "n_robots", varied).items():
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
            lines.append(f"| {_label(*key)} | {metric[:-2]} | {a:.4f} | {1000 * b:.4f} | "
                         f"{_f(r2, 3)} | {_f(min(eff))}-{_f(max(eff))} |")
    lines.append("")
    return lines


def _paper_sections(groups) -> list[str]:
    lines: list[str] = []
    sim1 = [g for g in groups if _is_sim1(g)]
    if sim1:
        lines += ["## Beside Sayres 2021 Simulation 1 (Figs. 10, 11, 13, 14)", "",
                  "Paper: 2000 trials per buffer and algorithm, kaiju 0.5.0. The paper prints "
                  "only some numbers in its text (the curves are figures); `-` where it states "
                  "none. Ours: mean [95 % CI], min, trials.", "",
                  "| alg | sigma mm | trials | mean eff. ours | 95 % CI | Fig. 10 paper | "
                  "agrees | min eff. ours | Fig. 11 paper | agrees | fold s ours (median) | "
                  "Figs. 13-14 paper | agrees |",
                  "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
        for g in sorted(sim1, key=lambda g: (ALG_ORDER.index(g.alg), g.params["buffer_mm"])):
            b = round(g.params["buffer_mm"], 4)
            m, (lo, hi), mn = g.mean("efficiency"), g.ci95("efficiency"), g.min("efficiency")
            p10, a10 = _paper_cell(PAPER_FIG10.get((g.alg, b)), m, lo, hi)
            p11, a11 = _paper_cell(PAPER_FIG11.get((g.alg, b)), mn, math.nan, math.nan)
            fold = g.v("fold_time_s")
            fm = float(np.mean(fold)) if fold.size else math.nan
            fmed = float(np.median(fold)) if fold.size else math.nan
            flo, fhi = g.ci95("fold_time_s")
            pf, af = _paper_cell(PAPER_FOLD.get((g.alg, b)), fm, flo, fhi)
            lines.append(f"| {ALG_SHORT[g.alg]} | {b:g} | {g.v('efficiency').size} | {_f(m)} | "
                         f"{_f(lo)}-{_f(hi)} | {p10} | {a10} | {_f(mn)} | {p11} | {a11} | "
                         f"{_f(fm, 2)} ({_f(fmed, 2)}) | {pf} | {af} |")
        lines += ["", "Fig. 14's MC values are medians read from the text (\"closer to 45 s for "
                  "the lower half ... nearing a minute for the upper half\" of total "
                  "reconfiguration = 2 x fold); 3.5 mm values are Table 3 means (same "
                  "conditions, Simulation 2).", ""]
    t3 = []
    for g in groups:
        p = g.params
        if not (p["layout"] == "hex" and p["n_robots"] == 547 and abs(p["pitch_mm"] - 22.4) < 1e-9
                and p["resolution"] == "replace"):
            continue
        ref = PAPER_TABLE3.get((g.alg, round(p["buffer_mm"], 4), round(p["step_deg"], 4)))
        if ref is None or (g.alg == "markov" and not _is_sim1_mc(p)):
            continue
        t3.append((g, ref))
    if t3:
        lines += ["## Beside Sayres 2021 Table 3", "",
                  "| alg | sigma mm | step deg | trials | tau_pg s ours | paper | tau_sr s ours | "
                  "paper | fold s ours | paper | efficiency ours | paper |",
                  "|---|---|---|---|---|---|---|---|---|---|---|---|"]
        for g, ref in t3:
            p = g.params
            lines.append(f"| {ALG_SHORT[g.alg]} | {p['buffer_mm']:g} | {p['step_deg']:g} | "
                         f"{g.v('efficiency').size} | {_f(g.mean('tau_pg_s'), 3)} | {ref[0]} | "
                         f"{_f(g.mean('tau_sr_s'), 3)} | {ref[1]} | "
                         f"{_f(g.mean('fold_time_s'), 2)} | {ref[2]} | "
                         f"{_f(g.mean('efficiency'))} | {ref[3]} |")
        lines += ["", "Paper times: kaiju 0.5.0 on one thread of a 2.9 GHz i9; ours: the numba "
                  "kernel time on a study worker (hosts under Trials; times grow when other "
                  "work shares the cores).", ""]
    return lines


def _is_sim1_mc(p) -> bool:
    return abs(p["greed"] - 0.9) < 1e-9 and abs(p["phobia"] - 0.3) < 1e-9


def _points_table(groups, varied) -> list[str]:
    cols = [k for k in varied if k != "algorithm"]
    head = (["alg"] + [SHORT.get(k) or k for k in cols]
            + ["trials", "errors", "mean eff.", "95 % CI", "min eff.", "std", "conv. 1st run",
               "fold s", "tau_pg s", "tau_sr s", "replaced", "rounds", "deadlocked left",
               "collisions (trials)"])
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for g in groups:
        e = g.v("efficiency")
        lo, hi = g.ci95("efficiency")
        row = [ALG_SHORT.get(g.alg, g.alg)] + [_fmt_val(k, g.params[k]) for k in cols] + [
            str(g.n), str(g.n_error), _f(g.mean("efficiency")), f"{_f(lo)}-{_f(hi)}",
            _f(g.min("efficiency")), _f(float(np.std(e, ddof=1)) if e.size > 1 else math.nan),
            _f(g.mean("convergence")), _f(g.mean("fold_time_s"), 2), _f(g.mean("tau_pg_s"), 3),
            _f(g.mean("tau_sr_s"), 3), _f(g.mean("n_replaced"), 2), _f(g.mean("rounds"), 2),
            str(g.n_deadlocked),
            f"{g.collisions} ({g.n_collision_trials}/{g.n_checked})" if g.n_checked
            else "not checked"]
        lines.append("| " + " | ".join(row) + " |")
    return lines


def _reproduce_line(g: Group) -> str:
    p = g.params
    if p["layout"] == "sdss-v-fps":
        lay = "sdss-v-fps"
    else:
        from models.layout import hex_rings
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
    return (f"The lowest-efficiency trial of the first point ({_label(g.alg, ())}, "
            f"efficiency {_f(float(eff[k]))}) replays with\n\n    {cmd}\n\n{note}").rstrip()


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
    fig_dir = out
    plt = _setup_mpl()
    varied = varied_params(groups)
    notes: list[str] = []
    if info["note"]:
        notes.append(info["note"])
    if info["ignored_rows"]:
        notes.append(f"{info['ignored_rows']} rows of grid points that are not in study.toml "
                     "were left out (use --all-points to include them).")
    drawn: list[str] = []
    skipped: dict[str, str] = {}
    ok_groups = [g for g in groups if g.v("efficiency").size]

    def skip(names, reason):
        for n in names:
            skipped[n] = reason

    buffer_figs = ["fig10_efficiency_mean", "fig11_efficiency_min", "fig12_efficiency_box",
                   "fig13_fold_time_mean", "fig14_fold_time_box"]
    if "buffer_mm" in varied and ok_groups:
        series = _limit(_series(ok_groups, "buffer_mm", varied), notes, "figs. 10-14")
        styles = _styles(series)
        n547 = {g.params["n_robots"] for g in ok_groups}
        ref = (0.998, "0.998 = one replacement in 547") if n547 == {547} else None
        paper10 = PAPER_FIG10 if all(_is_sim1(g) for g in ok_groups) else None
        paper11 = PAPER_FIG11 if paper10 else None
        paperf = PAPER_FOLD if paper10 else None
        xl = "collision buffer sigma_cb (mm)"
        _line_plot(plt, series, styles, "efficiency", "mean", "buffer_mm", xl, "mean efficiency",
                   fig_dir / "fig10_efficiency_mean.png", refline=ref, paper=paper10)
        _line_plot(plt, series, styles, "efficiency", "min", "buffer_mm", xl,
                   "lowest efficiency seen", fig_dir / "fig11_efficiency_min.png", paper=paper11)
        _box_figure(plt, ok_groups, varied, "efficiency", "efficiency",
                    fig_dir / "fig12_efficiency_box.png", notes, per_alg_panels=True)
        _line_plot(plt, series, styles, "fold_time_s", "mean", "buffer_mm", xl,
                   "mean fold time (s)", fig_dir / "fig13_fold_time_mean.png", paper=paperf)
        _box_figure(plt, ok_groups, varied, "fold_time_s", "fold time (s)",
                    fig_dir / "fig14_fold_time_box.png", notes, per_alg_panels=False)
        drawn += buffer_figs
    else:
        skip(buffer_figs, "buffer_mm has one value in this study")
    if "step_deg" in varied and ok_groups:
        drawn += _step_figures(plt, ok_groups, varied, fig_dir, notes)
    else:
        skip(["fig15_efficiency_vs_step", "fig16_runtime_vs_step"],
             "step_deg has one value in this study")
    if "n_robots" in varied and ok_groups:
        drawn += _grid_figures(plt, ok_groups, varied, fig_dir, notes)
    else:
        skip(["fig17_efficiency_vs_grid", "fig18_runtime_vs_grid"],
             "n_robots has one value in this study")
    if len({round(g.pitch_over_reach, 6) for g in groups}) > 1:
        drawn += _feasibility_map(plt, groups, varied, fig_dir, notes)
    else:
        skip(["feasibility_map"], "pitch / reach has one value in this study (vary pitch_mm "
             "or the arm lengths)")

    # ---- markdown
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
    rep = _reproduce_line(ok_groups[0]) if ok_groups else ""
    if rep:
        lines += [rep, ""]
    lines += _paper_sections(ok_groups)
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
    md = out / REPORT_MD
    tmp = out / f".{REPORT_MD}.{os.getpid()}.tmp"
    tmp.write_text("\n".join(lines), encoding="utf-8")
    os.replace(tmp, md)
    return Report(md, [fig_dir / f"{n}.png" for n in drawn], skipped, trends, notes)
