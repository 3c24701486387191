"""The `rfp-twin` command line (typer + rich).

Every rfp-twin error (bad spec, layout, targets, ids ...) is printed on one line and the
command exits non-zero; nothing half-written is left behind.
"""
from __future__ import annotations

import csv
import dataclasses
import sys
import time
from pathlib import Path
from typing import Optional

import numpy as np
import typer
from rich.console import Console
from rich.markup import escape
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from models.array import ArrayGeometry
from models.errors import LayoutError, RfpError, TargetError
from models.kinematics import inverse
from models.layout import Layout
from models.robot import load_spec
from planners.plan import DEADLOCKED
from planners.solver import ALGORITHMS, DIRECTIONS, RESOLVERS, PlannerSettings, plan_reconfiguration
from planners.stepwise import max_displacement
from planners.targets import random_targets
from planners.timing import BACKENDS as TIMING_BACKENDS
from models.trajectory import Trajectory
from twin.run_dir import write_run
from validation.checker2d import check_trajectory

app = typer.Typer(add_completion=False, no_args_is_help=True, pretty_exceptions_enable=False,
                  help="Digital twin of robotic fiber positioner arrays.")
console = Console(stderr=False)
err_console = Console(stderr=True)



@app.callback()
def _root() -> None:
    """rfp-twin: plan, validate, simulate and render robotic fiber positioner arrays."""


#: Exit codes.
EXIT_BAD_INPUT = 2
EXIT_INCOMPLETE = 3
EXIT_COLLISION = 4
#: Planners that integrate a potential field (planners/apf.py, planners/capf.py).
FIELD_ALGORITHMS = ("apf", "capf")
#: Extra clearance (mm) beyond the field's barrier that random targets keep.
APF_TARGET_SLACK_MM = 0.5


def resolve_layout(name: str, pitch_mm: float, fiducial_ids: tuple[int, ...] = ()) -> Layout:
    """Layout from a name: ``sdss-v-fps`` (the real 500-robot instrument), ``sdss-v-547``
    (the paper's all-robot grid), ``hex:N`` (a hex grid of N positions: 7, 19, 37, 61, 91, ...),
    or a CSV path.
    ``fiducial_ids`` turns positions of a generated grid into fiducials."""
    if fiducial_ids and (name == "sdss-v-fps" or not (name == "sdss-v-547" or name.startswith("hex:"))):
        raise LayoutError(f"--fiducials applies to generated grids (sdss-v-547, hex:N), not {name!r}; "
                          "a CSV layout says each position's kind itself")
    if name == "sdss-v-fps":
        return Layout.sdss_v_fps()
    if name == "sdss-v-547":
        return Layout.sdss_v_grid(pitch_mm=pitch_mm, fiducial_ids=fiducial_ids)
    if name.startswith("hex:"):
        try:
            n = int(name[4:])
        except ValueError:
            raise LayoutError(f"layout {name!r}: 'hex:N' needs an integer N") from None
        grid = Layout.hex_grid_positions(n, pitch_mm)
        if fiducial_ids:
            grid.robot_indices(list(fiducial_ids))  # names an unknown id
            kinds = grid.kinds.copy()
            kinds[np.isin(grid.ids, fiducial_ids)] = "fiducial"
            grid = Layout(grid.ids, grid.xy, kinds, name=grid.name)
        return grid
    path = Path(name)
    if path.suffix.lower() != ".csv" and not path.exists():
        raise LayoutError(f"layout {name!r}: allowed: sdss-v-fps, sdss-v-547, hex:N or a CSV file")
    return Layout.from_csv(path, min_separation_mm=min(1.0, pitch_mm / 4))


