"""The figures of a study report (matplotlib, Agg), in the style of Sayres 2021 Figs. 10-18.

:func:`draw_figures` draws what the study varies (see :data:`FIGURES` and the table in
:mod:`rfp_twin.twin.studies.report`) and says why the others are not drawn. Lines follow the
paper: MC blue solid, GC red dashed; box plots have whiskers at 1.5 IQR and outliers as
diamonds; grid-size plots shade the 95 % confidence interval of the mean (Student t).
Other parameters that vary become extra lines in lighter or darker shades of the
algorithm's colour. Axes: buffer mm, step deg, times s.
"""
from __future__ import annotations

import math
from collections import defaultdict
from pathlib import Path

import numpy as np

from rfp_twin.twin.studies.groups import (ALG_ORDER, ALG_SHORT, Group, fmt_val, make_series,
                                 series_label)
from rfp_twin.twin.studies.paper import PAPER_FIG10, PAPER_FIG11, PAPER_FOLD, is_sim1
from rfp_twin.twin.studies.store import replace_atomically

__all__ = ["FIGURES", "draw_figures"]

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

#: Colour, line style and colour map (for shades) of each algorithm's lines.
ALG_STYLE = {"markov": dict(color="tab:blue", linestyle="-", cmap="Blues"),
             "greedy": dict(color="tab:red", linestyle="--", cmap="Reds"),
             "capf": dict(color="tab:green", linestyle="-.", cmap="Greens"),
             "apf": dict(color="tab:purple", linestyle=":", cmap="Purples")}
#: Mean efficiency at which a feasibility-map cell counts as feasible.
FEASIBLE_EFFICIENCY = 0.99
#: Lower end of the feasibility map's colour scale.
MAP_VMIN = 0.9
#: Most series (lines / box groups) one figure draws.
MAX_SERIES = 12

BUFFER_FIGURES = ["fig10_efficiency_mean", "fig11_efficiency_min", "fig12_efficiency_box",
                  "fig13_fold_time_mean", "fig14_fold_time_box"]


def draw_figures(groups: list[Group], varied: list[str], fig_dir: Path,
                 notes: list[str]) -> tuple[list[str], dict[str, str]]:
    """Draw into ``fig_dir`` every figure the varied parameters allow (``NAME.png``).

    ``notes`` gets a line for each figure that leaves series out. Returns (names drawn,
    {name: why not drawn})."""
    plt = _setup_mpl()
    drawn: list[str] = []
    skipped: dict[str, str] = {}
    ok_groups = [g for g in groups if g.v("efficiency").size]
    for names, axis, draw in (
            (BUFFER_FIGURES, "buffer_mm", _buffer_figures),
            (["fig15_efficiency_vs_step", "fig16_runtime_vs_step"], "step_deg", _step_figures),
            (["fig17_efficiency_vs_grid", "fig18_runtime_vs_grid"], "n_robots", _grid_figures)):
        if axis in varied and ok_groups:
            drawn += draw(plt, ok_groups, varied, fig_dir, notes)
        else:
            skipped.update((n, f"{axis} has one value in this study") for n in names)
    if len({round(g.pitch_over_reach, 6) for g in groups}) > 1:
        drawn += _feasibility_map(plt, groups, varied, fig_dir, notes)
    else:
        skipped["feasibility_map"] = ("pitch / reach has one value in this study (vary pitch_mm "
                                      "or the arm lengths)")
    return drawn, skipped


