"""The side-by-side report on disk: markdown, JSON, two figures and one full report per
column (:func:`rfp_twin.validation.buffer.write_report` in a subfolder)."""
from __future__ import annotations

import json
from pathlib import Path

from rfp_twin.models.files import atomic_write_text
from rfp_twin.validation.buffer.comparison import BufferComparison, slug
from rfp_twin.validation.buffer.writer import finish_figure, pyplot, save_figure, write_report

#: Files of the side-by-side report.
COMPARISON_MD = "buffer_comparison.md"
COMPARISON_JSON = "comparison.json"


def write_comparison(comp: BufferComparison, out_dir: str | Path, command: str = "") -> dict:
    """Write ``buffer_comparison.md``, ``comparison.json``, ``wasted_space_compare.png``,
    ``mc_compare.png`` and each column's full report (``<column>/``) to ``out_dir``.

    Returns {"markdown": path, "json": path, "figures": [paths], "columns": [folders]}.
    """
    plt = pyplot()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    cols = comp.columns
    folders = []
    for c in cols:
        sub = out / slug(c.geometry)
        write_report(c, sub, command=command)
        folders.append(sub)
    figs = []

    save = figs.append

    fig, ax = plt.subplots(figsize=(7.0, 4.4))
    for k, c in enumerate(cols):
        line, = ax.plot(c.buffers_mm, c.wasted_fraction, marker="o", ms=3, label=c.geometry)
        ax.axvline(c.safe_buffer_mm, color=line.get_color(), linewidth=1, linestyle="--")
    ax.plot(cols[0].buffers_mm, cols[0].forbidden_fraction, color="k", linewidth=1,
            label="2D-forbidden (share of all)")
    save(finish_figure(fig, ax, out, "wasted_space_compare.png",
                       xlabel="collision buffer b, mm (dashed: each b*)",
                       ylabel="2D-forbidden but safe (share of forbidden)", ylim=(0, 1),
                       title=f"{comp.spec_name}: space wasted by the 2D model", legend_size=7))

    fig, axes = plt.subplots(len(cols), 1, figsize=(7.0, 2.3 * len(cols)), sharex=True,
                             squeeze=False)
    for ax, c in zip(axes[:, 0], cols):
        ax.hist(c.mc_samples_mm, bins=50, alpha=0.7, label="angular errors")
        ax.axvline(c.mc_buffer_mm, color="tab:blue", linestyle=":",
                   label=f"b_p {c.mc_buffer_mm:.3f}")
        if comp.instrument:
            ax.hist(c.spread_samples_mm, bins=50, alpha=0.5, color="tab:green",
                    label=f"+ {comp.instrument} spread")
            ax.axvline(c.spread_buffer_mm, color="tab:green", linestyle=":",
                       label=f"b_p {c.spread_buffer_mm:.3f}")
        ax.axvline(c.safe_buffer_mm, color="k", linewidth=1, label=f"b* {c.safe_buffer_mm:.3f}")
        ax.set_title(c.geometry, fontsize=9)
        ax.legend(fontsize=7)
    axes[-1, 0].set_xlabel(f"buffer one draw needs, mm (p = {cols[0].probability:g})")
    save(save_figure(fig, out, "mc_compare.png"))

    md_path = out / COMPARISON_MD
    atomic_write_text(md_path, _markdown(comp, command, folders))
    js_path = out / COMPARISON_JSON
    atomic_write_text(js_path, json.dumps(comp.to_dict(), indent=1))
    return {"markdown": md_path, "json": js_path, "figures": figs, "columns": folders}


def _markdown(comp: BufferComparison, command: str, folders) -> str:
    cols = comp.columns
    c0 = cols[0]
    head = "| quantity | " + " | ".join(comp.labels) + " |"
    sep = "|---" * (len(cols) + 1) + "|"
    sep2 = "|---" * (len(cols) + 2) + "|"
    summary = "\n".join(f"| {q} | " + " | ".join(cells) + " |" for q, cells in comp.rows())
    waste = "\n".join(
        f"| {b:.2f} | {c0.forbidden_fraction[i]:.4f} | "
        + " | ".join(f"{c.wasted_fraction[i]:.4f}" for c in cols) + " |"
        for i, b in enumerate(c0.buffers_mm))
    links = "\n".join(f"- {c.geometry}: [{f.name}/buffer_calibration.md]"
                      f"({f.name}/buffer_calibration.md)" for c, f in zip(cols, folders))
    spread = ""
    if comp.instrument:
        m = next((c.metrology for c in cols if c.metrology), {})
        spread = f"""
(d) adds to each of the same draws the measured deviations from nominal of two different
robots of the **{comp.instrument}** calibration ({m.get('n_robots', 0)} robots): alpha arm
length, metrology fiber x (a shift of the beta arm along itself) and base offset dx, dy.
The 2D model keeps the nominal robot. Standard deviations: alpha
{m.get('alpha', {}).get('std', 0.0):.4f}, metrology x {m.get('beta', {}).get('std', 0.0):.4f},
dx {m.get('dx', {}).get('std', 0.0):.4f}, dy {m.get('dy', {}).get('std', 0.0):.4f} mm.
"""
    return f"""# Collision-buffer calibration side by side: {comp.spec_name}

{('Command: `' + command + '`') if command else ''}

Every column is the same calibration (same 2D model of `{comp.spec_name}`: beta segments,
"safe in 2D at buffer b" = D2 > 2 b; same {c0.n_samples} uniform samples, {c0.n_draws}
Monte Carlo draws, seed {c0.seed}, pitch {c0.pitch_mm:.3f} mm) against a different robot:
the 3D collision meshes of each geometry (exact solid distance, FCL; every b* is a
verified 3D contact), and the 2D capsule model itself (the robot *is* the capsule: its
b* is its radius by construction). The P1 column is the published 2018-19 prototype
beta arm (kaiju, 2019), not the production robot; the estimate bar is this project's
estimate geometry.
{spread}
## Summary

{head}
{sep}
{summary}

![wasted space](wasted_space_compare.png)

## Wasted space per buffer

Share of the uniform configurations the 2D model forbids (the same for every column),
and per column the share of those that are safe for that robot (wasted).

| buffer mm | 2D-forbidden | {' | '.join(comp.labels)} |
{sep2}
{waste}

## Monte Carlo buffer (angular errors{' and metrology spread' if comp.instrument else ''})

![Monte Carlo](mc_compare.png)

## Full report per column

{links}

Total run time {comp.seconds:.1f} s.
"""
