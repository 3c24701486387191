"""The yield figures: completeness against density per design, and the yield frontier.

:func:`draw_completeness`: one panel per catalogue kind (uniform, clustered), x the
science target density (log), y the completeness (targets kept / targets within reach),
one line per design (mean over trials, bars from the lowest to the highest trial); with
densities per robot, the grey dotted line 1 / density is what an array reaches when every
robot takes a target. :func:`draw_yield_frontier`: at one reference density (uniform
catalogue), completeness (top) and targets per hour (bottom) of each design against its
robot count, pitch and arm ratio, and targets per hour per robot (bottom: the array's
targets per hour divided by its robots, so that arrays of any size compare); in the
robot-count panels the Pareto line joins the designs that no design with fewer (or as
many) robots beats. matplotlib's Agg canvas (no
pyplot state), written atomically. Units: mm, s.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from rfp_twin.twin.studies.store import replace_atomically

__all__ = ["COMPLETENESS_PNG", "FRONTIER_PNG", "draw_completeness", "draw_yield_frontier"]

COMPLETENESS_PNG = "yield_completeness.png"
FRONTIER_PNG = "yield_frontier.png"
KINDS = ("uniform", "clustered")
MARKERS = ("o", "s", "D", "^", "v", "P", "X", "h", "<", ">")
UNIT_TEXT = {"robot": "science targets per robot (per hexagonal cell of the pitch)",
             "patrol": "science targets per robot patrol area",
             "deg2": "science targets per deg$^2$"}


def _figure(w: float, h: float):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(w, h), dpi=120)
    FigureCanvasAgg(fig)
    return fig


def _styles(points) -> dict:
    """{design_id: (colour, marker)}, in the order of ``points``."""
    import matplotlib

    ids = list(dict.fromkeys(p.design_id for p in points))
    cmap = matplotlib.colormaps["tab10"]
    return {d: (cmap(i % 10), MARKERS[i % len(MARKERS)]) for i, d in enumerate(ids)}


def draw_completeness(points: list, path: Path) -> Path:
    """Completeness against density, one line per design (module docstring); returns ``path``."""
    kinds = [k for k in KINDS if any(p.catalogue == k for p in points)]
    unit = points[0].params.get("density_unit") or "robot"
    styles = _styles(points)
    n_leg = math.ceil((len(styles) + (unit == "robot")) / 2)
    height = 5.0 + 0.22 * n_leg                              # in
    fig = _figure(6.2 * len(kinds) + 0.4, height)
    axes = fig.subplots(1, len(kinds), squeeze=False, sharey=True)[0]
    dens = np.array(sorted({p.density for p in points}))
    for ax, kind in zip(axes, kinds):
        for did, (colour, marker) in styles.items():
            ps = sorted((p for p in points if p.design_id == did and p.catalogue == kind),
                        key=lambda p: p.density)
            ps = [p for p in ps if math.isfinite(p.mean("completeness"))]
            if not ps:
                continue
            x = np.array([p.density for p in ps])
            y = np.array([p.mean("completeness") for p in ps])
            lo = y - np.array([p.min("completeness") for p in ps])
            hi = np.array([p.values["completeness"].max() for p in ps]) - y
            ax.errorbar(x, y, yerr=[lo, hi], color=colour, marker=marker, ms=5, lw=1.5,
                        capsize=2.5, label=ps[0].label)
        if unit == "robot" and dens.size:
            xs = np.geomspace(dens.min(), dens.max(), 100)
            ax.plot(xs, np.minimum(1.0, 1.0 / xs), ls=":", color="0.45", lw=1.2,
                    label="1 / density (every robot on a target)")
        ax.set_xscale("log")
        ax.set_xticks(dens)
        ax.set_xticklabels([f"{d:g}" for d in dens])
        ax.minorticks_off()
        ax.set_ylim(0.0, 1.02)
        ax.grid(True, alpha=0.3)
        ax.set_xlabel(f"density: {UNIT_TEXT.get(unit, unit)}")
        ax.set_title(f"{kind} catalogue" + (" (Poisson)" if kind == "uniform"
                                            else " (Thomas process)"), fontsize=11)
    axes[0].set_ylabel("completeness: targets observed / targets within reach")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=2, fontsize=8.5, frameon=False)
    fig.subplots_adjust(left=0.07, right=0.98, top=1 - 0.75 / height, wspace=0.06,
                        bottom=(0.75 + 0.22 * n_leg) / height)
    fig.suptitle("Science completeness per pointing against target density (assign + "
                 "collision-free plan, every assigned target kept)", fontsize=11)
    replace_atomically(path, lambda tmp: fig.savefig(tmp, format="png"))
    return path


def _pareto_fewer(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Which points no other beats with fewer or as many robots (``x``) and more ``y``."""
    ok = np.isfinite(x) & np.isfinite(y)
    mask = ok.copy()
    for i in np.flatnonzero(ok):
        better = ok & (x <= x[i]) & (y >= y[i]) & ((x < x[i]) | (y > y[i]))
        mask[i] = not better.any()
    return mask


