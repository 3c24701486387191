"""``rfp-twin simulate | render | record | model export``: a run folder in the MuJoCo twin.

Each command reads a run folder written by ``rfp-twin plan``, or a jaeger / kaiju trajectory
file with ``--layout`` / ``--calibration`` (:func:`rfp_twin.twin.cli.motion_option.load_motion`),
and builds the MuJoCo model of its spec and layout; a probe-arm run folder (MIRADAS) goes
to :mod:`rfp_twin.twin.cli.probe` (the MuJoCo bench, its video, its recording). Heavy
imports (mujoco, rerun) happen inside the commands so that ``rfp-twin --help`` stays fast.
"""
from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from rfp_twin.models.errors import RfpError
from rfp_twin.twin.cli.layout_option import CALIBRATION_HELP, LAYOUT_HELP, chosen_layout
from rfp_twin.twin.cli.console import (EXIT_COLLISION, console, fail, one_line_errors,
                                  progress_bar)
from rfp_twin.twin.cli.motion_option import (SOURCE_HELP, MotionOptions, is_trajectory_file,
                                             load_motion)
from rfp_twin.twin.cli.options import options_from, with_options
from rfp_twin.twin.cli.shared_options import PRESET_HELP, parse_ids

model_app = typer.Typer(no_args_is_help=True, rich_markup_mode=None, help="The MuJoCo model of an array.")

#: Fault options: (option, fault class name in rfp_twin.twin.sim, number of fields, form).
FOLD_HELP = "Play targets -> fold instead of fold -> targets."
TIMESTEP_HELP = "MuJoCo timestep, s."
TILE_HELP = ("Simulate in tiles of at most this many robots (0: one MuJoCo model) [default: "
             "tiles of 512 above 2,000 robots].")
_FAULTS = (("--stuck", "Stuck", 2, "ID:TIME_S"), ("--slow", "Slow", 2, "ID:FACTOR"),
           ("--encoder-offset", "EncoderOffset", 3, "ID:ALPHA_DEG:BETA_DEG"))


def parse_faults(stuck: list[str], slow: list[str], offset: list[str]) -> list:
    """Fault objects of :mod:`rfp_twin.twin.sim` from the ``--stuck/--slow/--encoder-offset`` items."""
    import rfp_twin.twin.sim as sim

    faults = []
    for (opt, cls_name, n_args, form), items in zip(_FAULTS, (stuck, slow, offset)):
        for item in items:
            bits = item.split(":")
            try:
                if len(bits) != n_args:
                    raise ValueError
                faults.append(getattr(sim, cls_name)(int(bits[0]), *(float(b) for b in bits[1:])))
            except ValueError:
                raise RfpError(f"{opt} {item!r}; allowed: {form}") from None
    return faults


def build_with_progress(spec, lay, options=None, tile_robots: int | None = None):
    """The MuJoCo twin of ``lay``, built under a progress bar: one model (robots added, then
    MuJoCo's compile), or, above :data:`TILE_ABOVE_ROBOTS` robots or when ``tile_robots``
    > 0, a tiled twin of tiles of at most that many robots (0: one model)."""
    from rfp_twin.models.mjcf import build_model
    from rfp_twin.models.mjcf.tiled_twin import build_tiled
    from rfp_twin.models.mjcf.tiles import TILE_ABOVE_ROBOTS, TILE_ROBOTS

    if tile_robots is not None and tile_robots < 0:
        raise RfpError(f"--tile-robots {tile_robots}; allowed: 0 (one model) or a number of "
                       "robots >= 1")
    if tile_robots is None:
        tile_robots = TILE_ROBOTS if lay.n_robots > TILE_ABOVE_ROBOTS else 0
    with progress_bar("building model", "{task.completed}/{task.total}") as progress:
        task = progress.add_task("robots", total=lay.n_robots)

        def step(stage: str, done: int, total: int) -> None:
            progress.update(task, description=stage, completed=done, total=total)

        if tile_robots:
            return build_tiled(spec, lay, options=options, max_robots=tile_robots, progress=step)
        return build_model(spec, lay, options=options, progress=step)


def simulate_with_progress(twin, traj, faults=(), record: bool = False):
    """Simulate ``traj`` on ``twin`` under a progress bar (simulated seconds)."""
    from rfp_twin.twin.sim import simulate as run_sim

    with progress_bar("simulating") as progress:
        task = progress.add_task("", total=traj.duration + 0.5)
        return run_sim(twin, traj, faults, record=record,
                       callback=lambda t, m, d: progress.update(task, completed=t))


