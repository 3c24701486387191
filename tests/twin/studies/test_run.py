"""Running a study (twin/studies/run.py) on Dask: rows, resume, schedulers, the lock.

Tiny grids (19-37 robots), LocalClusters of at most 2 workers; the kill-and-resume test
runs the study in a subprocess and kills it with SIGKILL.
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from tests.twin.studies.builders import DETERMINISTIC, TINY, rows_by_key, study_file
from tests.twin.studies.test_cluster import free_port
from rfp_twin.twin.studies import (CONSOLIDATED, RESULTS, SCHEMA, StudyError, consolidate_results,
                                   done_keys, load_study, read_results, run_study)
from rfp_twin.twin.studies import cluster
from rfp_twin.twin.studies.store import WriterLock

ROOT = Path(__file__).resolve().parents[3]


def test_tiny_study_runs_on_a_local_cluster_of_processes(tmp_path):
    study = study_file(TINY, tmp_path)
    seen = []
    s = run_study(study, tmp_path / "out", workers=2, processes=True,
                  progress=lambda done, total: seen.append((done, total)))
    assert s.complete and s.n_run == 8 and s.n_before == 0 and s.workers == 2
    assert s.n_collisions == 0 and s.rate_per_min > 0
    assert seen[-1] == (8, 8)
    table = read_results(tmp_path / "out")
    assert table.schema.equals(SCHEMA)
    assert sorted(table.column("key").to_pylist()) == sorted(t.key for t in study.trial_list())
    assert (tmp_path / "out" / "study.toml").read_text() == TINY
    # same rows as a threaded run elsewhere: nothing depends on the worker
    s2 = run_study(study, tmp_path / "other", workers=1, processes=False, progress=False)
    assert s2.n_run == 8
    a, b = rows_by_key(table), rows_by_key(read_results(tmp_path / "other"))
    for key in a:
        for col in DETERMINISTIC:
            assert a[key][col] == b[key][col], (key, col)
    # each row carries every parameter
    row = next(iter(a.values()))
    for col in ("preset", "n_robots", "pitch_mm", "alpha_length_mm", "beta_length_mm",
                "buffer_mm", "step_deg", "algorithm", "greed", "phobia", "resolution", "seed",
                "efficiency", "convergence", "fold_time_s", "tau_pg_s", "tau_sr_s", "n_replaced",
                "collisions"):
        assert row[col] is not None, col
    # a second run has nothing to do
    again = run_study(study, tmp_path / "out", workers=1, processes=False, progress=False)
    assert again.n_run == 0 and again.n_before == 8 and again.complete and again.workers == 0


def test_killed_study_resumes_with_every_trial_exactly_once(tmp_path):
    text = TINY.replace("trials = 2", "trials = 30\nbatch = 1").replace("n_robots = 19",
                                                                           "n_robots = 37")
    path = tmp_path / "kill.toml"
    path.write_text(text)
    study = load_study(path)
    total = study.n_trials
    out = tmp_path / "out"
    results = out / RESULTS
    proc = subprocess.Popen([sys.executable, "-m", "rfp_twin.twin.cli", "study", "run", str(path), "--out",
                             str(out), "--workers", "1", "--threads"], cwd=ROOT,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            start_new_session=True)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            if results.is_dir() and len(list(results.glob("part-*.parquet"))) >= 12:
                break
            if proc.poll() is not None:
                pytest.fail(f"the study ended before it was killed: {proc.stderr.read()!r}")
            time.sleep(0.01)
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
        proc.stderr.close()
    assert proc.returncode == -signal.SIGKILL
    n_killed = len(list(results.glob("part-*.parquet")))
    assert 12 <= n_killed < total, "the kill came too late to test a resume"
    before = done_keys(out)

    # per-trial files kept (consolidate=False) to check each trial is written exactly once
    s = run_study(study, out, workers=1, processes=False, progress=False, consolidate=False)
    assert s.n_before == n_killed and s.n_run == total - n_killed and s.complete
    assert s.consolidated is None
    files = sorted(results.glob("part-*.parquet"))
    assert len(files) == total
    assert not list(results.glob(".*.tmp"))
    keys = []
    for f in files:
        t = pq.read_table(f)
        assert t.num_rows == 1
        keys.append(t.column("key")[0].as_py())
        assert f.name == f"part-{keys[-1]}.parquet"
    assert len(set(keys)) == total
    assert set(keys) == {t.key for t in study.trial_list()} and before <= set(keys)
    table = read_results(out)
    assert table.num_rows == total
    assert sorted(table.column("trial").to_pylist()) == sorted(t.index for t in study.trial_list())
    # then merged into one file, the per-trial files removed
    merged = consolidate_results(out)
    assert [p.name for p in results.glob("*.parquet")] == [CONSOLIDATED] == [merged.name]
    assert pq.read_table(results).num_rows == total


def test_partial_runs_and_more_trials_later(tmp_path):
    study = study_file(TINY, tmp_path)
    out = tmp_path / "out"
    s = run_study(study, out, workers=1, processes=False, progress=False, max_trials=3)
    assert s.n_run == 3 and not s.complete
    s = run_study(study, out, workers=1, processes=False, progress=False)
    assert s.n_before == 3 and s.n_run == 5 and s.complete
    # more trials per point later extend the same study
    s = run_study(study, out, workers=1, processes=False, progress=False, trials=3)
    assert s.n_before == 8 and s.n_run == 4 and read_results(out).num_rows == 12


def test_runs_on_an_existing_scheduler(tmp_path):
    """--scheduler ADDR: the same study on a cluster started elsewhere (here: in-process)."""
    from distributed import LocalCluster

    study = study_file(TINY.replace("trials = 2", "trials = 1"), tmp_path)
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                      dashboard_address=None) as lc:
        s = run_study(study, tmp_path / "out", scheduler=lc.scheduler_address, progress=False)
        assert s.complete and s.n_run == 4 and s.scheduler == lc.scheduler_address
        assert lc.scheduler.workers  # still up: run_study does not close it
    assert read_results(tmp_path / "out").num_rows == 4


def test_an_unreachable_scheduler_leaves_nothing_behind(tmp_path, monkeypatch):
    monkeypatch.setattr(cluster, "CONNECT_TIMEOUT_S", 1.0)
    study = study_file(TINY, tmp_path)
    out = tmp_path / "deep" / "out"
    with pytest.raises(StudyError, match="cannot reach the Dask scheduler"):
        run_study(study, out, scheduler=f"tcp://127.0.0.1:{free_port()}", progress=False)
    assert not (tmp_path / "deep").exists()


@pytest.mark.parametrize("kwargs, words", [
    (dict(workers=0), "workers = 0"), (dict(trials=1.5), "trials = 1.5"),
    (dict(scheduler="tcp://127.0.0.1:1", client=object()), "either scheduler or client"),
])
def test_bad_arguments_leave_nothing_behind(tmp_path, kwargs, words):
    with pytest.raises(StudyError, match=words):
        run_study(study_file(TINY, tmp_path), tmp_path / "out", progress=False, **kwargs)
    assert not (tmp_path / "out").exists()


def test_one_run_per_study_folder(tmp_path):
    study = study_file(TINY, tmp_path)
    results = tmp_path / "out" / RESULTS
    results.mkdir(parents=True)
    with WriterLock(results):
        with pytest.raises(StudyError, match="another run of this study is writing here"):
            run_study(study, tmp_path / "out", workers=1, processes=False, progress=False)
