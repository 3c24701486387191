"""``rfp-twin plan``: parse the options, run the pipeline, print the summary.

All the work is :class:`rfp_twin.twin.pipeline.Reconfiguration`; this module only turns options
into its inputs and its :class:`rfp_twin.twin.outcome.Outcome` into a run folder and a table.
"""
from __future__ import annotations

import time
from pathlib import Path
from typing import Optional

import typer

from rfp_twin.models.errors import TargetError
from rfp_twin.twin.cli.options import options_from, with_options
from rfp_twin.twin.cli.shared_options import (ArrayOptions, CatalogueOptions, force_option,
                                              out_option)
from rfp_twin.twin.pass_options import PassOptions
from rfp_twin.twin.pipeline import PlanOptions
from rfp_twin.twin.cli.console import (EXIT_COLLISION, EXIT_INCOMPLETE, fail, one_line_errors,
                                       print_rows, progress_bar)


#: CLI spellings of PlanOptions fields whose names carry their unit.
PLAN_RENAME = {"step_deg": "step", "budget_mm": "budget"}


@one_line_errors
@with_options(ArrayOptions)
@with_options(CatalogueOptions, {"solver": "assign_solver"})
@with_options(PassOptions)
@with_options(PlanOptions, PLAN_RENAME)
def plan(
    seed: int = typer.Option(0, help="Seed of targets, Markov moves and replacements."),
    n_targets: Optional[int] = typer.Option(None, help="Probe-arm presets (miradas-probe): "
                                            "this many random targets drawn with --seed "
                                            "[default: the typical scenario, 12 arms]."),
    targets: Optional[Path] = typer.Option(None, help="Targets CSV (robot_id + alpha_deg,beta_deg or "
                                           "x_mm,y_mm; robots left out are parked at the "
                                           "fold; probe arms: arm + theta1_deg,theta2_deg or "
                                           "x_mm,y_mm) [default: seeded random]."),
    catalogue: Optional[str] = typer.Option(None, help="Plan a target catalogue instead: assign "
                                            "it (collision-aware, rfp-twin assign), plan, and "
                                            "assign again without the targets the plan did "
                                            "not keep, until it keeps them all. A CSV/Parquet "
                                            "file or mock:uniform|clustered:DENSITY[/deg2|"
                                            "/patrol|/robot][,...] (see rfp-twin assign --help)."),
    assign_rounds: int = typer.Option(5, help="--catalogue: assign -> plan rounds at most, "
                                      ">= 1."),
    out: Path = out_option(Path("out/plan")),
    force: bool = force_option(),
    flow: str = typer.Option("twin", help="twin (plan, resolve deadlocks, post-process: ours) | "
                             "jaeger (SDSS-V's controller: decollide, plan without resolution, "
                             "up to 5 retries that move a deadlocked robot's target, production "
                             "smoothing, no re-check; the result is checked here)."),
    **option_values,
) -> None:
    """Plan a collision-free reconfiguration fold -> targets and write a run folder.

    By default the stepwise plan is smoothed, time-parametrised under the spec's speed and
    acceleration limits (interacting robots share one path parameter), simplified to at most
    --max-points per axis and verified again at buffer - budget."""
    t_import = time.perf_counter()
    from rfp_twin.models.kinds import ALPHA_BETA
    from rfp_twin.models.robot import preset_kind
    from rfp_twin.twin.run_dir import check_output_folder

    check_output_folder(out, force)
    array = options_from(ArrayOptions, option_values)
    if preset_kind(array.preset) != ALPHA_BETA:       # probe arms: their own planner
        from rfp_twin.twin.cli.probe import plan_probe_cli

        plan_probe_cli(array.preset, array.layout, option_values["algorithm"], seed, n_targets,
                       out, force, targets)
        return

    t_start = time.perf_counter()
    options = options_from(PlanOptions, option_values, PLAN_RENAME)
    algorithm, step = options.algorithm, options.step_deg
    rc, layout, _ = array.reconfiguration(options)
    if catalogue is not None and targets is not None:
        raise TargetError(f"--targets {str(targets)!r} and --catalogue {catalogue!r}; allowed: "
                          "one of them")
    tg = rc.read_targets(targets) if targets is not None else None
    if assign_rounds < 1:
        raise TargetError(f"--assign-rounds {assign_rounds}; allowed: >= 1")
    pass_options = options_from(PassOptions, option_values)
    passes = pass_options.passes
    if passes != 1:
        if catalogue is None:
            raise TargetError(f"--passes {passes} without --catalogue; allowed: --passes with "
                              "a catalogue")
    cat = None
    if catalogue is not None:
        assigning = options_from(CatalogueOptions, option_values, {"solver": "assign_solver"})
        assign_settings = assigning.settings()
        cat, _ = assigning.load(catalogue, rc.geom, layout, rc.spec.name, seed)
        if flow != "twin":
            raise TargetError(f"--catalogue with --flow {flow!r}; allowed: --flow twin")
    if flow not in ("twin", "jaeger"):
        raise TargetError(f"--flow {flow!r}; allowed: twin, jaeger")
    if flow == "jaeger":
        from rfp_twin.twin.cli.flow import run_jaeger_flow

        chosen = options.planner_settings()
        return run_jaeger_flow(rc, seed, tg, out, force, algorithm=algorithm, greed=chosen.greed,
                               phobia=chosen.phobia, step=step)
    t_setup = time.perf_counter()
    if passes != 1:
        from rfp_twin.twin.cli.passes import run_passes_cli

        return run_passes_cli(rc, cat, assign_settings, passes, seed=seed,
                              max_rounds=assign_rounds, out=out, force=force, layout=layout,
                              direct_stuck=pass_options.direct_stuck)
    n, rounds = rc.geom.n_robots, options.max_rounds + 1
    with progress_bar("planning", "{task.completed}/{task.total}") as progress:
        task = progress.add_task(f"{n} robots, {algorithm}", total=rounds if options.stepwise else None)

        def on_round(rnd: int, n_stuck: int) -> None:
            progress.update(task, completed=rnd + 1,
                            description=f"{n} robots, {algorithm}: {n_stuck} deadlocked")

        def on_stage(name: str) -> None:
            if name in ("post-processing", "checking"):
                progress.update(task, completed=rounds, total=rounds,
                                description=f"{n} robots: {name}")

        def on_progress(name: str, done: int, total: int) -> None:
            progress.update(task, completed=done, total=total,
                            description=f"{n} robots: {name}, groups timed")

        loop = None
        if cat is None:
            outcome = rc.run(seed=seed, targets=tg, on_round=on_round, on_stage=on_stage,
                             on_progress=on_progress)
        else:
            from rfp_twin.twin.plannable import plan_catalogue

            loop = plan_catalogue(rc, cat, assign_settings, seed=seed, max_rounds=assign_rounds,
                                  on_round=lambda k, info: progress.update(
                                      task, description=f"{n} robots: assignment round {k}, "
                                      f"{info['lost']} target(s) lost"),
                                  on_stage=on_stage, on_progress=on_progress)
            outcome = loop.outcome
    t_run = time.perf_counter()
    summary = outcome.summary(layout=layout)
    extra = None
    if loop is not None:
        from rfp_twin.twin.assignment_files import assignment_csv

        summary["assignment"] = loop.summary(cat)
        generic = not any(c in rc.layout.extra for c in ("boss_x_mm", "apogee_x_mm"))
        extra = {"assignment.csv": assignment_csv(loop.assignment, cat, generic)}
    summary["wall_time_s"] = time.perf_counter() - t_start
    summary["stage_wall_s"] = {"imports": t_start - t_import, "setup": t_setup - t_start,
                               **{k: outcome.seconds[k] for k in ("targets", "plan", "deliver")},
                               "summary": time.perf_counter() - t_run}
    check = outcome.check
    if not check.ok:
        raise fail(f"the plan fails the 2D check: {len(check.collisions)} collision(s), min "
                   f"clearance {check.min_clearance_mm:.4f} mm; nothing written", EXIT_COLLISION)
    outcome.write(out, summary=summary, overwrite=force, extra=extra)
    print_summary(summary, out)
    if loop is not None and loop.n_lost:
        raise fail(f"{loop.n_lost} assigned target(s) not kept by the plan after "
                   f"{len(loop.rounds)} round(s); see {out}/summary.json", EXIT_INCOMPLETE)
    if outcome.n_deadlocked:
        raise fail(f"{outcome.n_deadlocked} robot(s) still deadlocked after "
                   f"{summary['metrics']['rounds']} round(s); see {out}/targets.csv", EXIT_INCOMPLETE)


