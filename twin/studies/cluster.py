"""Where study trials run: a Dask cluster, trials batched into tasks, rows as they finish.

By default on a ``LocalCluster`` sized to the machine (one single-threaded worker process
per core: the numba kernels hold the GIL). ``scheduler="tcp://HOST:8786"`` (CLI:
``--scheduler``) sends the same study to any running Dask cluster whose workers have
rfp-twin installed (same version); the address is tried for :data:`CONNECT_TIMEOUT_S`
seconds before anything is written. On a SLURM cluster use dask-jobqueue::

    # on the login node, e.g. in a Python session kept open (or a script with input())
    from dask_jobqueue import SLURMCluster
    cluster = SLURMCluster(cores=1, processes=1, memory="2GB", walltime="04:00:00",
                           job_extra_directives=["--partition=short"])
    cluster.scale(jobs=64)                 # or cluster.adapt(maximum_jobs=64)
    print(cluster.scheduler_address)       # tcp://10.0.0.5:8786

    $ rfp-twin study run sim1 --scheduler tcp://10.0.0.5:8786

or from Python: ``run_study(load_study("sim1"), client=Client(cluster))``. The client
(login node) writes the Parquet rows; kill it and run it again to resume.

Trials go to the workers in batches (a few small-grid trials per task, a 547-robot trial
on its own, see :func:`batches`); a batch comes back, and is written, together. At most
three tasks per worker thread are in flight, so a killed run loses little work.
"""
from __future__ import annotations

import itertools
import time
from pathlib import Path
from typing import TYPE_CHECKING

from rfp_twin.twin.cores import usable_cores
from rfp_twin.twin.studies.runner import run_batch
from rfp_twin.twin.studies.spec import Study, StudyError, Trial
from rfp_twin.twin.studies.store import write_row

if TYPE_CHECKING:  # pragma: no cover
    from rfp_twin.twin.studies.run import RunSummary

__all__ = ["machine_workers", "batches", "connect", "local_client", "drive", "CONNECT_TIMEOUT_S"]

#: Robots per Dask task when ``batch = "auto"`` (a 547-grid trial is its own task).
AUTO_BATCH_ROBOTS = 300
AUTO_BATCH_MAX = 32
#: Seconds to reach a scheduler given by address before the run gives up.
CONNECT_TIMEOUT_S = 10.0


def machine_workers() -> int:
    """Worker processes of the default LocalCluster: the cores this process may use."""
    return usable_cores()


def batches(trials: list[Trial], batch: str | int) -> list[list[Trial]]:
    """Trials in order, cut into Dask tasks of ``batch`` trials, or for ``"auto"`` of
    about :data:`AUTO_BATCH_ROBOTS` robots (at most :data:`AUTO_BATCH_MAX` trials)."""
    out: list[list[Trial]] = []
    cur: list[Trial] = []
    robots = 0
    for t in trials:
        cur.append(t)
        robots += t.point.n_robots
        full = (len(cur) >= batch) if batch != "auto" else \
            (robots >= AUTO_BATCH_ROBOTS or len(cur) >= AUTO_BATCH_MAX)
        if full:
            out.append(cur)
            cur, robots = [], 0
    if cur:
        out.append(cur)
    return out


def connect(scheduler: str):
    """A ``distributed.Client`` of the running scheduler at ``scheduler``; StudyError when
    it does not answer within :data:`CONNECT_TIMEOUT_S`."""
    from distributed import Client

    try:
        return Client(scheduler, timeout=f"{CONNECT_TIMEOUT_S:g}s")
    except (OSError, TimeoutError, ValueError) as exc:
        raise StudyError(f"cannot reach the Dask scheduler at {scheduler!r} "
                         f"({type(exc).__name__}: {exc}); allowed: the address "
                         "of a running scheduler, e.g. tcp://HOST:8786") from None


