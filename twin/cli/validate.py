"""`rfp-twin validate` and `rfp-twin calibrate-buffer`: the 3D (FCL) checks on the CLI.

``register(app)`` adds both commands to a typer app (``rfp_twin.twin.cli`` calls it).

Commands
--------
validate RUN_DIR [--geometry FILE]
    Check the run's trajectory against the 3D collision meshes (FCL); writes
    ``RUN_DIR/validation.json``; exit 4 on any 3D collision.
validate TRAJECTORY.json --layout sdss-v-apo | --calibration DIR [--geometry FILE]
    A jaeger / kaiju trajectory file (:mod:`rfp_twin.twin.cli.motion_option`): the 2D check
    under the preset's rule (``sdss-v-production`` at 2.0 mm unless ``--preset`` /
    ``--buffer`` say otherwise), the buffer the trajectory kept
    (:mod:`rfp_twin.twin.kept_buffer`) and the 3D check; writes ``TRAJECTORY.validation.json``;
    exit 4 on any 2D or 3D collision.
validate PROBE_RUN_DIR
    A probe-arm run folder (``rfp-twin plan --preset miradas-probe``): the 2D check every
    0.01 s and the FCL 3D check every 0.1 s (:mod:`rfp_twin.validation.probe`); writes
    ``PROBE_RUN_DIR/validation.json``; exit 4 on any contact.
calibrate-buffer --preset sdss-v --out DIR [--instrument sdss-v-apo]
    Calibrate the 2D collision buffer against the 3D meshes; writes
    ``DIR/buffer_calibration.md``, ``DIR/calibration.json`` and PNG figures.
calibrate-buffer --preset sdss-v --compare sdss-v sdss-v-p1 --out DIR
    The same for several geometries and the 2D capsule model side by side: writes
    ``DIR/buffer_comparison.md``, ``DIR/comparison.json``, figures and one full report
    per column.

Exit codes (:mod:`rfp_twin.twin.cli.console`): 0 clear, 2 bad input (one-line message naming the
field / file and what is allowed), 4 collision.
"""
from __future__ import annotations

import time
from pathlib import Path
from typing import List, Optional

import typer

from rfp_twin.models.errors import SpecError, field_error
from rfp_twin.twin.cli.console import (EXIT_BAD_INPUT, EXIT_COLLISION, command_line, console, fail,
                                  one_line_errors, progress_bar)
from rfp_twin.twin.cli.motion_option import (SOURCE_HELP, MotionOptions, is_trajectory_file,
                                             load_motion)
from rfp_twin.twin.cli.options import options_from, with_options
from rfp_twin.twin.cli.shared_options import PRESET_HELP

__all__ = ["register", "validate", "calibrate_buffer", "VALIDATION_JSON", "EXIT_BAD_INPUT",
           "EXIT_COLLISION"]

#: File written into the run folder by `validate`.
VALIDATION_JSON = "validation.json"


def _geometry_for_run(geometry: Optional[str], spec, summary: dict):
    """The meshes for a run and where they came from: ``--geometry`` (preset name or
    TOML file with a ``[geometry]`` table), else the preset / file the run was planned
    with (``load_run`` sets it as the spec's source), else the defaults of its spec."""
    from rfp_twin.models.geometry import geometry_for_spec, load_geometry
    from rfp_twin.models.robot import spec_origin

    if geometry is not None:
        return load_geometry(geometry, spec), str(geometry)
    if spec_origin(spec) is not None and spec.source == str(summary.get("spec", "")):
        return geometry_for_spec(spec), spec.source
    return geometry_for_spec(spec), f"defaults for {spec.source}"