def _buffer_figures(plt, groups, varied, fig_dir, notes) -> list[str]:
    """Figs. 10-14: efficiency and fold time vs buffer (the paper's values beside them
    when every point has Simulation 1's conditions)."""
    series = _limit(make_series(groups, "buffer_mm", varied), notes, "figs. 10-14")
    styles = _styles(series)
    n547 = {g.params["n_robots"] for g in groups}
    ref = (0.998, "0.998 = one replacement in 547") if n547 == {547} else None
    sim1 = all(is_sim1(g) for g in groups)
    xl = "collision buffer sigma_cb (mm)"
    _line_plot(plt, series, styles, "efficiency", "mean", "buffer_mm", xl, "mean efficiency",
               fig_dir / "fig10_efficiency_mean.png", refline=ref,
               paper=PAPER_FIG10 if sim1 else None)
    _line_plot(plt, series, styles, "efficiency", "min", "buffer_mm", xl,
               "lowest efficiency seen", fig_dir / "fig11_efficiency_min.png",
               paper=PAPER_FIG11 if sim1 else None)
    _box_figure(plt, groups, varied, "efficiency", "efficiency",
                fig_dir / "fig12_efficiency_box.png", notes, per_alg_panels=True)
    _line_plot(plt, series, styles, "fold_time_s", "mean", "buffer_mm", xl,
               "mean fold time (s)", fig_dir / "fig13_fold_time_mean.png",
               paper=PAPER_FOLD if sim1 else None)
    _box_figure(plt, groups, varied, "fold_time_s", "fold time (s)",
                fig_dir / "fig14_fold_time_box.png", notes, per_alg_panels=False)
    return list(BUFFER_FIGURES)


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


def _save(plt, fig, path: Path, tight: bool = True) -> None:
    """Write ``fig`` to ``path`` (PNG, atomically) and close it."""
    if tight:
        fig.tight_layout()
    replace_atomically(path, lambda tmp: fig.savefig(tmp, format="png"))
    plt.close(fig)


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
                markersize=4, label=series_label(*key))
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
        ax.plot([], [], color=st["color"], linewidth=6, alpha=0.45, label=series_label(*key))
    ax.set_xticks(range(len(xvals)))
    ax.set_xticklabels([fmt_val(xname, x) for x in xvals])
    ax.set_xlim(-0.6, len(xvals) - 0.4)


def _box_figure(plt, groups, varied, metric, ylabel, path, notes, per_alg_panels: bool):
    xvals = sorted({g.params["buffer_mm"] for g in groups})
    series = _limit(make_series(groups, "buffer_mm", varied), notes, path.stem)
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
    series = make_series(groups, "step_deg", varied)
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
                    markersize=4, label=series_label(*key))
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
                        markersize=4, label=series_label(*key))
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
    series = _limit(make_series(groups, "n_robots", varied), notes, "fig17/18")
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
                    markersize=4, label=series_label(*key))
            ax.fill_between(xs, ci[:, 0], ci[:, 1], color=st["color"], alpha=0.18, linewidth=0)
        ax.set_xlabel("number of robots")
        ax.set_ylabel(f"mean {name} (s)")
        ax.legend(loc="upper left")
    _save(plt, fig, fig_dir / "fig18_runtime_vs_grid.png")
    return ["fig17_efficiency_vs_grid", "fig18_runtime_vs_grid"]


def _feasibility_map(plt, groups, varied, fig_dir, notes) -> list[str]:
    """One panel per algorithm and slice: mean targets kept over (pitch / reach, buffer)."""
    import matplotlib
    from matplotlib.patches import Rectangle

    slices = make_series(groups, "pitch_over_reach", varied, extra_exclude=(
        "pitch_mm", "alpha_length_mm", "beta_length_mm", "buffer_mm"))
    keys = list(slices)
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
        ax.set_title(series_label(*key), fontsize=10)
        ax.grid(False)
    for ax in list(axes.flat)[len(keys):]:
        ax.set_visible(False)
    sm = matplotlib.cm.ScalarMappable(norm=norm, cmap=cmap)
    fig.colorbar(sm, ax=axes.ravel().tolist(), shrink=0.85, extend="min",
                 label="mean efficiency (unresolved robots lost)")
    _save(plt, fig, fig_dir / "feasibility_map.png", tight=False)   # constrained layout
    return ["feasibility_map"]