def read_targets_csv(path: Path, geom: ArrayGeometry) -> np.ndarray:
    """Targets from CSV: ``robot_id`` and either ``alpha_deg,beta_deg`` or ``x_mm,y_mm``
    (fiber position; right-armed inverse kinematics). Every robot needs a row."""
    spec = geom.spec
    try:
        with open(path, newline="", encoding="utf-8") as fh:
            rows = list(csv.DictReader(fh))
    except FileNotFoundError:
        raise TargetError(f"{path}: targets file not found") from None
    if not rows:
        raise TargetError(f"{path}: no target rows")
    cols = set(rows[0])
    by_angles = {"alpha_deg", "beta_deg"} <= cols
    by_xy = {"x_mm", "y_mm"} <= cols
    if "robot_id" not in cols or not (by_angles or by_xy):
        raise TargetError(f"{path}: columns {sorted(cols)}; allowed: robot_id with alpha_deg,beta_deg "
                          "or x_mm,y_mm")
    vals = np.full((geom.n_robots, 2), np.nan)
    index = {int(r): k for k, r in enumerate(geom.robot_ids)}
    keys = ("alpha_deg", "beta_deg") if by_angles else ("x_mm", "y_mm")
    for line, row in enumerate(rows, start=2):
        try:
            rid = int(row["robot_id"])
            v = [float(row[k]) for k in keys]
        except (TypeError, ValueError):
            raise TargetError(f"{path}:{line}: robot_id must be an integer and {keys} numbers") from None
        if rid not in index:
            raise TargetError(f"{path}:{line}: unknown robot id {rid}; allowed ids: "
                              f"{int(geom.robot_ids.min())}..{int(geom.robot_ids.max())}")
        if not np.all(np.isfinite(v)):
            raise TargetError(f"{path}:{line}: robot {rid}: NaN/inf target; allowed: finite numbers")
        vals[index[rid]] = v
    missing = np.flatnonzero(np.isnan(vals[:, 0]))
    if missing.size:
        raise TargetError(f"{path}: robot {int(geom.robot_ids[missing[0]])} has no target row "
                          f"({missing.size} robot(s) missing)")
    if by_xy:
        vals = inverse(geom.base_xy, vals, spec.alpha_length_mm, spec.beta_length_mm,
                       right_arm=True, ids=geom.robot_ids)
    return vals


def parse_offline(items: list[str], spec) -> dict[int, tuple[float, float]]:
    """``ID`` (parked folded) or ``ID:ALPHA:BETA`` -> {id: (alpha, beta)}."""
    out: dict[int, tuple[float, float]] = {}
    for item in items:
        for part in filter(None, item.split(",")):
            bits = part.split(":")
            try:
                rid = int(bits[0])
                ang = (float(bits[1]), float(bits[2])) if len(bits) == 3 else tuple(spec.fold_deg)
            except (ValueError, IndexError):
                raise TargetError(f"--offline {part!r}; allowed: ID or ID:ALPHA:BETA") from None
            if len(bits) not in (1, 3):
                raise TargetError(f"--offline {part!r}; allowed: ID or ID:ALPHA:BETA")
            out[rid] = ang
    return out


