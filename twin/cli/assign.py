"""``rfp-twin assign``: a target catalogue -> one collision-free pose per robot, on disk.

The work is :func:`rfp_twin.planners.assignment.assign`; this module turns the options
into its inputs (array, catalogue, settings) and its result into a folder
(:mod:`rfp_twin.twin.assignment_files`) and a table.
"""
from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path
from typing import Optional

import typer
from rich.table import Table

from rfp_twin.twin.cli.console import console, one_line_errors
from rfp_twin.twin.cli.layout_option import CALIBRATION_HELP, LAYOUT_HELP, chosen_layout

CATALOGUE_HELP = ("A catalogue file (CSV or Parquet: id; x_mm,y_mm or x_wok_mm,y_wok_mm or "
                  "ra_deg,dec_deg; optional priority, kind science|sky|standard, fiber "
                  "boss|apogee|any) or a mock: mock:uniform|clustered:DENSITY[/deg2|/patrol|"
                  "/robot][,sky=D][,standard=D][,levels=K][,fiber=F][,children=C][,sigma=MM].")


def parse_arms(text: str) -> tuple[str, ...]:
    return ("right", "left") if text == "both" else tuple(v for v in text.split(",") if v)


@one_line_errors
def assign(
    catalogue: str = typer.Option(..., help=CATALOGUE_HELP),
    preset: str = typer.Option("sdss-v", help="Robot preset name or path to a robot TOML."),
    layout: Optional[str] = typer.Option(None, help=LAYOUT_HELP),
    calibration: Optional[Path] = typer.Option(None, help=CALIBRATION_HELP),
    fiducials: str = typer.Option("", help="Comma-separated position ids that are fiducials "
                                  "(generated grids only)."),
    buffer: Optional[float] = typer.Option(None, help="Collision buffer sigma_cb, mm "
                                           "[default: preset]."),
    step: float = typer.Option(0.1, help="Angular step of the stepwise planner, deg: final "
                               "poses keep its margin (Sayres 2021 Eq. 7) beyond the buffer."),
    seed: int = typer.Option(0, help="Seed of a mock catalogue."),
    offline: list[str] = typer.Option([], help="Offline robot: ID (parked folded) or "
                                      "ID:ALPHA:BETA; it takes no target and the others clear "
                                      "its pose; repeat or comma-separate."),
    telescope: str = typer.Option("auto", help="Plate scale and field for deg^2 densities and "
                                  "ra/dec: auto (SDSS-V layouts: apo, sdss-v-lco: lco) | apo "
                                  "(217.7358 mm/deg, 1.5 deg) | lco (330.275 mm/deg, 1.1 deg) "
                                  "| none."),
    field_centre: Optional[str] = typer.Option(None, help="RA,DEC of the field centre, deg "
                                               "(catalogues with ra_deg,dec_deg)."),
    solver: str = typer.Option("auto", help="auto (HiGHS up to 3000 robots, the heuristic "
                               "above) | highs | cpsat (exact) | greedy (greedy + local "
                               "improvement)."),
    time_limit: float = typer.Option(10.0, help="Time limit of the exact solver, s."),
    arms: str = typer.Option("right", help="Arm solutions that are candidates: right | both | "
                             "left (left-armed poses, beta in (180, 360), are much harder for "
                             "the planner to fold)."),
    sky_quota: int = typer.Option(0, help="Minimum sky fibers per region."),
    standard_quota: int = typer.Option(0, help="Minimum standard fibers per region."),
    sectors: int = typer.Option(1, help="Regions for the quotas: equal angular sectors about "
                                "the array's centre."),
    out: Path = typer.Option(Path("out/assign"), help="Output folder (must not exist unless "
                             "--force)."),
    force: bool = typer.Option(False, help="Replace an existing output folder."),
) -> None:
    """Assign a catalogue's targets to the robots: at most one target per robot and each
    target once, no two final poses colliding, priorities maximised; robots without a
    target are parked at the fold. Writes assignment.csv (plan it with `rfp-twin plan
    --targets OUT/assignment.csv`) and report.json."""
    from rfp_twin.models.robot import load_spec
    from rfp_twin.planners import apply_offline
    from rfp_twin.planners.assignment import AssignSettings, Quotas
    from rfp_twin.planners.assignment import assign as run_assign
    from rfp_twin.twin.assignment_files import (ASSIGNMENT_CSV, REPORT_JSON, assignment_csv,
                                                assignment_report, report_json,
                                                write_assignment)
    from rfp_twin.twin.catalogue_source import load_catalogue, parse_centre, telescope_for
    from rfp_twin.twin.cli.plan import parse_ids, parse_offline
    from rfp_twin.twin.pipeline import PlanOptions, Reconfiguration
    from rfp_twin.twin.run_dir import check_output_folder

    check_output_folder(out, force)
    t0 = time.perf_counter()
    spec = load_spec(preset)
    layout_name = chosen_layout(layout, calibration, spec)
    settings = AssignSettings(solver=solver, time_limit_s=time_limit, arms=parse_arms(arms),
                              quotas=Quotas(sky=sky_quota, standard=standard_quota,
                                            sectors=sectors))
    still = parse_offline(offline, spec.fold_deg)
    rc = Reconfiguration.from_names(spec, layout_name, buffer_mm=buffer,
                                    fiducial_ids=parse_ids(fiducials, "--fiducials"),
                                    options=PlanOptions(step_deg=step), offline=still)
    apply_offline(rc.geom, still)       # unknown ids and angles out of range: one line
    tel = telescope_for(telescope, layout_name, spec.name)
    cat = load_catalogue(catalogue, rc.geom, telescope=tel,
                         field_centre=parse_centre(field_centre), seed=seed)
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
    t = Table(title=f"rfp-twin assign -> {out}", show_header=True)
    t.add_column("quantity")
    t.add_column("value", justify="right")
    rows = [
        ("robots / layout", f"{report['n_robots']} / {report['layout']}"),
        ("buffer + margin", f"{report['buffer_mm']:.3f} + {report['margin_mm']:.4f} mm"),
        ("catalogue", f"{cat['n_targets']} targets ({cat['n_science']} science, {cat['n_sky']} "
                      f"sky, {cat['n_standard']} standard)"),
        ("candidates", f"{st['n_candidates']} poses"),
        ("assigned", f"{report['assigned']} ({c['science']} science, {c['sky']} sky, "
                     f"{c['standard']} standard), {c['parked']} parked"),
        ("objective / bound", f"{report['objective']:g} / {report['bound']:g} (gap "
                              f"{100 * report['gap']:.2f} %)"),
        ("solver / status", f"{report['solver']} / {report['status']}"),
        ("time", f"{report['wall_time_s']:.2f} s (assign {st['seconds']['total']:.2f} s)"),
    ]
    if report.get("science_completeness") is not None:
        rows.insert(5, ("science completeness", f"{100 * report['science_completeness']:.1f} %"))
    for k, v in rows:
        t.add_row(k, v)
    console.print(t)