@one_line_errors
@with_options(MotionOptions)
def validate(
    run: Path = typer.Argument(..., help=SOURCE_HELP),
    geometry: Optional[str] = typer.Option(
        None, "--geometry", help="Robot TOML (or preset) whose [geometry] table gives the "
        "meshes, e.g. your CAD exports [default: the preset the run was planned with]."),
    fold: bool = typer.Option(False, "--fold", help="Check targets -> fold "
                              "(trajectories_to_fold.json; a trajectory file played backwards) "
                              "instead of fold -> targets."),
    min_gap: float = typer.Option(0.0, help="3D distance at or below which links collide, mm."),
    resolution: float = typer.Option(1e-5, help="Time resolution of the bisection, s."),
    out: Optional[Path] = typer.Option(None, help="Report file [default: RUN/validation.json, "
                                       "or FILE.validation.json beside a trajectory file]."),
    buffer: Optional[float] = typer.Option(
        None, help="2D buffer of a trajectory file's check, mm [default: the preset's, 2.0 for "
        "sdss-v-production]."),
    **motion_values,
) -> None:
    """Check a run folder or a trajectory file against the 3D collision meshes (FCL); a
    trajectory file also gets the 2D check under its preset's rule and the buffer it kept.
    Exit 4 on any collision."""
    import orjson

    from rfp_twin.models.files import atomic_write_bytes
    from rfp_twin.twin.run_dir import TRAJECTORIES, TRAJECTORIES_TO_FOLD

    options = options_from(MotionOptions, motion_values)
    from rfp_twin.twin.probe_files import is_probe_run

    if is_probe_run(run):
        if geometry is not None or fold or buffer is not None or any(
                motion_values.get(k) is not None for k in ("layout", "calibration", "preset")):
            raise field_error(SpecError, "--geometry/--fold/--layout/--calibration/--preset/"
                              "--buffer", "given", "none of them with a probe-arm run folder")
        from rfp_twin.twin.cli.probe import validate_probe_cli

        return validate_probe_cli(run, out)
    is_file = is_trajectory_file(run)
    if buffer is not None and not is_file:
        raise field_error(SpecError, "--buffer", buffer, "only with a trajectory file (a run "
                          "folder was checked in 2D by `rfp-twin plan`)")
    spec, lay, traj, summary = load_motion(run, options, to_fold=fold)
    geom, geom_label = _geometry_for_run(geometry, spec, summary)
    data = {"command": command_line(), "run": str(run)}
    collided = []
    if is_file:
        from rfp_twin.twin.kept_buffer import kept_buffer
        from rfp_twin.validation.checker2d import check_trajectory

        data.update(summary)
        data["trajectory"] = "reversed" if fold else "as written"
        b2d = spec.buffer_mm if buffer is None else buffer
        check2d = check_trajectory(traj, spec, lay, b2d)
        kept = kept_buffer(traj, spec, lay, check2d)
        data["check2d"] = check2d.to_dict()
        data["kept_buffer"] = kept.to_dict()
        console.print(check2d.table(), highlight=False)
        console.print(_kept_line(kept, spec), highlight=False)
        if summary["absent_ids"]:
            console.print(f"not checked: {len(summary['absent_ids'])} robot(s) of {lay.name} "
                          "neither in the file nor in its initial positions", highlight=False)
        if not check2d.ok:
            collided.append(f"{len(check2d.collisions)} 2D collision(s) at {b2d} mm")
    else:
        data["trajectory"] = TRAJECTORIES_TO_FOLD if fold else TRAJECTORIES
    report = _check3d(traj, spec, lay, geom, min_gap, resolution)
    data.update({**report.to_dict(), "geometry": geom_label})
    report.geometry = geom_label
    path = out if out is not None else _default_report(run, is_file)
    # orjson: 0.2 s instead of ~2 s for the 113,877 pairs of a 12,871-robot fold (the
    # report's non-finite numbers are already null)
    atomic_write_bytes(path, orjson.dumps(data, option=orjson.OPT_INDENT_2))
    console.print(report.table(), highlight=False)
    console.print(f"wrote {path}", highlight=False)
    if not report.ok:
        collided.append(f"{len(report.collisions)} 3D collision(s)")
    if collided:
        raise fail(f"{'; '.join(collided)}; see {path}", EXIT_COLLISION)