@app.command()
def plan(
    preset: str = typer.Option("sdss-v", help="Robot preset name or path to a robot TOML."),
    layout: Optional[str] = typer.Option(None, help="sdss-v-fps | sdss-v-547 | hex:N | CSV file "
                                         "[default: sdss-v-fps for SDSS-V presets, hex:547 otherwise]"),
    fiducials: str = typer.Option("", help="Comma-separated position ids that are fiducials "
                                  "(generated grids only)."),
    buffer: Optional[float] = typer.Option(None, help="Collision buffer sigma_cb, mm [default: preset]."),
    step: float = typer.Option(0.1, help="Angular step, deg."),
    algorithm: str = typer.Option("greedy", help="greedy | markov (stepwise, Sayres 2021) | roadmap "
                                  "(Sabater 2018 prioritized state-time planner on every robot; "
                                  "slow: minutes on 500 robots) | apf (Makarem 2014 navigation "
                                  "function) | capf (Macktoobian 2019)"),
    greed: float = typer.Option(0.9, help="Markov greed, [0, 1]."),
    phobia: float = typer.Option(0.3, help="Markov phobia, [0, 1]."),
    seed: int = typer.Option(0, help="Seed of targets, Markov moves and replacements."),
    offline: list[str] = typer.Option([], help="Offline robot: ID (parked folded) or ID:ALPHA:BETA; "
                                      "repeat or comma-separate."),
    targets: Optional[Path] = typer.Option(None, help="Targets CSV (robot_id + alpha_deg,beta_deg or "
                                           "x_mm,y_mm) [default: seeded random]."),
    direction: str = typer.Option("reverse", help="reverse (targets->fold, reversed) | forward"),
    resolve: str = typer.Option("search", help="Deadlocks left by greedy/markov/roadmap: search "
                                "(re-plan each deadlocked group by state-time search, keeping its "
                                "targets; replace a target only where that fails) | replace (new "
                                "target for one robot per group, Sayres 2021) | none."),
    apf_gain: float = typer.Option(1.0, help="apf/capf: field gain u = -gain J^T grad psi, 1/s."),
    lambda3: float = typer.Option(0.03, help="capf: cooperative weight (Macktoobian Eq. 5)."),
    max_steps: Optional[int] = typer.Option(None, help="Step limit [default: 1000 deg / step]."),
    out: Path = typer.Option(Path("out/plan"), help="Output folder (must not exist unless --force)."),
    force: bool = typer.Option(False, help="Replace an existing output folder."),
    raw: bool = typer.Option(False, help="Write the stepwise paths (constant speed, infinite "
                             "acceleration) instead of firmware-ready trajectories."),
    budget: float = typer.Option(0.03, help="Buffer share of smoothing + simplification, mm "
                                 "(Eq. 12); trajectories are verified at buffer - budget."),
    max_points: int = typer.Option(1024, help="Most (angle, time) points per axis (firmware)."),
    timing_backend: str = typer.Option("toppra", help="Time-optimal parametrisation: toppra (the "
                                       "library) | numba (our kernel of the same algorithm, "
                                       "same trajectories, ~3-5x faster)."),
) -> None:
    """Plan a collision-free reconfiguration fold -> targets and write a run folder.

    By default the stepwise plan is smoothed, time-parametrised under the spec's speed and
    acceleration limits (interacting robots share one path parameter), simplified to at most
    --max-points per axis and verified again at buffer - budget."""
    t_start = time.perf_counter()
    spec = load_spec(preset)
    if buffer is not None:
        spec = spec.with_overrides(buffer_mm=buffer)
    if layout is None:
        layout = "sdss-v-fps" if spec.name.startswith("sdss-v") else "hex:547"
    if algorithm not in ALGORITHMS + FIELD_ALGORITHMS:
        raise RfpError(f"--algorithm {algorithm!r}; allowed: "
                       f"{', '.join(ALGORITHMS + FIELD_ALGORITHMS)}")
    if resolve not in RESOLVERS + ("none",):
        raise RfpError(f"--resolve {resolve!r}; allowed: {', '.join(RESOLVERS + ('none',))}")
    if direction not in DIRECTIONS:
        raise RfpError(f"--direction {direction!r}; allowed: {', '.join(DIRECTIONS)}")
    if timing_backend not in TIMING_BACKENDS:
        raise RfpError(f"--timing-backend {timing_backend!r}; allowed: {', '.join(TIMING_BACKENDS)}")
    lay = resolve_layout(layout, spec.pitch_mm, _parse_ids(fiducials, "--fiducials"))
    geom = ArrayGeometry(spec, lay, spec.buffer_mm)
    stepwise = algorithm in ALGORITHMS
    settings = PlannerSettings(algorithm=algorithm if stepwise else "greedy", step_deg=step,
                               greed=greed, phobia=phobia, direction=direction,
                               max_steps=max_steps, resolve="replace" if resolve == "none" else resolve)
    field = None if stepwise else field_settings(algorithm, apf_gain, lambda3)
    rng = np.random.default_rng(seed)
    md = max_displacement(spec.alpha_length_mm, spec.beta_length_mm, float(geom.seg_end.max()), step)
    if field is not None:
        from planners.apf import apf_target_margin_mm

        # targets inside the field's barrier (d = 2 buffer + margin) can never be reached
        md = apf_target_margin_mm(geom, field) + APF_TARGET_SLACK_MM
    off = parse_offline(offline, spec)
    if targets is None:
        fixed = np.zeros(geom.n_robots, dtype=bool)
        init = np.zeros((geom.n_robots, 2))
        for rid, ang in off.items():
            k = lay.robot_index(rid)
            fixed[k] = True
            init[k] = ang
        tg = random_targets(geom, rng, fixed=fixed, initial=init, margin_mm=md)
    else:
        tg = read_targets_csv(targets, geom)

    if field is not None:
        from planners.apf import plan_apf_reconfiguration

        with err_console.status(f"planning {geom.n_robots} robots, {algorithm} field"):
            result, _ = plan_apf_reconfiguration(geom, tg, field, offline=off, algorithm=algorithm)
    else:
        result = _plan_stepwise(geom, tg, settings, rng, off, resolve != "none", algorithm)


    post = None
    if raw:
        traj, check_buffer = Trajectory.from_plan(result), spec.buffer_mm
    else:
        from planners.postprocess import postprocess

        with err_console.status("smoothing, timing, simplifying, verifying"):
            traj, post = postprocess(result, geom, budget_mm=budget, max_points=max_points,
                                     verifier=check_trajectory,
                                     backend=timing_backend)
        check_buffer = post.verify_buffer_mm
    check = check_trajectory(traj, spec, lay, check_buffer)
    m = dict(result.metrics)
    summary = {
        "command": " ".join(["rfp-twin"] + sys.argv[1:]),
        "spec": spec.source, "robot": spec.name, "layout": layout, "n_robots": geom.n_robots,
        "n_fiducials": lay.n_fiducials, "buffer_mm": spec.buffer_mm,
        "segment_mm": [spec.segment_start_mm, spec.segment_end(spec.buffer_mm)],
        "step_deg": step if stepwise else None, "algorithm": algorithm,
        "greed": greed if algorithm == "markov" else 1.0,
        "phobia": phobia if algorithm == "markov" else 0.0, "seed": seed,
        "direction": direction if stepwise else "direct (fold -> targets)",
        "resolve": resolve if stepwise else "none", "max_steps": settings.steps_limit if stepwise else None,
        "field": dataclasses.asdict(field) if field is not None else None,
        "offline": sorted(off),
        "fold_deg": list(spec.fold_deg), "speed_deg_s": list(spec.max_speed_deg_s),
        "metrics": m, "duration_s": traj.duration,
        "points_per_axis_median": float(np.median(traj.point_counts())),
        "points_per_axis_max": int(traj.point_counts().max()),
        "trajectories": "stepwise (raw)" if raw else "firmware-ready (postprocessed)",
        "postprocess": post.to_dict() if post is not None else None,
        "check2d": check.to_dict(),
        "wall_time_s": time.perf_counter() - t_start,
    }
    if not check.ok:
        err_console.print(f"[red]error:[/] the plan fails the 2D check: {len(check.collisions)} "
                          f"collision(s), min clearance {check.min_clearance_mm:.4f} mm; nothing written")
        raise typer.Exit(EXIT_COLLISION)
    write_run(out, spec=spec, layout=lay, plan=result, trajectory=traj, summary=summary,
              check2d=summary["check2d"], overwrite=force)
    print_summary(summary, out)
    n_dead = int(np.sum(result.status == DEADLOCKED))
    if n_dead:
        err_console.print(f"[red]error:[/] {n_dead} robot(s) still deadlocked after "
                          f"{m['rounds']} round(s); see {out}/targets.csv")
        raise typer.Exit(EXIT_INCOMPLETE)


