"""`rfp-twin study ...`: run design studies on Dask and report them.

A typer sub-app; :mod:`rfp_twin.twin.cli` mounts it as ``rfp-twin study``.

Commands
--------
run FILE      run (or resume) a study: FILE is a study TOML or a shipped study name; a
              finished study's trials end up in one file, DIR/results/trials.parquet
report DIR    markdown + figures for a study folder (design studies: the frontier)
consolidate DIR   merge a folder's per-trial files into DIR/results/trials.parquet
list          the shipped studies
"""
from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer
from rich.table import Table

from rfp_twin.twin.cli.console import (EXIT_COLLISION, EXIT_INCOMPLETE, EXIT_INTERRUPTED, console,
                                  err_console, fail, one_line_errors)
from rfp_twin.twin.cores import usable_cores

# rfp_twin.twin.studies (pyarrow, the trial runner) is imported inside the commands: the
# root app mounts this sub-app, and `rfp-twin plan` must not pay for it.

#: Trend checks printed one per line; more are summed up in one line.
MAX_TRENDS_SHOWN = 8

STUDY_DIR_HELP = "Study folder written by `rfp-twin study run`."
study_app = typer.Typer(add_completion=False, no_args_is_help=True, rich_markup_mode=None,
                        pretty_exceptions_enable=False,
                        help="Design studies: thousands of simulated reconfigurations on Dask, "
                             "stored as Parquet, reported as figures.")


@study_app.command("run")
@one_line_errors
def run(
    file: str = typer.Argument(..., help="Study TOML file, or a shipped study name "
                               "(see `rfp-twin study list`)."),
    scheduler: Optional[str] = typer.Option(
        None, help="Address of a running Dask scheduler, e.g. tcp://HOST:8786 (a SLURM cluster "
                   "via dask-jobqueue: see twin/studies/cluster.py) (default: a LocalCluster "
                   "here)."),
    workers: Optional[int] = typer.Option(
        None, help=f"LocalCluster worker processes (default: cores here = {usable_cores()})."),
    out: Optional[Path] = typer.Option(None, help="Study folder (default: out/studies/<name>)."),
    trials: Optional[int] = typer.Option(None, help="Trials per grid point instead of the "
                                         "file's (a larger value later extends the same study)."),
    max_trials: Optional[int] = typer.Option(None, help="Stop after this many new trials "
                                             "(run again to go on)."),
    threads: bool = typer.Option(False, "--threads", help="LocalCluster workers as threads of "
                                 "this process (no parallel speed-up of the numba kernels)."),
    report: bool = typer.Option(False, "--report", help="Write the report when the run ends."),
) -> None:
    """Run a study; trials already in the study folder are skipped (resume)."""
    from rfp_twin.twin.studies import default_out_dir, load_study, run_study

    study = load_study(file)
    if scheduler is not None and workers is not None:
        err_console.print("note: --workers applies to a LocalCluster only; the scheduler's "
                          "workers are used", highlight=False)
        workers = None
    out_dir = out if out is not None else default_out_dir(study)
    n_total = study.trials * len(study.points) if trials is None else trials * len(study.points)
    err_console.print(f"study [bold]{study.name}[/]: {len(study.points)} grid points x "
                      f"{trials or study.trials} trials = {n_total} trials -> {out_dir}",
                      highlight=False)
    try:
        s = run_study(study, out_dir, scheduler=scheduler, workers=workers,
                      processes=not threads, trials=trials, max_trials=max_trials,
                      console=err_console)
    except KeyboardInterrupt:
        err_console.print(f"interrupted: finished trials are saved in {out_dir}/results; run the "
                          "same command again to resume", highlight=False)
        raise typer.Exit(EXIT_INTERRUPTED)
    t = Table(title=f"rfp-twin study {study.name} -> {out_dir}")
    t.add_column("quantity")
    t.add_column("value", justify="right")
    for k, v in (("trials in study", str(s.n_total)),
                 ("already done before this run", str(s.n_before)),
                 ("run now", str(s.n_run)),
                 ("failed trials (status error)", str(s.n_errors)),
                 ("trials with collisions (2D check)", str(s.n_collisions)),
                 ("cluster", f"{s.scheduler}, {s.workers} worker threads"),
                 ("start-up + resume scan", f"{s.setup_s:.1f} s"),
                 ("run time", f"{s.seconds:.1f} s"),
                 ("throughput", f"{s.rate_per_min:.1f} trials/min")):
        t.add_row(k, v)
    if study.coverage:
        t.add_row("coverage measured now (geometries)", str(s.n_coverage))
    if s.consolidated is not None:
        t.add_row("trials consolidated into", str(s.consolidated))
    console.print(t)
    if report:
        _report(out_dir, None, False)
    if s.n_collisions:
        raise fail(f"the 2D checker found collisions in {s.n_collisions} trial(s); see the "
                   "'collisions' column", EXIT_COLLISION)
    if not s.complete:
        err_console.print(f"{s.n_total - s.n_before - s.n_run} trial(s) left; run again to go on",
                          highlight=False)
        raise typer.Exit(EXIT_INCOMPLETE)