def _probe_run(run: Path, motion_values: dict, **alpha_beta_only) -> bool:
    """Is ``run`` a probe-arm run folder (MIRADAS)? Options that only apply to alpha/beta
    runs and trajectory files, when given with one, raise a one-line error."""
    from rfp_twin.twin.probe_files import is_probe_run

    if not is_probe_run(run):
        return False
    given = {f"--{k}": motion_values.get(k) for k in ("layout", "calibration", "preset")}
    given.update({f"--{k.replace('_', '-')}": v for k, v in alpha_beta_only.items()})
    used = [k for k, v in given.items() if v not in (None, False, [], ())]
    if used:
        raise RfpError(f"{run}: {used[0]} does not apply to a probe-arm run; allowed: the run "
                       "folder alone (it holds its own preset)")
    return True


def replay(run: Path, motion: MotionOptions, fold: bool, tile_robots: int | None):
    """``(twin, trajectory, recorded simulation report)``: the run folder or trajectory file
    ``run`` (played targets -> fold with ``fold``) simulated in its MuJoCo twin, poses
    recorded for ``render`` and ``record``."""
    spec, lay, traj, _ = load_motion(run, motion, to_fold=fold)
    twin = build_with_progress(spec, lay, tile_robots=tile_robots)
    return twin, traj, simulate_with_progress(twin, traj, record=True)


@model_app.command("export")
@one_line_errors
def model_export(
    out: Path = typer.Option(..., help="Folder for rfp-twin.xml and meshes/."),
    preset: str = typer.Option("sdss-v", help=PRESET_HELP),
    layout: Optional[str] = typer.Option(None, help=LAYOUT_HELP),
    calibration: Optional[Path] = typer.Option(None, help=CALIBRATION_HELP),
    fiducials: str = typer.Option("", help="Comma-separated fiducial ids (generated grids)."),
    timestep: float = typer.Option(0.004, help=TIMESTEP_HELP),
) -> None:
    """Write the MuJoCo model (MJCF + STL meshes); MuJoCo's own viewer opens it."""
    from rfp_twin.models.mjcf import ModelOptions, export_model
    from rfp_twin.models.robot import load_spec
    from rfp_twin.models.layout import layout_by_name

    from rfp_twin.models.robot import preset_kind

    if preset_kind(preset) != "alpha-beta":                  # probe arms (MIRADAS)
        from rfp_twin.models.kinds import load_kind
        from rfp_twin.models.mjcf.probe_bench import export_probe_bench

        kind = load_kind(preset)
        if layout is not None:
            n = len(layout_by_name(layout, 1.0).robot_ids)
            kind = type(kind)(kind.spec.with_overrides(n_arms=n))
        path = export_probe_bench(kind, out)
        console.print(f"wrote {path} ({kind.n_arms} probe arms)")
        return
    spec = load_spec(preset)
    lay = layout_by_name(chosen_layout(layout, calibration, spec), spec.pitch_mm,
                         parse_ids(fiducials, "--fiducials"))
    path = export_model(spec, lay, out, options=ModelOptions(timestep_s=timestep))
    console.print(f"wrote {path} ({lay.n_robots} robots, {lay.n_fiducials} fiducials)")


@one_line_errors
@with_options(MotionOptions)
def simulate(
    run: Path = typer.Argument(..., help=SOURCE_HELP),
    stuck: list[str] = typer.Option([], help="Fault: robot stuck from a time, ID:TIME_S."),
    slow: list[str] = typer.Option([], help="Fault: robot running slow, ID:FACTOR."),
    encoder_offset: list[str] = typer.Option([], help="Fault: encoder offset, ID:ALPHA_DEG:BETA_DEG."),
    timestep: float = typer.Option(0.004, help=TIMESTEP_HELP),
    tile_robots: Optional[int] = typer.Option(None, help=TILE_HELP),
    **motion_values,
) -> None:
    """Run the plan (or a trajectory file) in the MuJoCo twin; writes RUN/sim.json (or
    FILE.sim.json beside a trajectory file); exit 4 on any robot contact."""
    from rfp_twin.models.mjcf import ModelOptions

    if _probe_run(run, motion_values, stuck=stuck, slow=slow, encoder_offset=encoder_offset,
                  tile_robots=tile_robots):
        from rfp_twin.twin.cli.probe import simulate_probe_cli

        return simulate_probe_cli(run)
    spec, lay, traj, _ = load_motion(run, options_from(MotionOptions, motion_values))
    faults = parse_faults(stuck, slow, encoder_offset)
    twin = build_with_progress(spec, lay, ModelOptions(timestep_s=timestep), tile_robots)
    report = simulate_with_progress(twin, traj, faults)
    path = run.with_name(f"{run.stem}.sim.json") if is_trajectory_file(run) else run / "sim.json"
    report.to_json(path)
    console.print(report.table())
    if report.collided:
        raise fail(f"{report.robot_contacts} robot-robot contact(s) in simulation; see "
                   f"{path}", EXIT_COLLISION)