def _plan_stepwise(geom: ArrayGeometry, tg: np.ndarray, settings: PlannerSettings,
                   rng: np.random.Generator, off: dict, resolve: bool, algorithm: str):
    """plan_reconfiguration with a progress bar over resolution rounds."""
    with Progress(TextColumn("[bold]planning[/] {task.description}"), BarColumn(),
                  TextColumn("{task.completed}/{task.total} rounds"), TimeElapsedColumn(),
                  console=err_console, transient=True) as progress:
        task = progress.add_task(f"{geom.n_robots} robots, {algorithm}", total=settings.max_rounds + 1)

        def on_round(rnd: int, n_stuck: int) -> None:
            progress.update(task, completed=rnd + 1,
                            description=f"{geom.n_robots} robots, {algorithm}: {n_stuck} deadlocked")

        result = plan_reconfiguration(geom, tg, settings, rng, offline=off, resolve=resolve,
                                      progress=on_round)
        progress.update(task, completed=settings.max_rounds + 1)
    return result


def field_settings(algorithm: str, gain: float, lambda3: float):
    """ApfSettings / CapfSettings for the CLI: the segment model (arms, not just tips)."""
    from planners.apf import ApfSettings
    from planners.capf import CapfSettings

    if algorithm == "capf":
        return CapfSettings(model="segment", gain=gain, lambda3=lambda3)
    return ApfSettings(model="segment", gain=gain)