def _report(study_dir: Path, out: Optional[Path], all_points: bool) -> None:
    from rfp_twin.twin.studies.report import write_report

    rep = write_report(study_dir, out, all_points=all_points)
    console.print(f"report: {rep.markdown}")
    for f in rep.figures:
        console.print(f"  figure: {f}")
    for name, why in rep.skipped.items():
        console.print(f"  not drawn: {name} ({why})", highlight=False)
    if len(rep.trends) <= MAX_TRENDS_SHOWN:
        for name, ok in rep.trends.items():
            console.print(f"  trend {name}: {'yes' if ok else 'NO'}", highlight=False)
    elif rep.trends:
        console.print(f"  trends: {sum(rep.trends.values())} of {len(rep.trends)} hold (each "
                      f"in {rep.markdown.name})", highlight=False)


@study_app.command("report")
@one_line_errors
def report(
    study_dir: Path = typer.Argument(..., help=STUDY_DIR_HELP),
    out: Optional[Path] = typer.Option(None, help="Report folder (default: DIR/report)."),
    all_points: bool = typer.Option(False, "--all-points", help="Include rows of grid points "
                                    "no longer in the folder's study.toml."),
) -> None:
    """Write report.md and the figures (Sayres 2021 Figs. 10-18 style, feasibility map)."""
    _report(study_dir, out, all_points)


@study_app.command("consolidate")
@one_line_errors
def consolidate(
    study_dir: Path = typer.Argument(..., help=STUDY_DIR_HELP),
) -> None:
    """Merge a study folder's per-trial files into DIR/results/trials.parquet (verified, then
    the per-trial files are removed); `study run` does this itself when a study finishes."""
    from rfp_twin.twin.studies import consolidate_results
    from rfp_twin.twin.studies.spec import StudyError
    from rfp_twin.twin.studies.store import RESULTS, WriterLock, data_files

    results = study_dir / RESULTS
    if not results.is_dir():
        raise StudyError(f"{study_dir}: no {RESULTS}/ folder; allowed: a folder written by "
                         "`rfp-twin study run`")
    n_files = len(data_files(results))
    with WriterLock(results):
        merged = consolidate_results(study_dir)
    if merged is None:
        console.print(f"{results}: no trials to consolidate")
        return
    import pyarrow.parquet as pq

    console.print(f"{n_files} file(s) -> {merged} ({pq.ParquetFile(merged).metadata.num_rows} "
                  "trials)")


@study_app.command("list")
@one_line_errors
def list_cmd() -> None:
    """List the studies shipped with rfp-twin."""
    from rfp_twin.twin.studies import list_studies, load_study

    t = Table(title="shipped studies (twin/study_files/*.toml)")
    for c in ("name", "points", "trials/point", "trials", "description"):
        t.add_column(c)
    for name in list_studies():
        s = load_study(name)
        t.add_row(name, str(len(s.points)), str(s.trials), str(s.n_trials), s.description)
    console.print(t)