def _default_report(run: Path, is_file: bool) -> Path:
    """``RUN/validation.json``, or ``FILE.validation.json`` beside a trajectory file."""
    run = Path(run)
    return run.with_name(f"{run.stem}.{VALIDATION_JSON}") if is_file else run / VALIDATION_JSON


def _kept_line(kept, spec) -> str:
    """One line: the buffer a trajectory kept and the pairs that set it."""
    def part(label, mm, pair):
        return f"{label} {mm:.4f} mm ({pair[0]}-{pair[1]})" if pair else f"{label} -"
    return (f"kept buffer {kept.buffer_mm:.4f} mm under {spec.name}'s rule: "
            f"{part('robot pairs', kept.robot_mm, kept.robot_pair)}, "
            f"{part('obstacles', kept.obstacle_mm, kept.obstacle_pair)}")


def _check3d(traj, spec, lay, geom, min_gap: float, resolution: float):
    """The 3D check under a progress bar."""
    from rfp_twin.validation.mesh3d import validate_trajectory

    with progress_bar("3D check") as progress:
        task = progress.add_task(f"{traj.n_robots} robots", total=1.0)

        def on_progress(stage: str, done: int, total: int) -> None:
            frac = done / total if total else 1.0
            frac = 0.3 * frac if stage == "capsule bounds" else 0.3 + 0.7 * frac
            progress.update(task, completed=min(frac, 1.0),
                            description=f"{traj.n_robots} robots: {stage}")

        return validate_trajectory(traj, spec, lay, geom, min_gap_mm=min_gap,
                                   resolution_s=resolution, progress=on_progress)


