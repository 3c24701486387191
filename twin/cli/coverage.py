"""``rfp-twin coverage``: how much of the focal plane 1, 2, 3 fibers reach.

Measures :func:`rfp_twin.models.coverage.measure_coverage` for a preset and a layout and
writes ``DIR/coverage.json`` (the result's ``to_dict()`` plus the command line) and
``DIR/coverage.png`` (the multiplicity map); prints a short table. Exit 2 with a
one-line error on bad input, before anything is written.
"""
from __future__ import annotations

import json
import statistics
from pathlib import Path
from typing import Optional

import typer
from rich.table import Table

from rfp_twin.models.errors import LayoutError
from rfp_twin.twin.cli.console import command_line, console, one_line_errors, progress_bar
from rfp_twin.twin.cli.layout_option import LAYOUT_HELP
from rfp_twin.twin.cli.shared_options import PRESET_HELP

#: Files written into the output folder.
COVERAGE_JSON = "coverage.json"
COVERAGE_PNG = "coverage.png"


@one_line_errors
def coverage(
    preset: str = typer.Option("sdss-v", help=PRESET_HELP),
    layout: Optional[str] = typer.Option(None, help="raft:N | raft:R=MM (triangular rafts, "
                                         "Spec-S5) | " + LAYOUT_HELP),
    pitch: Optional[float] = typer.Option(None, help="Pitch of generated layouts (hex:N, "
                                          "sdss-v-547, raft:...), mm (default: the preset's)."),
    spacing: Optional[float] = typer.Option(None, help="Grid cell size, mm (default: pitch / 20)."),
    out: Path = typer.Option(..., help="Output folder for coverage.json and coverage.png "
                             "(created if missing; those two files are replaced)."),
) -> None:
    """Fraction of the focal plane (convex hull of the robot bases) reached by >= 1, 2, 3
    fibers, per-raft instrumented areas, and a multiplicity map."""
    from rfp_twin.models.coverage import measure_coverage
    from rfp_twin.models.coverage.maps import coverage_png
    from rfp_twin.models.files import atomic_write_bytes, atomic_write_text
    from rfp_twin.models.layout import default_layout_name, layout_by_name
    from rfp_twin.models.robot import load_spec

    if out.exists() and not out.is_dir():
        raise LayoutError(f"--out {str(out)!r} is a file; allowed: a folder (new or existing)")
    spec = load_spec(preset)
    if pitch is not None:
        spec = spec.with_overrides(pitch_mm=pitch)
    name = layout or default_layout_name(spec)
    lay = layout_by_name(name, spec.pitch_mm)
    with progress_bar("coverage", "{task.completed}/{task.total} tiles") as progress:
        task = progress.add_task(f"{lay.n_robots} robots", total=None)

        def on_tile(done: int, total: int) -> None:
            progress.update(task, completed=done, total=total)

        cov = measure_coverage(lay, spec, spacing, progress=on_tile)
    png = coverage_png(cov)
    data = {"command": command_line(), "preset": preset, "layout_name": name, **cov.to_dict()}
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out / COVERAGE_JSON, json.dumps(data, indent=1))
    atomic_write_bytes(out / COVERAGE_PNG, png)
    console.print(summary_table(cov, out), highlight=False)


def summary_table(cov, out: Path) -> Table:
    """The measurement's figures as a rich table."""
    t = Table(title=f"rfp-twin coverage -> {out}")
    t.add_column("quantity")
    t.add_column("value", justify="right")
    t.add_row("layout / spec", f"{cov.layout} ({cov.n_robots} robots) / {cov.spec}")
    t.add_row("grid", f"{cov.spacing_mm:.4g} mm, {cov.n_cells:,} cells, {cov.seconds:.2f} s")
    t.add_row("focal plane (hull of bases)", f"{cov.focal_plane_area_mm2:,.0f} mm^2")
    if cov.fraction is not None:
        t.add_row(">= 1 / 2 / 3 fibers", " / ".join(f"{100 * cov.fraction[k]:.2f}%"
                                                    for k in ("1", "2", "3")))
        t.add_row("exactly 0 / 1 / 2 / 3 / 4+", " / ".join(f"{100 * v:.1f}%"
                                                          for v in cov.multiplicity.values()))
    else:
        t.add_row(">= 1 / 2 / 3 fibers", " / ".join(f"{cov.area_mm2[k]:,.1f}"
                                                    for k in ("1", "2", "3")) + " mm^2")
    fractions = [r.fraction for r in cov.rafts if r.fraction is not None]
    if fractions:
        t.add_row(f"{len(cov.rafts)} rafts: reached / triangle", f"min {min(fractions):.4f}, "
                  f"median {statistics.median(fractions):.4f}, max {max(fractions):.4f}")
    t.add_row("wrote", f"{COVERAGE_JSON}, {COVERAGE_PNG}")
    return t