@one_line_errors
@with_options(MotionOptions)
def render(
    run: Path = typer.Argument(..., help=SOURCE_HELP),
    out: Path = typer.Option(Path("fold.mp4"), help="MP4 file to write."),
    camera: Optional[str] = typer.Option(None, help="top | oblique | closeup [default: top, "
                                         "closeup with --robot]."),
    robot: Optional[int] = typer.Option(None, help="Robot id for the close-up camera."),
    width: int = typer.Option(1280, help="Frame width, px."),
    height: int = typer.Option(720, help="Frame height, px."),
    fps: float = typer.Option(30.0, help="Frames per second of the video."),
    speedup: float = typer.Option(1.0, help="Simulated seconds per video second."),
    fold: bool = typer.Option(False, help=FOLD_HELP),
    full_quality: bool = typer.Option(False, help="Shadows, reflections, MSAA (slow on a CPU)."),
    tile_robots: Optional[int] = typer.Option(None, help=TILE_HELP),
    **motion_values,
) -> None:
    """Simulate a run and render it offscreen to MP4 (robots coloured by state)."""
    from rfp_twin.twin.render import RenderSettings, render_run  # first: picks MUJOCO_GL before mujoco

    if _probe_run(run, motion_values, camera=camera, robot=robot, fold=fold,
                  tile_robots=tile_robots):
        from rfp_twin.twin.cli.probe import render_probe_cli

        return render_probe_cli(run, out, width, height, fps, speedup)
    settings = RenderSettings(width=width, height=height, fps=fps, speedup=speedup,
                              camera=camera or ("closeup" if robot is not None else "top"),
                              robot_id=robot, lean=not full_quality)
    twin, traj, sim_report = replay(run, options_from(MotionOptions, motion_values), fold,
                                    tile_robots)
    with progress_bar("rendering", "{task.completed}/{task.total} frames") as progress:
        task = progress.add_task("", total=None)
        report = render_run(twin, traj, out, settings, sim_report=sim_report,
                            progress=lambda i, n: progress.update(task, completed=i, total=n))
    console.print(f"wrote {out}: {report.frames} frames, {report.fps_rendered:.1f} frames/s "
                  f"rendered, {report.fps_achieved:.1f} frames/s with encoding ({report.backend})")


@one_line_errors
@with_options(MotionOptions)
def record(
    run: Path = typer.Argument(..., help=SOURCE_HELP),
    out: Path = typer.Option(Path("run.rrd"), help=".rrd file to write."),
    fold: bool = typer.Option(False, help=FOLD_HELP),
    dt: Optional[float] = typer.Option(None, help="Seconds between logged poses [default 0.02]."),
    tile_robots: Optional[int] = typer.Option(None, help=TILE_HELP),
    **motion_values,
) -> None:
    """Simulate a run and write a rerun recording: arm poses, fiber traces, contacts."""
    from rfp_twin.twin.record import RecordSettings, record_run

    if _probe_run(run, motion_values, fold=fold, tile_robots=tile_robots):
        from rfp_twin.twin.cli.probe import record_probe_cli

        return record_probe_cli(run, out, dt)
    settings = RecordSettings(dt_s=dt)
    twin, traj, sim_report = replay(run, options_from(MotionOptions, motion_values), fold,
                                    tile_robots)
    with progress_bar("recording", "{task.completed}/{task.total} robots") as progress:
        task = progress.add_task("", total=twin.layout.n_robots)
        path = record_run(twin, traj, out, sim_report=sim_report, settings=settings,
                          progress=lambda done, total: progress.update(task, completed=done))
    console.print(f"wrote {path} ({path.stat().st_size / 1e6:.1f} MB); open it with `rerun {path}`")
