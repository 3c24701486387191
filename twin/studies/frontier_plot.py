"""The design frontier figure: coverage against feasibility, one marker per design point.

One row per robot family: targets kept (left panel) and fold time (middle, firmware-ready
when the study measured it) against the share of the focal plane reached by >= k
fibers, and a key (right). Marker shape: arm ratio q = alpha / beta; colour: collision
buffer; small filled: ``search`` (our resolver), large open ring: ``replace`` (Sayres
2021), so a design both resolve alike shows a filled marker in its ring; the two markers
of one design (the same targets) are joined by a grey line. Pareto frontiers are
staircases (solid: search, dashed: replace); their points carry short tags (``s1``,
``r1``, ...) that the key spells out as ``q, p/r, sigma`` (coincident points share a tag).
Designs of equal coverage (the same pitch / reach) are dodged sideways by :data:`DODGE`
of the panel's coverage range per (arm ratio, buffer) slot so that no marker hides
another; the report's table has the exact values. matplotlib's Agg canvas (no pyplot
state), written atomically. Units: s; coverage and kept in [0, 1].
"""
from __future__ import annotations

import math
from collections import defaultdict
from pathlib import Path

from rfp_twin.twin.studies.store import replace_atomically

__all__ = ["FRONTIER_PNG", "draw_frontier", "frontier_groups"]

FRONTIER_PNG = "frontier.png"
#: Marker per arm ratio (in increasing order); circles are kept for the resolver legend.
RATIO_MARKERS = ("v", "D", "^", "s", "P", "X", "h", "<")
#: Sideways dodge per (arm ratio, buffer) slot, as a share of the coverage range.
DODGE = 0.02
#: Line style and tag letter of each resolver's frontier.
FRONTIER_STYLE = {"search": dict(linestyle="-", color="black"),
                  "replace": dict(linestyle="--", color="0.35"),
                  "none": dict(linestyle=":", color="0.55")}
TAG = {"search": "s", "replace": "r", "none": "n"}


def _family_title(ds) -> str:
    p = ds[0].params
    lay = f"{p['n_rafts']} raft(s)" if p["layout"] == "raft" else p["layout"]
    name = ds[0].family or "all points"
    return f"{name}: {p['preset']} on {lay}, {p['n_robots']} robots, pitch {p['pitch_mm']:g} mm"


def _group_label(ds) -> str:
    """``q 0.8/1.25, p/r 1.5, sigma 0.6``: the values of designs drawn at one point."""
    def vals(key: str) -> str:
        return "/".join(f"{v:.3g}" for v in sorted({round(d.params[key], 4) for d in ds}))
    return f"q {vals('arm_ratio')}, p/r {vals('pitch_over_reach')}, sigma {vals('buffer_mm')}"


def _y(d, metric: str) -> float:
    return d.kept if metric == "kept" else d.fold()


def frontier_groups(ds, k: int, metric: str) -> list[tuple[str, list]]:
    """[(tag, designs)]: the frontier points of ``metric`` ("kept" | "fold"), per resolver in
    order of coverage, coincident designs (same coverage and value) under one tag."""
    out = []
    for res in FRONTIER_STYLE:
        front = sorted((d for d in ds if d.resolution == res and d.frontier.get(metric)
                        and math.isfinite(_y(d, metric))),
                       key=lambda d: (-d.cover[k], _y(d, metric)))
        at: dict[tuple, list] = {}
        for d in front:
            at.setdefault((round(d.cover[k], 4), round(_y(d, metric), 4)), []).append(d)
        out += [(f"{TAG[res]}{i}", g) for i, g in enumerate(at.values(), start=1)]
    return out


def _panel(ax, ds, k: int, metric: str, colours: dict, markers: dict) -> list[tuple[str, list]]:
    """Markers, pair lines, frontiers and tags of one family and metric; returns the tags."""
    xs_all = [d.cover[k] for d in ds if d.cover.get(k) is not None]
    width = (max(xs_all) - min(xs_all)) if xs_all else 0.0
    step = DODGE * (width if width > 0 else 0.2)
    slots = sorted({(round(d.params["arm_ratio"], 4), d.params["buffer_mm"]) for d in ds})
    shift = {s: (i - (len(slots) - 1) / 2) * step for i, s in enumerate(slots)}

    def x_of(d):
        return d.cover[k] + shift[(round(d.params["arm_ratio"], 4), d.params["buffer_mm"])]

    pairs: dict[str, list] = defaultdict(list)
    for d in ds:
        if d.cover.get(k) is None or not math.isfinite(_y(d, metric)):
            continue
        pairs[d.design_id].append((x_of(d), _y(d, metric)))
        colour = colours[d.params["buffer_mm"]]
        search = d.resolution == "search"
        ax.scatter([x_of(d)], [_y(d, metric)], marker=markers[round(d.params["arm_ratio"], 4)],
                   s=34 if search else 95, zorder=4 if search else 3,
                   facecolors=colour if search else "none", edgecolors=colour, linewidths=1.5)
    for pts in pairs.values():
        if len(pts) > 1:
            ax.plot([p[0] for p in pts], [p[1] for p in pts], color="0.75", lw=0.9, zorder=1)
    tags = frontier_groups(ds, k, metric)
    for res, style in FRONTIER_STYLE.items():
        front = sorted((d for tag, g in tags if tag[0] == TAG[res] for d in g),
                       key=lambda d: (x_of(d), _y(d, metric)))
        if front:
            ax.step([x_of(d) for d in front], [_y(d, metric) for d in front], where="pre",
                    lw=1.3, zorder=2, alpha=0.8, **style)
    for tag, g in tags:
        x = sum(x_of(d) for d in g) / len(g)
        above = tag.startswith("s")
        ax.annotate(tag, (x, _y(g[0], metric)), xytext=(5, 6 if above else -12),
                    textcoords="offset points", fontsize=8, fontweight="bold", color="0.1",
                    bbox=dict(boxstyle="round,pad=0.1", fc="white", ec="none", alpha=0.75))
    ax.set_xlabel(f"share of the focal plane reached by >= {k} fibers")
    ax.set_ylabel("targets kept (mean)" if metric == "kept" else "fold time (s, mean)")
    ax.grid(True, alpha=0.25)
    ax.margins(x=0.08, y=0.1)
    return tags


