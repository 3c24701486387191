"""The calibration report on disk: markdown, JSON and three figures (PNG)."""
from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from rfp_twin.models.files import atomic_write_text
from rfp_twin.validation.buffer.report import BufferCalibration



def save_figure(fig, out: Path, name: str) -> Path:
    """Save a matplotlib figure as ``out / name`` (PNG, 120 dpi) atomically and close it."""
    import matplotlib.pyplot as plt

    path = out / name
    tmp = out / f".{name}.tmp.png"
    fig.savefig(tmp, dpi=120, bbox_inches="tight")
    plt.close(fig)
    os.replace(tmp, path)
    return path


def pyplot():
    """matplotlib.pyplot on the file-only Agg backend (no display needed)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def finish_figure(fig, ax, out: Path, name: str, *, xlabel: str, ylabel: str, title: str,
                  ylim: tuple | None = None, legend_size: int = 8) -> Path:
    """Label ``ax`` (axis labels, title, optional y range, legend) and save ``fig`` as
    ``out / name`` (:func:`save_figure`)."""
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    if ylim is not None:
        ax.set_ylim(*ylim)
    ax.set_title(title)
    ax.legend(fontsize=legend_size)
    return save_figure(fig, out, name)


def write_report(cal: BufferCalibration, out_dir: str | Path, command: str = "") -> dict:
    """Write ``buffer_calibration.md``, ``calibration.json`` and the figures
    (``scatter_2d_3d.png``, ``wasted_space.png``, ``mc_buffer.png``) to ``out_dir``.

    Returns {"markdown": path, "json": path, "figures": [paths]}. Files are written to
    temporary names and renamed.
    """
    plt = pyplot()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    figs = []

    d2 = np.asarray(cal.scatter_d2_mm)
    d3 = np.asarray(cal.scatter_d3_mm)
    fig, ax = plt.subplots(figsize=(6.4, 5.0))
    col = d3 <= 0.0
    ax.scatter(d2[~col], d3[~col], s=4, alpha=0.5, label="clear in 3D")
    ax.scatter(d2[col], d3[col], s=6, color="tab:red", label="colliding in 3D (distance 0)")
    for b, style, lab in ((cal.safe_buffer_mm, "-", f"2 b* = {2 * cal.safe_buffer_mm:.3f} mm"),
                          (cal.spec_buffer_mm, "--",
                           f"2 x preset buffer {cal.spec_buffer_mm:g} mm"),
                          (cal.mc_buffer_mm, ":", f"2 b_p = {2 * cal.mc_buffer_mm:.3f} mm")):
        ax.axvline(2 * b, color="k", linestyle=style, linewidth=1, label=lab)
    figs.append(finish_figure(
        fig, ax, out, "scatter_2d_3d.png", xlabel="2D model distance D2 (beta segments), mm",
        ylabel="3D mesh distance D3 (FCL), mm",
        title=f"{cal.spec_name}: 2D vs 3D distance ({len(d2)} configurations)"))

    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    ax.plot(cal.buffers_mm, cal.wasted_fraction, marker="o", ms=3,
            label="2D-forbidden but 3D-safe (share of forbidden)")
    ax.plot(cal.buffers_mm, cal.forbidden_fraction, marker=".", ms=3,
            label="2D-forbidden (share of all configurations)")
    ax.axvline(cal.safe_buffer_mm, color="k", linewidth=1, label=f"b* {cal.safe_buffer_mm:.3f} mm")
    ax.axvline(cal.mc_buffer_mm, color="k", linestyle=":", linewidth=1,
               label=f"b_p (p = {cal.probability:g}) {cal.mc_buffer_mm:.3f} mm")
    figs.append(finish_figure(
        fig, ax, out, "wasted_space.png", xlabel="collision buffer, mm", ylabel="fraction",
        ylim=(0, 1),
        title=f"{cal.spec_name}: space wasted by the 2D model ({cal.n_samples} samples)"))

    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    ax.hist(cal.mc_samples_mm, bins=50, alpha=0.7 if cal.instrument else 1.0,
            label="angular errors" if cal.instrument else None)
    ax.axvline(cal.mc_buffer_mm, color="k", linestyle=":", label=f"b_p {cal.mc_buffer_mm:.3f} mm")
    if cal.instrument:
        ax.hist(cal.spread_samples_mm, bins=50, alpha=0.5, color="tab:green",
                label=f"+ metrology spread ({cal.instrument})")
        ax.axvline(cal.spread_buffer_mm, color="tab:green", linestyle=":",
                   label=f"b_p with spread {cal.spread_buffer_mm:.3f} mm")
    ax.axvline(cal.safe_buffer_mm + cal.paper_sigma_eps_mm, color="tab:red", linestyle="--",
               label=f"b* + paper sigma_eps {cal.safe_buffer_mm + cal.paper_sigma_eps_mm:.3f} mm")
    figs.append(finish_figure(
        fig, ax, out, "mc_buffer.png",
        xlabel="buffer needed for one draw of angular errors B(e), mm", ylabel="draws",
        title=f"{cal.n_draws} draws, errors +-{cal.angular_error_deg[0]:g} / "
              f"+-{cal.angular_error_deg[1]:g} deg"))

    w = cal.worst
    rows = "\n".join(f"| {b:.2f} | {f:.4f} | {wf:.4f} |"
                     for b, f, wf in zip(cal.buffers_mm, cal.forbidden_fraction,
                                         cal.wasted_fraction))
    md = f"""# Collision-buffer calibration: {cal.spec_name} ({cal.geometry})

