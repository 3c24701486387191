"""A tiny design study end to end, through the code path of `rfp-twin study run`: on a Dask
scheduler given by address, coverage once per geometry, search and replace on the same
targets, the finished study consolidated into one file, resumed and extended from it."""
from __future__ import annotations

import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

from tests.twin.studies.builders import study_file
from tests.twin.studies.test_design_spec import DESIGN
from rfp_twin.twin.cli.study import study_app
from rfp_twin.twin.studies import CONSOLIDATED, RESULTS, done_keys, read_coverage, run_study
from rfp_twin.twin.studies.frontier import design_results


@pytest.fixture(scope="module")
def scheduler():
    """A LocalCluster started here (threads: no process start-up), by address only."""
    from distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                      dashboard_address=None) as lc:
        yield lc.scheduler_address


def test_design_study_on_a_scheduler_address(tmp_path, scheduler):
    path = tmp_path / "tiny-design.toml"
    path.write_text(DESIGN)
    out = tmp_path / "out"
    r = CliRunner().invoke(study_app, ["run", str(path), "--out", str(out), "--scheduler",
                                       scheduler, "--report"])
    assert r.exit_code == 0, r.output
    assert "trials consolidated into" in r.stdout and "report:" in r.stdout
    # one file of trials, read by pyarrow (what pandas.read_parquet(folder) calls) in one call
    results = out / RESULTS
    assert [p.name for p in results.glob("*.parquet")] == [CONSOLIDATED]
    table = pq.read_table(results)
    assert table.num_rows == 12 and len(set(table.column("key").to_pylist())) == 12
    rows = table.to_pylist()
    assert {r["worker"].rsplit(":", 1)[1] for r in rows}          # ran on the cluster's workers
    for row in rows:
        assert row["status"] in ("ok", "deadlocked") and row["collisions"] == 0
        assert 0.0 <= row["kept"] <= row["efficiency"] <= 1.0
        assert row["plan_s"] >= 0 and row["fold_fw_s"] >= row["fold_time_s"] > 0
        assert row["family"] in ("raft", "sdss") and row["targets_hash"]
        assert row["arm_ratio"] == pytest.approx(row["alpha_length_mm"] / row["beta_length_mm"])
    # search and replace planned the same targets: pairs share seed and targets
    pairs: dict = {}
    for row in rows:
        pairs.setdefault((row["design_id"], row["trial"]), []).append(row)
    assert len(pairs) == 6
    for pair in pairs.values():
        assert sorted(r["resolution"] for r in pair) == ["replace", "search"]
        assert pair[0]["seed"] == pair[1]["seed"]
        assert pair[0]["targets_hash"] == pair[1]["targets_hash"]
    assert len({r["targets_hash"] for r in rows}) == 6
    # coverage: once per geometry (2 raft arm ratios + 1 sdss), not per trial
    cov = read_coverage(out).to_pylist()
    assert len(cov) == 3 == len({r["geometry_id"] for r in rows})
    for c in cov:
        assert 0.0 <= c["cover_3"] <= c["cover_2"] <= c["cover_1"] <= 1.0
        assert c["cover_1"] > 0.9 and c["cover_2"] > 0.1
    raft = [c for c in cov if c["layout"] == "raft"]
    assert all(c["raft_fraction_mean"] > 0.5 for c in raft)
    # the report's frontier
    assert (out / "report" / "frontier.png").is_file()
    assert "Design frontier" in (out / "report" / "report.md").read_text()
    assert len(design_results(out)) == 6


def test_resume_reads_the_consolidated_file(tmp_path):
    study = study_file(DESIGN.replace("trials = 2", "trials = 1"), tmp_path)
    out = tmp_path / "out"
    first = run_study(study, out, workers=1, processes=False, progress=False)
    assert first.complete and first.n_run == 6 and first.n_coverage == 3
    assert first.consolidated == out / RESULTS / CONSOLIDATED
    keys = done_keys(out)
    assert len(keys) == 6
    # finished: a rerun runs nothing, measures nothing, keeps the one file
    again = run_study(study, out, workers=1, processes=False, progress=False)
    assert (again.n_before, again.n_run, again.n_coverage) == (6, 0, 0)
    assert [p.name for p in (out / RESULTS).glob("*.parquet")] == [CONSOLIDATED]
    # more trials later: the consolidated rows count as done, new ones are added and merged
    more = run_study(study, out, workers=1, processes=False, progress=False, trials=2)
    assert (more.n_before, more.n_run) == (6, 6) and more.complete
    assert keys < done_keys(out) and len(done_keys(out)) == 12
    assert [p.name for p in (out / RESULTS).glob("*.parquet")] == [CONSOLIDATED]
    assert pq.ParquetFile(out / RESULTS / CONSOLIDATED).metadata.num_rows == 12
    try:                                  # pandas is no dependency; pyarrow reads it above
        import pandas as pd
    except ImportError:
        pd = None
    if pd is not None:
        assert len(pd.read_parquet(out / RESULTS)) == 12