def local_client(workers: int | None, processes: bool):
    """A new LocalCluster (``workers`` single-threaded workers, default one per core) and
    its Client: ``(cluster, client)``."""
    from distributed import Client, LocalCluster

    cluster = LocalCluster(n_workers=workers or machine_workers(), threads_per_worker=1,
                           processes=processes, dashboard_address=None,
                           silence_logs=50)  # logging.CRITICAL: no heartbeat noise at close
    return cluster, Client(cluster)


def drive(client, study: Study, todo: list[list[Trial]], results: Path, summary: "RunSummary",
          n_threads: int, progress, console) -> None:
    """Submit batches with a bounded window; write rows as results arrive and count them
    in ``summary``. A failing task stops new submissions; what finished is kept and the
    failure is raised at the end."""
    from distributed import as_completed

    it = iter(todo)
    by_key: dict[str, list[Trial]] = {}
    bar = task = None
    callback = progress if callable(progress) else None
    if progress is True:
        bar, task = _progress_bar(study.name, summary.n_total, summary.n_before, console)

    def submit(b: list[Trial]):
        items = [(t.point.to_dict(), t.point.spec, t.index, t.seed, t.key, t.point.ids())
                 for t in b]
        fut = client.submit(run_batch, items, study.check, study.name, study.seed,
                            study.firmware, exposure_s=study.exposure_s,
                            key=f"rfp-study-{b[0].key}", pure=False)
        by_key[fut.key] = b
        return fut

    def window() -> int:
        # 3 tasks per worker thread in flight; re-read as workers join (adaptive clusters)
        try:
            threads = sum(client.nthreads().values())
        except Exception:  # pragma: no cover (scheduler gone: as_completed will say so)
            threads = n_threads
        return max(4, 3 * threads)

    t0 = time.perf_counter()
    failure: BaseException | None = None
    ac = as_completed([submit(b) for b in itertools.islice(it, window())])
    target, checked_at = window(), time.perf_counter()
    try:
        for fut in ac:
            batch = by_key.pop(fut.key)
            try:
                rows = fut.result()
            except Exception as exc:  # a bug in a trial: stop submitting, keep what finished
                if failure is None:
                    failure = exc
                    exc.add_note(f"rfp-twin study {study.name}: trial {batch[0].key} "
                                 f"(point {batch[0].point.point_id}, trial {batch[0].index}) "
                                 "failed; finished trials are saved, run again to resume")
                continue
            for row in rows:
                write_row(results, row)
                summary.n_run += 1
                summary.n_errors += row["status"] == "error"
                summary.n_collisions += bool(row.get("collisions"))
            summary.seconds = time.perf_counter() - t0
            if bar is not None:
                bar.update(task, completed=summary.n_before + summary.n_run,
                           rate=f"{summary.rate_per_min:.1f} trials/min")
            if callback is not None:
                callback(summary.n_before + summary.n_run, summary.n_total)
            if failure is None:
                if time.perf_counter() - checked_at > 2.0:
                    target, checked_at = window(), time.perf_counter()
                while len(by_key) < target:
                    nxt = next(it, None)
                    if nxt is None:
                        break
                    ac.add(submit(nxt))
    finally:
        summary.seconds = time.perf_counter() - t0
        if bar is not None:
            bar.stop()
    if failure is not None:
        raise failure


def _progress_bar(name: str, total: int, done: int, console):
    """A started rich bar: trials done / total, trials per minute, elapsed, eta."""
    from rich.console import Console
    from rich.progress import (BarColumn, MofNCompleteColumn, Progress, TextColumn,
                               TimeElapsedColumn, TimeRemainingColumn)

    bar = Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(),
                   TextColumn("trials  {task.fields[rate]}"), TimeElapsedColumn(),
                   TextColumn("eta"), TimeRemainingColumn(),
                   console=console or Console(stderr=True))
    task = bar.add_task(name, total=total, completed=done, rate="-- trials/min")
    bar.start()
    return bar, task