{('Command: `' + command + '`') if command else ''}

Geometry: `{cal.geometry}`. Two robots at pitch {cal.pitch_mm:.3f} mm in the neighbour
directions {', '.join(f'{d:g}' for d in cal.directions_deg)} deg. 2D model: beta segments,
"safe in 2D at buffer b" = D2 > 2 b. 3D: exact solid distance of the collision meshes
(FCL), "safe in 3D" = D3 > 0.

Samples: **{cal.n_samples} uniform (Sobol) configurations**, {cal.n_boundary} more near the
boundary (jittered copies + local search), {cal.n_colliding} of them 3D-colliding;
{cal.n_draws} Monte Carlo draws; seed {cal.seed}. {cal.n_fcl_calls} FCL calls;
run time {cal.seconds.get('total', 0.0):.1f} s.

## (a) Smallest buffer for which safe in 2D implies safe in 3D

**b\\* = {cal.safe_buffer_mm:.4f} mm** (uniform samples alone: {cal.safe_buffer_uniform_mm:.4f} mm;
the mesh's beta envelope around the 2D segment, an upper bound when only beta arms touch:
{cal.envelope_mm:.4f} mm). Preset buffer: {cal.spec_buffer_mm:g} mm.

Worst configuration found (verified 3D contact, links {w['links']}, 3D distance
{w['d3_mm']:.4f} mm):

| robot | alpha deg | beta deg |
|---|---|---|
| A (origin) | {w['alpha_a']:.4f} | {w['beta_a']:.4f} |
| B (direction {w['direction_deg']:g} deg) | {w['alpha_b']:.4f} | {w['beta_b']:.4f} |

2D distance there: {w['d2_mm']:.4f} mm (= 2 b\\*).

![2D vs 3D distance](scatter_2d_3d.png)

## (b) Space wasted by the 2D model

Share of the {cal.n_samples} uniform configurations that the 2D model forbids (D2 <= 2 b),
and the share of those that are safe in 3D. 3D-colliding share of all configurations:
{cal.colliding_fraction:.4f}.

| buffer mm | 2D-forbidden | of which 3D-safe (wasted) |
|---|---|---|
{rows}

![wasted space](wasted_space.png)

## (c) Angular errors (Monte Carlo)

Errors uniform in +-{cal.angular_error_deg[0]:g} deg (alpha) and +-{cal.angular_error_deg[1]:g}
deg (beta), independent per robot and axis; {cal.n_draws} draws. For each draw, B(e) is the
buffer needed for every 2D-safe commanded configuration to stay 3D-safe.

| quantity | mm |
|---|---|
| b\\* (no errors) | {cal.safe_buffer_mm:.4f} |
| **b_p, p = {cal.probability:g}** | **{cal.mc_buffer_mm:.4f}** |
| angular-error share b_p - b\\* | {cal.mc_share_mm:.4f} |
| worst corner (all errors at their bounds) | {cal.corner_buffer_mm:.4f} (share {cal.corner_share_mm:.4f}) |
| paper's analytic sigma_eps (Sayres 2021 Eq. 12) | {cal.paper_sigma_eps_mm:.4f} |
| B(e) median / 90 % / 99 % / max | {' / '.join(f"{cal.mc_quantiles[k]:.4f}" for k in ('0.5', '0.9', '0.99', '1.0'))} |

![Monte Carlo](mc_buffer.png)
{spread_section(cal)}
Stage times (s): {', '.join(f'{k} {v:.1f}' for k, v in cal.seconds.items())}.
"""
    md_path = out / "buffer_calibration.md"
    atomic_write_text(md_path, md)
    js_path = out / "calibration.json"
    atomic_write_text(js_path, json.dumps(cal.to_dict(), indent=1))
    return {"markdown": md_path, "json": js_path, "figures": figs}


def spread_section(cal: BufferCalibration) -> str:
    """Markdown of part (d), the metrology spread ("" without an instrument)."""
    if not cal.instrument:
        return ""
    m = cal.metrology
    rows = "\n".join(
        f"| {name} | {lab} | {m[name]['mean']:+.4f} | {m[name]['std']:.4f} | "
        f"{m[name]['max_abs']:.4f} |"
        for name, lab in (("alpha", f"alpha arm - {m['nominal_alpha_mm']:g} mm"),
                          ("beta", f"metrology fiber x - {m['nominal_metrology_mm']:g} mm "
                                   "(beta arm shift)"),
                          ("dx", "base offset dx"), ("dy", "base offset dy")))
    q = cal.spread_quantiles
    return f"""
## (d) Metrology spread of {cal.instrument}

Each of the {cal.n_draws} draws above also gives robots A and B the measured deviations
from nominal of two different robots of the **{cal.instrument}** calibration ({m['n_robots']}
robots, drawn with replacement across draws); the 2D model keeps the nominal robot (a
planner that ignores the per-robot calibration). Deviations, mm:

| deviation | what | mean | std | max abs |
|---|---|---|---|---|
{rows}

| quantity | mm |
|---|---|
| b_p, angular errors only | {cal.mc_buffer_mm:.4f} |
| **b_p, angular errors + metrology spread ({cal.instrument})** | **{cal.spread_buffer_mm:.4f}** |
| change | {cal.spread_change_mm:+.4f} |
| B(e, m) median / 90 % / 99 % / max | {' / '.join(f"{q[k]:.4f}" for k in ('0.5', '0.9', '0.99', '1.0'))} |
"""
