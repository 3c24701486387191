"""Run a study: resume scan, the trials left on a Dask cluster, a summary of the run.

:func:`run_study` checks its arguments and reaches the scheduler it is given before it
writes anything (a bad address leaves no folder behind), then takes the study folder's
writer lock, copies the definition to ``study.toml``, measures the coverage of geometries
not yet measured (studies with ``coverage = true``, :mod:`rfp_twin.twin.studies.coverage`),
skips every trial already in ``results/`` and runs the others
(:mod:`rfp_twin.twin.studies.cluster`), writing each row as it comes back
(:mod:`rfp_twin.twin.studies.store`). When the study is complete, its per-trial files are
consolidated into ``results/trials.parquet`` (:func:`~rfp_twin.twin.studies.store.consolidate_results`).
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from rfp_twin.twin.studies.cluster import batches, connect, drive, local_client
from rfp_twin.twin.studies.coverage import update_coverage
from rfp_twin.twin.studies.parse import is_int
from rfp_twin.twin.studies.spec import Study, StudyError
from rfp_twin.twin.studies.store import (COMPACT_AT, RESULTS, WriterLock, compact_results,
                                         consolidate_results, data_files, default_out_dir,
                                         done_keys, write_study_copy)

__all__ = ["RunSummary", "run_study"]


@dataclass
class RunSummary:
    """What :func:`run_study` did.

    n_total : trials in the study; n_before : already written when the run started;
    n_run : written by this run; n_errors / n_collisions : trials of this run with an
    error / with collisions found; seconds : from the first submission to the last
    result; setup_s : cluster start-up and resume scan; workers : Dask worker threads;
    rate_per_min : n_run / seconds * 60; complete : every trial is written;
    n_coverage : geometries whose coverage this run measured; consolidated : the file
    the finished study's trials were merged into (None: not complete, or not asked).
    """

    study: str
    out_dir: Path
    n_total: int
    n_before: int
    n_run: int
    n_errors: int
    n_collisions: int
    seconds: float
    setup_s: float
    workers: int
    scheduler: str
    complete: bool
    n_coverage: int = 0
    consolidated: Path | None = None

    @property
    def rate_per_min(self) -> float:
        return 60.0 * self.n_run / self.seconds if self.seconds > 0 else 0.0


def run_study(study: Study, out_dir: str | Path | None = None, *, scheduler: str | None = None,
              workers: int | None = None, processes: bool = True, client=None,
              trials: int | None = None, max_trials: int | None = None,
              progress: bool | Callable[[int, int], None] = True, console=None,
              consolidate: bool = True) -> RunSummary:
    """Run every trial of ``study`` not yet in ``out_dir/results``; write each as it finishes.

    Parameters
    ----------
    study : Study
    out_dir : study folder (default ``out/studies/<name>``); gets ``study.toml`` (a copy of
        the definition) and ``results/`` (the Parquet dataset).
    scheduler : ``tcp://HOST:PORT`` of a running Dask scheduler; default a new LocalCluster.
    workers : LocalCluster worker count (default: the cores of this machine).
    processes : LocalCluster workers as processes (True) or threads of this process.
    client : an existing ``distributed.Client`` to use instead (not closed here).
    trials : trials per point instead of the study's (keys do not depend on it, so a larger
        value later extends the same study).
    max_trials : stop after this many new trials (a partial run; run again to go on).
    progress : True: a rich progress bar (trials done / total, trials per minute);
        a callable(done, total); or False.
    console : rich Console for messages and the bar (default stderr).
    consolidate : merge the per-trial files into ``results/trials.parquet`` once every
        trial is written (verified before the per-trial files are removed).

    Returns
    -------
    RunSummary
    """
    t_setup = time.perf_counter()
    if scheduler is not None and client is not None:
        raise StudyError("give either scheduler or client, not both")
    if workers is not None and (not is_int(workers) or workers < 1):
        raise StudyError(f"workers = {workers!r}; allowed: an integer >= 1")
    if trials is not None and (not is_int(trials) or trials < 1):
        raise StudyError(f"trials = {trials!r}; allowed: an integer >= 1")
    out = Path(out_dir) if out_dir is not None else default_out_dir(study)
    results = out / RESULTS
    given = client
    own_cluster = own_client = None
    if scheduler is not None:
        own_client = client = connect(scheduler)   # before anything is written
    try:
        results.mkdir(parents=True, exist_ok=True)
        with WriterLock(results):
            for stale in results.glob(".*.tmp"):      # left by a killed run
                stale.unlink(missing_ok=True)
            write_study_copy(out, study)
            n_coverage = update_coverage(study, out) if study.coverage else 0
            if len(data_files(results)) >= COMPACT_AT:
                compact_results(out)
            all_trials = study.trial_list(trials)
            done = done_keys(out)
            todo = [t for t in all_trials if t.key not in done]
            n_before = len(all_trials) - len(todo)
            if max_trials is not None:
                todo = todo[:max(0, int(max_trials))]
            tasks = batches(todo, study.batch)
            if tasks and client is None:
                own_cluster, own_client = local_client(workers, processes)
                client = own_client
            if not (tasks or given is not None):
                n_threads, sched = 0, "none (nothing left to run)"
            else:
                n_threads = max(1, sum(client.nthreads().values()))
                sched = scheduler or (f"LocalCluster({len(client.nthreads())} "
                                      f"{'processes' if processes else 'threads'})"
                                      if own_cluster else str(client.scheduler.address))
            summary = RunSummary(study.name, out, len(all_trials), n_before, 0, 0, 0, 0.0,
                                 time.perf_counter() - t_setup, n_threads, sched, False,
                                 n_coverage)
            if tasks:
                drive(client, study, tasks, results, summary, n_threads, progress, console)
            if summary.n_before + summary.n_run >= summary.n_total and consolidate:
                summary.consolidated = consolidate_results(out)
            elif len(data_files(results)) >= COMPACT_AT:
                compact_results(out)
    finally:
        if own_client is not None:
            own_client.close()
        if own_cluster is not None:
            own_cluster.close()
    summary.complete = summary.n_before + summary.n_run >= summary.n_total
    return summary