model_app = typer.Typer(no_args_is_help=True, help="The MuJoCo model of an array.")
app.add_typer(model_app, name="model")
from twin.study_cli import study_app  # noqa: E402  (a sub-app: `rfp-twin study ...`)

app.add_typer(study_app, name="study")
from twin.validate_cli import register as _register_validation  # noqa: E402

_register_validation(app)  # `rfp-twin validate RUN`, `rfp-twin calibrate-buffer`


@model_app.command("export")
def model_export(
    out: Path = typer.Option(..., help="Folder for rfp-twin.xml and meshes/."),
    preset: str = typer.Option("sdss-v", help="Robot preset name or path to a robot TOML."),
    layout: Optional[str] = typer.Option(None, help="sdss-v-fps | sdss-v-547 | hex:N | CSV file."),
    fiducials: str = typer.Option("", help="Comma-separated fiducial ids (generated grids)."),
    timestep: float = typer.Option(0.004, help="MuJoCo timestep, s."),
) -> None:
    """Write the MuJoCo model (MJCF + STL meshes); MuJoCo's own viewer opens it."""
    from models.mjcf import ModelOptions, export_model

    spec = load_spec(preset)
    lay = resolve_layout(layout or ("sdss-v-fps" if spec.name.startswith("sdss-v") else "hex:547"),
                         spec.pitch_mm, _parse_ids(fiducials, "--fiducials"))
    path = export_model(spec, lay, out, options=ModelOptions(timestep_s=timestep))
    console.print(f"wrote {path} ({lay.n_robots} robots, {lay.n_fiducials} fiducials)")


