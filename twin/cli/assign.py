"""``rfp-twin assign``: a target catalogue -> one collision-free pose per robot, on disk.

The work is :func:`rfp_twin.planners.assignment.assign`; this module turns the options
into its inputs (array, catalogue, settings) and its result into a folder
(:mod:`rfp_twin.twin.assignment_files`) and a table.
"""
from __future__ import annotations

import time
from dataclasses import fields, replace
from pathlib import Path

import typer

from rfp_twin.models.options import option_info
from rfp_twin.planners.plan.settings import PlannerSettings
from rfp_twin.twin.cli.console import one_line_errors, print_rows
from rfp_twin.twin.cli.options import options_from, with_options
from rfp_twin.twin.cli.shared_options import (ArrayOptions, CatalogueOptions, force_option,
                                              out_option)

#: The planner's step (its declaration: default, range, unit), whose margin final poses keep.
STEP = next(f for f in fields(PlannerSettings) if f.name == "step_deg")
STEP_INFO = option_info(PlannerSettings, "step_deg")
CATALOGUE_HELP = ("A catalogue file (CSV or Parquet: id; x_mm,y_mm or x_wok_mm,y_wok_mm or "
                  "ra_deg,dec_deg; optional priority, kind science|sky|standard, fiber "
                  "boss|apogee|any, exposures) or a mock: mock:uniform|clustered:DENSITY[/deg2|/patrol|"
                  "/robot][,sky=D][,standard=D][,levels=K][,fiber=F][,children=C][,sigma=MM]"
                  "[,exposures=N].")


@one_line_errors
@with_options(ArrayOptions)
@with_options(CatalogueOptions)
def assign(
    catalogue: str = typer.Option(..., help=CATALOGUE_HELP),
    step: float = typer.Option(STEP.default, help=f"{STEP_INFO.describe()[:-1]} of the stepwise "
                               "planner: final poses keep its margin (Sayres 2021 Eq. 7) beyond "
                               "the buffer."),
    seed: int = typer.Option(0, help="Seed of a mock catalogue."),
    time_limit: float = typer.Option(10.0, help="Time limit of the exact solver, s."),
    out: Path = out_option(Path("out/assign")),
    force: bool = force_option(),
    **option_values,
) -> None:
    """Assign a catalogue's targets to the robots: at most one target per robot and each
    target once, no two final poses colliding, priorities maximised; robots without a
    target are parked (--parking). Writes assignment.csv (plan it with `rfp-twin plan
    --targets OUT/assignment.csv`) and report.json."""
    from rfp_twin.planners import apply_offline
    from rfp_twin.planners.assignment import assign as run_assign
    from rfp_twin.twin.assignment_files import (ASSIGNMENT_CSV, REPORT_JSON, assignment_csv,
                                                assignment_report, report_json,
                                                write_assignment)
    from rfp_twin.twin.pipeline import PlanOptions
    from rfp_twin.twin.run_dir import check_output_folder

    check_output_folder(out, force)
    t0 = time.perf_counter()
    array = options_from(ArrayOptions, option_values)
    assigning = options_from(CatalogueOptions, option_values)
    settings = assigning.settings(time_limit_s=time_limit)
    rc, layout_name, still = array.reconfiguration(PlanOptions(step_deg=step))
    apply_offline(rc.geom, still)       # unknown ids and angles out of range: one line
    cat, tel = assigning.load(catalogue, rc.geom, layout_name, rc.spec.name, seed)
    margin = rc.target_margin_mm()
    settings = replace(settings, margin_mm=margin,
                       fixed=tuple((int(r), float(a), float(b)) for r, (a, b) in still.items()))
    result = run_assign(rc.geom, cat, settings)
    report = assignment_report(result, cat, settings=settings, layout_name=layout_name,
                               buffer_mm=rc.spec.buffer_mm, margin_mm=margin,
                               telescope=tel.name if tel is not None else None)
    report["wall_time_s"] = time.perf_counter() - t0
    generic = not any(c in rc.layout.extra for c in ("boss_x_mm", "apogee_x_mm"))
    write_assignment(out, {ASSIGNMENT_CSV: assignment_csv(result, cat, generic),
                           REPORT_JSON: report_json(report)}, overwrite=force)
    print_report(report, out)


def print_report(report: dict, out: Path) -> None:
    """The assignment's figures as a table on stdout."""
    c = report["counts"]
    cat = report["catalogue"]
    st = report["stats"]
    rows = [
        ("robots / layout", f"{report['n_robots']} / {report['layout']}"),
        ("buffer + margin", f"{report['buffer_mm']:.3f} + {report['margin_mm']:.4f} mm"),
        ("catalogue", f"{cat['n_targets']} targets ({cat['n_science']} science, {cat['n_sky']} "
                      f"sky, {cat['n_standard']} standard)"),
        ("candidates", f"{st['n_candidates']} poses"),
        ("assigned", f"{report['assigned']} ({c['science']} science, {c['sky']} sky, "
                     f"{c['standard']} standard), {c['parked']} parked "
                     f"({c.get('parked_off_fold', 0)} off the fold)"),
        ("objective / bound", f"{report['objective']:g} / {report['bound']:g} (gap "
                              f"{100 * report['gap']:.2f} %)"),
        ("solver / status", f"{report['solver']} / {report['status']}"),
        ("time", f"{report['wall_time_s']:.2f} s (assign {st['seconds']['total']:.2f} s)"),
    ]
    if report.get("science_completeness") is not None:
        rows.insert(5, ("science completeness", f"{100 * report['science_completeness']:.1f} %"))
    print_rows(f"rfp-twin assign -> {out}", rows)