@one_line_errors
def calibrate_buffer(
    more: Optional[List[str]] = typer.Argument(
        None, metavar="[GEOMETRY]...", show_default=False,
        help="More geometries for --compare (so that `--compare sdss-v sdss-v-p1` works)."),
    preset: str = typer.Option("sdss-v", help=PRESET_HELP),
    out: Path = typer.Option(..., help="Folder for the report and figures."),
    geometry: Optional[str] = typer.Option(
        None, "--geometry", help="Robot TOML (or preset) whose [geometry] table gives the "
        "meshes [default: the preset's]."),
    compare: Optional[List[str]] = typer.Option(
        None, "--compare", help="Calibrate these geometries (presets / TOML files, e.g. "
        "`--compare sdss-v sdss-v-p1`; repeatable, or comma-separated) and the 2D capsule "
        "model side by side, against the 2D model of --preset."),
    capsule_radius: Optional[float] = typer.Option(
        None, help="Radius of the 2D capsule model column of --compare, mm [default: the "
        "preset's beta_half_width_mm, 1.5 for SDSS-V (Sayres 2021 Sect. 3.3)]."),
    instrument: Optional[str] = typer.Option(
        None, help="Add the metrology spread of a real instrument to the Monte Carlo: "
        "sdss-v-apo | sdss-v-lco | a calibration folder."),
    layout: Optional[str] = typer.Option(
        None, help="Layout giving pitch and neighbour directions: sdss-v-fps | sdss-v-547 | "
        "hex:N | CSV [default: hex directions at the preset's pitch]."),
    samples: int = typer.Option(131072, help="Uniform (Sobol) configurations."),
    draws: int = typer.Option(2000, help="Monte Carlo draws of the angular errors."),
    probability: float = typer.Option(0.99, help="Probability of 3D safety for the Monte Carlo "
                                      "buffer, (0, 1]."),
    alpha_error: Optional[float] = typer.Option(None, help="Alpha angular error bound, deg "
                                                "[default: preset, 1.50 for SDSS-V]."),
    beta_error: Optional[float] = typer.Option(None, help="Beta angular error bound, deg "
                                               "[default: preset, 1.48 for SDSS-V]."),
    seed: int = typer.Option(0, help="Seed of the samples and the Monte Carlo."),
) -> None:
    """Calibrate the 2D collision buffer against the 3D meshes (markdown + figures).

    Smallest buffer for which 2D-safe implies 3D-safe, space wasted by the 2D model per
    buffer, and a Monte Carlo over angular errors (with --instrument, also over a real
    instrument's metrology spread). With --compare, several geometries and the 2D
    capsule model side by side in one report."""
    from rfp_twin.models.geometry import load_geometry
    from rfp_twin.models.robot import load_spec
    from rfp_twin.validation.buffer import calibrate_buffer as run_calibration
    from rfp_twin.validation.buffer import (compare_buffers, describe_geometry, write_comparison,
                                            write_report)
    from rfp_twin.validation.buffer.comparison import stage_fraction

    names = [n.strip() for v in (compare or []) for n in v.split(",") if n.strip()]
    if more and not compare:
        raise field_error(SpecError, "GEOMETRY", list(more), "extra geometries only after "
                          "--compare (e.g. --compare sdss-v sdss-v-p1)")
    names += list(more or [])
    if compare is not None and not names:
        raise field_error(SpecError, "--compare", list(compare), "one or more geometries")
    if names and geometry is not None:
        raise field_error(SpecError, "--geometry", geometry, "no --geometry with --compare "
                          "(list every geometry after --compare)")
    spec = load_spec(preset)
    lay = None
    if layout is not None:
        from rfp_twin.models.layout import layout_by_name

        lay = layout_by_name(layout, spec.pitch_mm)
    errs = (spec.angular_error_deg[0] if alpha_error is None else alpha_error,
            spec.angular_error_deg[1] if beta_error is None else beta_error)
    if out.exists() and not out.is_dir():
        raise field_error(SpecError, "--out", str(out), "a folder (new or existing)")
    kw = dict(n_samples=samples, n_draws=draws, probability=probability,
              angular_error_deg=errs, seed=seed)
    clock = time.perf_counter()
    if names:
        geoms = [(describe_geometry(n, g), g) for n in names
                 for g in [load_geometry(n, spec)]]
        radius = (capsule_radius if capsule_radius is not None
                  else load_geometry(preset, spec).params.beta_half_width_mm)
        with progress_bar("calibrating") as progress:
            task = progress.add_task(spec.name, total=1.0)

            def on_compare(stage: str, frac: float) -> None:
                progress.update(task, completed=0.97 * frac, description=stage)

            comp = compare_buffers(spec, geoms, lay, capsule_radius_mm=radius,
                                   instrument=instrument, progress=on_compare, **kw)
            progress.update(task, completed=0.97, description=f"{spec.name}: report")
            paths = write_comparison(comp, out, command=command_line())
        console.print(comp.table(), highlight=False)
    else:
        geom = load_geometry(geometry if geometry is not None else preset, spec)
        label = geometry if geometry is not None else str(geom.params.source)
        with progress_bar("calibrating") as progress:
            task = progress.add_task(spec.name, total=1.0)

            def on_progress(stage: str, frac: float) -> None:
                progress.update(task, completed=stage_fraction(stage, frac,
                                                               instrument is not None),
                                description=f"{spec.name}: {stage}")

            cal = run_calibration(spec, geom, lay, instrument=instrument, label=label,
                                  progress=on_progress, **kw)
            progress.update(task, completed=0.97, description=f"{spec.name}: report")
            paths = write_report(cal, out, command=command_line())
        console.print(cal.table(), highlight=False)
    console.print(f"report: {paths['markdown']} ({time.perf_counter() - clock:.1f} s)",
                  highlight=False)
    for f in paths["figures"]:
        console.print(f"  figure: {f}", highlight=False)


def register(app: typer.Typer) -> None:
    """Add ``validate`` and ``calibrate-buffer`` to a typer app."""
    app.command("validate")(validate)
    app.command("calibrate-buffer")(calibrate_buffer)