def _parse_ids(text: str, option: str) -> tuple[int, ...]:
    try:
        return tuple(int(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise LayoutError(f"{option} {text!r}; allowed: comma-separated integer ids") from None


def _parse_faults(stuck: list[str], slow: list[str], offset: list[str]):
    from twin.sim import EncoderOffset, Slow, Stuck

    faults = []
    for opt, items, cls, n_args in (("--stuck", stuck, Stuck, 2), ("--slow", slow, Slow, 2),
                                    ("--encoder-offset", offset, EncoderOffset, 3)):
        for item in items:
            bits = item.split(":")
            try:
                if len(bits) != n_args:
                    raise ValueError
                faults.append(cls(int(bits[0]), *(float(b) for b in bits[1:])))
            except ValueError:
                form = {"--stuck": "ID:TIME_S", "--slow": "ID:FACTOR",
                        "--encoder-offset": "ID:ALPHA_DEG:BETA_DEG"}[opt]
                raise RfpError(f"{opt} {item!r}; allowed: {form}") from None
    return faults


@app.command()
def simulate(
    run: Path = typer.Argument(..., help="Run folder written by `rfp-twin plan`."),
    stuck: list[str] = typer.Option([], help="Fault: robot stuck from a time, ID:TIME_S."),
    slow: list[str] = typer.Option([], help="Fault: robot running slow, ID:FACTOR."),
    encoder_offset: list[str] = typer.Option([], help="Fault: encoder offset, ID:ALPHA_DEG:BETA_DEG."),
    timestep: float = typer.Option(0.004, help="MuJoCo timestep, s."),
) -> None:
    """Run the plan in the MuJoCo twin; writes RUN/sim.json; exit 4 on any robot contact."""
    from models.mjcf import ModelOptions, build_model
    from twin.run_dir import load_run
    from twin.sim import simulate as run_sim

    spec, lay, traj, _ = load_run(run)
    faults = _parse_faults(stuck, slow, encoder_offset)
    twin = build_model(spec, lay, options=ModelOptions(timestep_s=timestep))
    with Progress(TextColumn("[bold]simulating[/]"), BarColumn(), TextColumn("{task.percentage:>3.0f}%"),
                  TimeElapsedColumn(), console=err_console, transient=True) as progress:
        task = progress.add_task("sim", total=traj.duration + 0.5)
        report = run_sim(twin, traj, faults,
                         callback=lambda t, m, d: progress.update(task, completed=t), record=False)
    report.to_json(Path(run) / "sim.json")
    console.print(report.table())
    if report.collided:
        err_console.print(f"[red]error:[/] {report.robot_contacts} robot-robot contact(s) in simulation; "
                          f"see {run}/sim.json")
        raise typer.Exit(EXIT_COLLISION)


@app.command()
def render(
    run: Path = typer.Argument(..., help="Run folder written by `rfp-twin plan`."),
    out: Path = typer.Option(Path("fold.mp4"), help="MP4 file to write."),
    camera: Optional[str] = typer.Option(None, help="top | oblique | closeup [default: top, "
                                         "closeup with --robot]."),
    robot: Optional[int] = typer.Option(None, help="Robot id for the close-up camera."),
    width: int = typer.Option(1280, help="Frame width, px."),
    height: int = typer.Option(720, help="Frame height, px."),
    fps: float = typer.Option(30.0, help="Frames per second of the video."),
    speedup: float = typer.Option(1.0, help="Simulated seconds per video second."),
    fold: bool = typer.Option(False, help="Play targets -> fold instead of fold -> targets."),
    full_quality: bool = typer.Option(False, help="Shadows, reflections, MSAA (slow on a CPU)."),
) -> None:
    """Simulate a run and render it offscreen to MP4 (robots coloured by state)."""
    from twin.render import RenderSettings, render_run  # first: picks MUJOCO_GL before mujoco

    from models.mjcf import build_model
    from twin.run_dir import load_run

    spec, lay, traj, _ = load_run(run, to_fold=fold)
    settings = RenderSettings(width=width, height=height, fps=fps, speedup=speedup,
                              camera=camera or ("closeup" if robot is not None else "top"),
                              robot_id=robot, lean=not full_quality)
    with Progress(TextColumn("[bold]rendering[/]"), BarColumn(),
                  TextColumn("{task.completed}/{task.total} frames"), TimeElapsedColumn(),
                  console=err_console, transient=True) as progress:
        task = progress.add_task("render", total=None)
        report = render_run(build_model(spec, lay), traj, out, settings,
                            progress=lambda i, n: progress.update(task, completed=i, total=n))
    console.print(f"wrote {out}: {report.frames} frames, {report.fps_rendered:.1f} frames/s "
                  f"rendered, {report.fps_achieved:.1f} frames/s with encoding ({report.backend})")


@app.command()
def record(
    run: Path = typer.Argument(..., help="Run folder written by `rfp-twin plan`."),
    out: Path = typer.Option(Path("run.rrd"), help=".rrd file to write."),
    fold: bool = typer.Option(False, help="Play targets -> fold instead of fold -> targets."),
    dt: Optional[float] = typer.Option(None, help="Seconds between logged poses [default 0.02]."),
) -> None:
    """Simulate a run and write a rerun recording: arm poses, fiber traces, contacts."""
    from models.mjcf import build_model
    from twin.record import RecordSettings, record_run
    from twin.run_dir import load_run

    spec, lay, traj, _ = load_run(run, to_fold=fold)
    with err_console.status("simulating and recording"):
        path = record_run(build_model(spec, lay), traj, out, settings=RecordSettings(dt_s=dt))
    console.print(f"wrote {path} ({path.stat().st_size / 1e6:.1f} MB); open it with `rerun {path}`")


def print_summary(summary: dict, out: Path) -> None:
    m = summary["metrics"]
    c = summary["check2d"]
    t = Table(title=f"rfp-twin plan -> {out}", show_header=True)
    t.add_column("quantity")
    t.add_column("value", justify="right")
    rows = [
        ("robots (offline)", f"{summary['n_robots']} ({m['n_offline']})"),
        ("fiducials", str(summary["n_fiducials"])),
        ("algorithm / direction", f"{summary['algorithm']} / {summary['direction']}"),
        ("buffer / step", f"{summary['buffer_mm']:.3f} mm / " + (
            f"{summary['step_deg']} deg" if summary["step_deg"] is not None
            else f"Euler {summary['field']['dt_s']} s")),
        ("efficiency (Eq. 11)", f"{m['efficiency']:.4f}"),
        ("convergence (1st run)", f"{m['convergence']:.4f}"),
        ("targets replaced", str(m["n_replaced"])),
        ("deadlocked", str(m["n_deadlocked"])),
        *([("kept by search", f"{m['n_search_robots']} robots, {m['n_search_groups']} groups, "
                              f"{m['search_s']:.1f} s ({m['n_search_failed_groups']} "
                              f"failed)"),
           ("kept by continuation", f"{m.get('n_continued_robots', 0)} robots, "
                                    f"{m.get('n_continued_groups', 0)} groups")]
          if summary.get("resolve") == "search" else []),
        ("fold time (stepwise)", f"{m['fold_time_s']:.2f} s"),
        ("trajectory duration", f"{summary['duration_s']:.2f} s ({summary['trajectories']})"),
        ("tau_pg / tau_sr", f"{m['tau_pg_s']:.3f} s / {m['tau_sr_s']:.3f} s"),
        ("points per axis (median / max)",
         f"{summary['points_per_axis_median']:.0f} / {summary['points_per_axis_max']}"),
        ("2D check", f"{'clear' if c['ok'] else 'COLLISION'} at {c['buffer_mm']:.3f} mm, min "
                     f"clearance {c['min_clearance_mm']:.4f} mm"),
    ]
    p = summary.get("postprocess")
    if p:
        rows.insert(-1, ("max |v| / |a| (alpha, beta)",
                         f"{max(p['max_speed_deg_s']):.2f} deg/s / {max(p['max_accel_deg_s2']):.1f} deg/s^2"))
        solvers = ", ".join(f"{k} {v}" for k, v in sorted(p.get("timing_solvers", {}).items()))
        rows.insert(-1, ("post-processing", f"{p['stage_seconds'].get('total', 0.0):.2f} s, "
                                            f"{p['n_groups']} groups (largest {p['largest_group']})"))
        rows.insert(-1, ("groups timed by", solvers or "-"))
    for k, v in rows:
        t.add_row(k, v)
    console.print(t)


def main() -> None:
    """Entry point that turns rfp-twin errors into one-line messages and exit code 2."""
    try:
        app()
    except RfpError as exc:
        err_console.print(f"[red]error:[/] {escape(str(exc))}", highlight=False, soft_wrap=True)
        sys.exit(EXIT_BAD_INPUT)


if __name__ == "__main__":
    main()