def _key(fig, tax, handles, tags_kept, tags_fold) -> None:
    """Legend, then the frontier tags spelled out, in the key axes ``tax``."""
    tax.axis("off")
    leg = tax.legend(handles=handles, loc="upper left", bbox_to_anchor=(0.0, 1.0), fontsize=8,
                     frameon=False, borderaxespad=0.0)
    fig.canvas.draw()                                    # the legend's size, for the text below
    top = leg.get_window_extent().transformed(tax.transAxes.inverted()).y0 - 0.04
    lines = []
    for title, tags in (("Pareto frontier, targets kept:", tags_kept),
                        ("Pareto frontier, fold time:", tags_fold)):
        lines.append(title)
        lines += [f"  {tag}: {_group_label(g)}" for tag, g in tags] or ["  (none)"]
    tax.text(0.0, top, "\n".join(lines), transform=tax.transAxes, va="top", ha="left",
             fontsize=7.5, linespacing=1.35)


def draw_frontier(designs: list, path: Path, k: int = 2) -> Path:
    """Draw the frontier figure of ``designs`` (:class:`~rfp_twin.twin.studies.frontier.DesignResult`
    with ``frontier`` marked) into ``path`` (PNG, atomically); returns ``path``."""
    import matplotlib
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    fams = sorted({d.family for d in designs})
    fw = any(math.isfinite(d.fold_fw_s) for d in designs)
    height = 4.6 * len(fams) + 0.4                       # in; margins below in inches too
    fig = Figure(figsize=(15.0, height), dpi=110)
    FigureCanvasAgg(fig)
    axes = fig.subplots(len(fams), 3, squeeze=False, width_ratios=[1.0, 1.0, 0.62],
                        gridspec_kw=dict(left=0.05, right=0.99, wspace=0.22,
                                         hspace=1.0 / 3.6, top=1 - 0.35 / height,
                                         bottom=0.55 / height))
    cmap = matplotlib.colormaps["viridis"]
    for row, fam in enumerate(fams):
        ds = [d for d in designs if d.family == fam]
        ratios = sorted({round(d.params["arm_ratio"], 4) for d in ds})
        buffers = sorted({d.params["buffer_mm"] for d in ds})
        markers = {q: RATIO_MARKERS[i % len(RATIO_MARKERS)] for i, q in enumerate(ratios)}
        colours = {b: cmap(0.85 * i / max(1, len(buffers) - 1)) for i, b in enumerate(buffers)}
        tags_kept = _panel(axes[row][0], ds, k, "kept", colours, markers)
        tags_fold = _panel(axes[row][1], ds, k, "fold", colours, markers)
        axes[row][0].set_title(_family_title(ds), fontsize=10, loc="left")
        axes[row][1].set_title(f"{'firmware-ready' if fw else 'stepwise'} fold: shorter is "
                               "better", fontsize=10, loc="left")
        handles = [Line2D([], [], marker="o", ls="none", color="0.3", mfc="0.3", ms=6,
                          label="filled: search"),
                   Line2D([], [], marker="o", ls="none", color="0.3", mfc="none", ms=10,
                          label="ring: replace (paper)")]
        handles += [Line2D([], [], marker=markers[q], ls="none", color="0.3", mfc="0.6",
                           label=f"q = alpha/beta {q:g}") for q in ratios]
        handles += [Patch(color=colours[b], label=f"sigma {b:g} mm") for b in buffers]
        handles += [Line2D([], [], lw=1.3, label=f"frontier ({r})", **FRONTIER_STYLE[r])
                    for r in FRONTIER_STYLE if any(d.resolution == r for d in ds)]
        _key(fig, axes[row][2], handles, tags_kept, tags_fold)
    replace_atomically(path, lambda tmp: fig.savefig(tmp, format="png"))
    return path
