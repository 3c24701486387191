"""Design studies (twin/studies.py, twin/study_report.py, twin/study_cli.py).

Tiny grids (7-37 robots), LocalClusters of at most 2 workers; the kill-and-resume test
runs the study in a subprocess and kills it with SIGKILL.
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest

from twin.studies import (COMPACT_PREFIX, RESULTS, SCHEMA, StudyError, _Lock, compact_results,
                          done_keys, list_studies, load_study, parse_study, read_results,
                          run_study, run_trial, write_row)
from twin.study_report import FIGURES, PAPER_FIG10, write_report

ROOT = Path(__file__).resolve().parents[2]

TINY = """
[study]
name = "tiny"
trials = 2
seed = 11
[grid]
n_robots = 19
buffer_mm = [1.5, 3.0]
step_deg = 0.5
algorithm = ["GC", "MC"]
"""

#: Varies every axis a figure needs (buffer, step, grid size, pitch / reach).
ALL_AXES = """
[study]
name = "all-axes"
trials = 3
seed = 5
[grid]
n_robots = [7, 19]
pitch_mm = [20.0, 22.4]
buffer_mm = [1.5, 2.5]
step_deg = [0.5, 1.0]
algorithm = ["greedy", "markov"]
"""

#: Results that must not depend on where or when a trial ran.
DETERMINISTIC = ("key", "point_id", "trial", "seed", "status", "efficiency", "convergence",
                 "fold_time_s", "n_replaced", "n_deadlocked", "rounds", "n_steps", "collisions")


def _study(text: str, tmp_path: Path, name: str = "study.toml"):
    path = tmp_path / name
    path.write_text(text)
    return load_study(path)


def _rows_by_key(table) -> dict:
    return {r["key"]: r for r in table.to_pylist()}


# ---------------------------------------------------------------------------------------
# Study files
# ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("text, words", [
    ("[grid]\nbufer_mm = 2.0\n", ["unknown key 'bufer_mm' in table 'grid'", "buffer_mm", "step_deg"]),
    ("[study]\ntrails = 3\n", ["unknown key 'trails' in table 'study'", "trials"]),
    ("[grids]\n", ["unknown table or key 'grids'", "tables 'study' and 'grid'"]),
    ("[grid]\nalgorithm = ['greedy', 'astar']\n", ["grid.algorithm = 'astar'",
                                                  "greedy | markov"]),
    ("[grid]\nn_robots = 500\n", ["grid.n_robots = 500", "nearest: 469, 547"]),
    ("[grid]\nbuffer_mm = [2.0, 12.0]\n", ["buffer_mm = 12.0", "pitch_mm / 2 = 11.2"]),
    ("[grid]\nstep_deg = 0\n", ["grid.step_deg = 0", "[0.001, 10]"]),
    ("[grid]\ngreed = 1.5\n", ["grid.greed = 1.5", "[0, 1]"]),
    ("[grid]\nresolution = 'roadmap'\n", ["grid.resolution = 'roadmap'", "replace | search | none"]),
    ("[grid]\nbuffer_mm = []\n", ["grid.buffer_mm = []", "non-empty list"]),
    ("[grid]\nbuffer_mm = [2.0, 2.0]\n", ["without repeated values"]),
    ("[grid]\npreset = 'nope'\n", ["grid.preset = 'nope'", "sdss-v"]),
    ("[study]\ntrials = 0\n", ["study.trials = 0", "integer >= 1"]),
    ("[study]\ncheck = 'yes'\n", ["study.check = 'yes'", "true | false"]),
    ("[study]\nname = 'a b'\n", ["study.name = 'a b'", "folder-safe"]),
    ("[study\n", ["malformed TOML"]),
])
def test_bad_study_files_name_the_key_and_the_allowed_values(tmp_path, text, words):
    with pytest.raises(StudyError) as info:
        _study(text, tmp_path, "bad.toml")
    msg = str(info.value)
    assert str(tmp_path / "bad.toml") in msg and "\n" not in msg
    for w in words:
        assert w in msg, msg


def test_shipped_studies_match_the_paper_tables():
    names = list_studies()
    for n in ("sim1", "sim1-small", "sim2", "sim2-small", "sim3", "sim3-small", "density",
              "density-small"):
        assert n in names
    sim1, sim2, sim3 = load_study("sim1"), load_study("sim2"), load_study("sim3")
    assert sim1.n_trials == 36000 and sim2.n_trials == 18000 and sim3.n_trials == 6000
    assert sim1.grid["buffer_mm"] == (1.5, 1.75, 2.0, 2.25, 2.5, 2.75, 3.0, 3.25, 3.5)
    assert sim2.grid["step_deg"] == (0.05, 0.1, 0.25, 0.5, 0.75, 1.0)
    assert sim3.grid["n_robots"][0] == 37 and sim3.grid["n_robots"][-3:] == (2269, 2611, 2977)
    for s in (sim1, sim2, sim3):
        for p in s.points:
            assert (p.alpha_length_mm, p.beta_length_mm, p.pitch_mm) == (7.4, 15.0, 22.4)
            assert p.spec.fold_deg == (10.0, 170.0)
            assert p.max_steps == round(1000 / p.step_deg)
            assert (p.greed, p.phobia) == ((0.9, 0.3) if p.algorithm == "markov" else (1.0, 0.0))
    # the small versions are the first trials of the full ones (same keys)
    small = {t.key for t in load_study("sim1-small").trial_list()}
    assert small == {t.key for t in sim1.trial_list(6)}


def test_trial_seeds_and_keys_are_stable_and_distinct(tmp_path):
    a = _study(TINY, tmp_path).trial_list()
    b = parse_study(TINY).trial_list()
    assert [(t.key, t.seed) for t in a] == [(t.key, t.seed) for t in b]
    assert len({t.key for t in a}) == len(a) == 8 and len({t.seed for t in a}) == 8
    assert all(0 <= t.seed < 2**63 for t in a)
    # the base seed changes every trial; greed does not matter for greedy points
    other = parse_study(TINY.replace("seed = 11", "seed = 12")).trial_list()
    assert not {t.key for t in a} & {t.key for t in other}
    g = parse_study(TINY.replace('algorithm = ["GC", "MC"]', 'algorithm = "GC"\ngreed = [0.5, 0.9]'))
    assert len(g.points) == 2  # two buffers; greed collapses for GC


def test_trial_is_deterministic_and_its_seed_replays_it(tmp_path):
    study = _study(TINY, tmp_path)
    t = study.trial_list()[3]
    r1 = run_trial(t.point, t.index, study.seed, check=True)
    r2 = run_trial(t.point, t.index, study.seed, check=True)
    for k in DETERMINISTIC:
        assert r1[k] == r2[k], k
    assert r1["seed"] == t.seed and r1["key"] == t.key and r1["collisions"] == 0
    # a trial is random_targets + plan_reconfiguration on default_rng(seed), as `rfp-twin plan`
    from tests.planners.conftest import make_geom, plan_random

    geom = make_geom(19, t.point.buffer_mm)
    _, plan = plan_random(geom, t.seed, algorithm=t.point.algorithm, step_deg=t.point.step_deg)
    assert plan.metrics["efficiency"] == r1["efficiency"]
    assert plan.metrics["n_steps"] == r1["n_steps"]


def test_infeasible_points_are_recorded_not_raised(tmp_path):
    # pitch 16 mm with a 3.5 mm buffer: the folded state (10, 170) already collides
    study = parse_study("[grid]\nn_robots = 7\npitch_mm = 16.0\nbuffer_mm = 3.5\n")
    t = study.trial_list()[0]
    row = run_trial(t.point, 0, study.seed)
    assert row["status"] == "error" and "folded state" in row["error"]
    assert row.get("efficiency") is None and row["wall_s"] >= 0


# ---------------------------------------------------------------------------------------
# Running on Dask, resuming
# ---------------------------------------------------------------------------------------
def test_tiny_study_runs_on_a_local_cluster_of_processes(tmp_path):
    study = _study(TINY, tmp_path)
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
    a, b = _rows_by_key(table), _rows_by_key(read_results(tmp_path / "other"))
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
    proc = subprocess.Popen([sys.executable, "-m", "twin.cli", "study", "run", str(path), "--out",
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

    s = run_study(study, out, workers=1, processes=False, progress=False)
    assert s.n_before == n_killed and s.n_run == total - n_killed and s.complete
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


def test_partial_runs_duplicates_and_compaction(tmp_path):
    study = _study(TINY, tmp_path)
    out = tmp_path / "out"
    s = run_study(study, out, workers=1, processes=False, progress=False, max_trials=3)
    assert s.n_run == 3 and not s.complete
    s = run_study(study, out, workers=1, processes=False, progress=False)
    assert s.n_before == 3 and s.n_run == 5 and s.complete
    results = out / RESULTS
    # a compaction killed between its rename and its deletes leaves rows twice: reads dedupe
    dup = results / f"{COMPACT_PREFIX}x.parquet"
    dup.write_bytes(sorted(results.glob("part-*.parquet"))[0].read_bytes())
    assert read_results(out).num_rows == 8 and len(done_keys(out)) == 8
    merged = compact_results(out)
    assert [p.name for p in results.glob("*.parquet")] == [merged.name]
    assert pq.read_table(merged).num_rows == 8
    assert run_study(study, out, workers=1, processes=False, progress=False).n_run == 0
    # more trials per point later extend the same study
    s = run_study(study, out, workers=1, processes=False, progress=False, trials=3)
    assert s.n_before == 8 and s.n_run == 4 and read_results(out).num_rows == 12


def test_runs_on_an_existing_scheduler(tmp_path):
    """--scheduler ADDR: the same study on a cluster started elsewhere (here: in-process)."""
    from distributed import LocalCluster

    study = _study(TINY.replace("trials = 2", "trials = 1"), tmp_path)
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                      dashboard_address=None) as cluster:
        s = run_study(study, tmp_path / "out", scheduler=cluster.scheduler_address,
                      progress=False)
        assert s.complete and s.n_run == 4 and s.scheduler == cluster.scheduler_address
        assert cluster.scheduler.workers  # still up: run_study does not close it
    assert read_results(tmp_path / "out").num_rows == 4


def test_one_writer_per_study_folder(tmp_path):
    study = _study(TINY, tmp_path)
    results = tmp_path / "out" / RESULTS
    results.mkdir(parents=True)
    with _Lock(results):
        with pytest.raises(StudyError, match="another run of this study is writing here"):
            run_study(study, tmp_path / "out", workers=1, processes=False, progress=False)


# ---------------------------------------------------------------------------------------
# Reports
# ---------------------------------------------------------------------------------------
def test_report_renders_every_figure(tmp_path):
    study = _study(ALL_AXES, tmp_path)
    out = tmp_path / "out"
    run_study(study, out, workers=1, processes=False, progress=False)
    rep = write_report(out)
    assert not rep.skipped
    assert sorted(p.stem for p in rep.figures) == sorted(FIGURES)
    for p in rep.figures:
        data = p.read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000, p
    md = rep.markdown.read_text()
    for stem in FIGURES:
        assert f"({stem}.png)" in md
    assert "## Results per grid point" in md and "## Trends vs buffer" in md
    assert "rfp-twin plan --preset sdss-v" in md


def test_report_puts_the_papers_fig10_beside_ours(tmp_path):
    """Rows shaped like Simulation 1 (synthetic metrics, real keys): the comparison table."""
    study = load_study("sim1-small")
    out = tmp_path / "sim1"
    results = out / RESULTS
    results.mkdir(parents=True)
    (out / "study.toml").write_text(study.text)
    rng = np.random.default_rng(0)
    for t in study.trial_list(3):
        p = t.point
        slope, offset = (0.02, 0.002) if p.algorithm == "greedy" else (0.005, 0.0)
        base = 1.0 - offset - slope * (p.buffer_mm - 1.5)
        row = dict(p.to_dict(), key=t.key, study=study.name, point_id=p.point_id, trial=t.index,
                   base_seed=study.seed, seed=t.seed, n_fiducials=0, reach_mm=22.4,
                   pitch_over_reach=1.0, status="ok", efficiency=base - rng.uniform(0, 1e-4),
                   convergence=base, fold_time_s=12.0 if p.algorithm == "greedy" else 24.0,
                   tau_pg_s=0.1, tau_sr_s=0.2, n_replaced=1, n_deadlocked=0, rounds=1,
                   n_steps=1000, checked=True, collisions=0, min_clearance_mm=0.1,
                   check_s=0.1, wall_s=0.5, worker="test")
        write_row(results, row)
    rep = write_report(out)
    md = rep.markdown.read_text()
    assert "## Beside Sayres 2021 Simulation 1" in md
    assert "| GC | 3.5 | 3 |" in md and "0.968" in md and "0.993" in md
    assert rep.trends["monotonic GC"] and rep.trends["monotonic MC"] and rep.trends["MC >= GC"]
    assert set(PAPER_FIG10) <= {(p.algorithm, p.buffer_mm) for p in study.points}
    assert {"fig15_efficiency_vs_step", "feasibility_map"} <= set(rep.skipped)


# ---------------------------------------------------------------------------------------
# CLI
# ---------------------------------------------------------------------------------------
def _cli(*args, cwd=ROOT):
    return subprocess.run([sys.executable, "-m", "twin.cli", "study", *args], capture_output=True,
                          text=True, cwd=cwd, timeout=120)


def test_cli_run_report_and_errors(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[grid]\nbuffer = 2.0\n")
    r = _cli("run", str(bad))
    assert r.returncode == 2
    assert r.stderr.strip().count("\n") == 0 and "unknown key 'buffer' in table 'grid'" in r.stderr
    r = _cli("run", "no-such-study")
    assert r.returncode == 2 and "sim1-small" in r.stderr
    good = tmp_path / "good.toml"
    good.write_text(TINY.replace("trials = 2", "trials = 1"))
    r = _cli("run", str(good), "--out", str(tmp_path / "o"), "--workers", "1", "--threads",
             "--report")
    assert r.returncode == 0, r.stderr
    assert "throughput" in r.stdout and "report:" in r.stdout
    assert (tmp_path / "o" / "report" / "fig10_efficiency_mean.png").is_file()
    r = _cli("report", str(tmp_path / "nothing"))
    assert r.returncode == 2 and "no results/ folder" in r.stderr


def test_field_planners_run_as_study_algorithms(tmp_path):
    """apf / capf trials: checked, no replacement, efficiency = converged fraction."""
    text = TINY.replace('algorithm = ["GC", "MC"]', 'algorithm = ["apf", "capf"]').replace(
        "buffer_mm = [1.5, 3.0]", "buffer_mm = 2.0")
    study = _study(text, tmp_path)
    s = run_study(study, tmp_path / "out", workers=1, processes=False, progress=False)
    assert s.complete and s.n_run == 4 and s.n_collisions == 0
    rows = list(_rows_by_key(read_results(tmp_path / "out")).values())
    assert {r["algorithm"] for r in rows} == {"apf", "capf"}
    for r in rows:
        assert r["status"] in ("ok", "deadlocked") and r["error"] is None
        assert r["n_replaced"] == 0 and r["collisions"] == 0
        assert r["efficiency"] == pytest.approx(1 - r["n_deadlocked"] / 19)
        assert 0.0 < r["fold_time_s"] < 60.0