def draw_yield_frontier(points: list, path: Path, density: float) -> Path:
    """Completeness and targets per hour per robot at ``density`` (uniform catalogue) against robot
    count, pitch and arm ratio (module docstring); returns ``path``."""
    sel = [p for p in points if p.catalogue == "uniform" and abs(p.density - density) < 1e-12]
    if not sel:
        sel = [p for p in points if abs(p.density - density) < 1e-12]
    unit = points[0].params.get("density_unit") or "robot"
    styles = _styles(points)
    n_leg = math.ceil((len({p.design_id for p in sel}) + 1) / 3)
    height = 7.6 + 0.22 * n_leg                              # in
    fig = _figure(15.0, height)
    axes = fig.subplots(2, 3)
    xs = (("n_robots", "robots in the array"), ("pitch_mm", "pitch (mm)"),
          ("arm_ratio", "arm ratio q = alpha / beta"))
    ys = (("completeness", "completeness at this density"),
          ("targets_per_hour", "targets per hour per robot"))
    for r, (ycol, ylabel) in enumerate(ys):
        for c, (xcol, xlabel) in enumerate(xs):
            ax = axes[r][c]
            x = np.array([float(p.params[xcol]) for p in sel])
            y = np.array([p.mean(ycol) for p in sel])
            if ycol == "targets_per_hour":
                y = y / np.array([float(p.params["n_robots"]) for p in sel])
            for p, xi, yi in zip(sel, x, y):
                colour, marker = styles[p.design_id]
                ax.plot([xi], [yi], marker=marker, color=colour, ms=8, ls="none",
                        label=p.label)
            if xcol == "n_robots" and x.size:
                on = _pareto_fewer(x, y)
                order = np.argsort(x[on])
                ax.step(x[on][order], y[on][order], where="post", color="0.2", lw=1.0,
                        ls="--", label="Pareto: no design beats it with fewer robots")
            ax.set_xlabel(xlabel)
            ax.set_ylabel(ylabel)
            ax.grid(True, alpha=0.3)
            if ycol == "completeness":
                ax.set_ylim(0.0, 1.02)
            elif np.isfinite(y).any():
                ax.set_ylim(0.0, 1.1 * float(np.nanmax(y)))
    handles, labels = axes[1][0].get_legend_handles_labels()
    seen = dict(zip(labels, handles))
    fig.legend(list(seen.values()), list(seen), loc="lower center", ncol=3, fontsize=8.5,
               frameon=False)
    fig.subplots_adjust(left=0.05, right=0.99, top=1 - 0.5 / height, hspace=0.28, wspace=0.22,
                        bottom=(0.75 + 0.22 * n_leg) / height)
    exp = sorted({p.params.get("exposure_s") for p in sel if p.params.get("exposure_s")})
    fig.suptitle(f"Yield frontier at {density:g} {UNIT_TEXT.get(unit, unit)} (uniform "
                 f"catalogue; targets per hour with {', '.join(f'{e:g}' for e in exp)} s "
                 "exposures)", fontsize=11)
    replace_atomically(path, lambda tmp: fig.savefig(tmp, format="png"))
    return path