def _group_row(g: dict) -> str:
    """The group that sets the end: its robots, timed and stepwise durations."""
    ids = ", ".join(str(r) for r in g["robots"][:8]) + (" ..." if len(g["robots"]) > 8 else "")
    return (f"{ids}: {g['duration_s']:.2f} s (stepwise {g['stepwise_s']:.2f} s"
            + (f", {g['narrowed_robots']} narrowed" if g["narrowed_robots"] else "") + ")")


def print_summary(summary: dict, out: Path) -> None:
    """The run's figures as a table on stdout."""
    m = summary["metrics"]
    c = summary["check2d"]
    rows = [
        ("robots (offline)", f"{summary['n_robots']} ({m['n_offline']})"),
        (("fiducials / guide cameras", f"{summary['n_fiducials'] - summary['n_gfa']} / "
                                       f"{summary['n_gfa']}")
         if summary.get("n_gfa") else ("fiducials", str(summary["n_fiducials"]))),
        ("algorithm / direction", f"{summary['algorithm']} / {summary['direction']}"),
        ("buffer / step", f"{summary['buffer_mm']:.3f} mm / " + (
            f"{summary['step_deg']} deg" if summary["step_deg"] is not None
            else f"Euler {summary['field']['dt_s']} s")),
        ("efficiency (Eq. 11)", f"{m['efficiency']:.4f}"),
        ("convergence (1st run)", f"{m['convergence']:.4f}"),
        ("targets replaced", str(m["n_replaced"]) + (
            f" ({m['n_local_groups']} group{'s' if m['n_local_groups'] > 1 else ''} then "
            "searched in place)"
            if m.get("n_local_groups") else "")),
        ("deadlocked", str(m["n_deadlocked"])),
        *([("kept by re-run", f"{m.get('n_rerun_robots', 0)} robots, "
                              f"{m.get('n_rerun_groups', 0)} groups, "
                              f"{m.get('rerun_s', 0.0):.2f} s ({m.get('rerun_attempts', 0)} "
                              f"runs)"),
           ("kept by search", f"{m['n_search_robots']} robots, {m['n_search_groups']} groups, "
                              f"{m['search_s']:.1f} s ({m['n_search_failed_groups']} "
                              f"failed)"),
           ("kept by continuation", f"{m.get('n_continued_robots', 0)} robots, "
                                    f"{m.get('n_continued_groups', 0)} groups")]
          if summary.get("resolve") == "search" else []),
        ("fold time (stepwise)", f"{m['fold_time_s']:.2f} s"),
        ("trajectory duration", (f"{summary['duration_s']:.2f} s = "
                                 f"{summary['duration_ratio']:.3f} x stepwise (firmware-ready)"
                                 if summary.get("duration_ratio")
                                 else f"{summary['duration_s']:.2f} s ({summary['trajectories']})")),
        *([("fold time on the instrument", f"{summary['fold_s']:.2f} s (path delay "
                                             f"{summary['path_delay_s']:.1f} s + trajectory)")]
          if summary.get("path_delay_s") else []),
        *([("robots that set the end", _group_row(summary["slowest_groups"][0]))]
          if summary.get("slowest_groups") else []),
        ("tau_pg / tau_sr / planning", f"{m['tau_pg_s']:.3f} s / {m['tau_sr_s']:.3f} s / "
                                       + (f"{m['planning_s']:.2f} s" if "planning_s" in m else "-")),
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
    a = summary.get("assignment")
    if a:
        lost = ", ".join(str(r["lost"]) for r in a["rounds"])
        rows[:0] = [
            ("catalogue", f"{a['n_targets']} targets ({a['catalogue']})"),
            ("assigned / kept by the plan", f"{a['assigned']} / {a['kept']} ({a['counts']['parked']} "
                                            "parked)"),
            ("assignment rounds (lost per round)", f"{a['n_rounds']} ({lost})"),
            ("objective / bound", f"{a['objective']:g} / {a['bound']:g} ({a['solver']}, "
                                  f"{a['status']})"),
            *([("science completeness", f"{100 * a['science_completeness']:.1f} %")]
              if a.get("science_completeness") is not None else []),
        ]
    print_rows(f"rfp-twin plan -> {out}", rows)
