"""`rfp-twin study run | report | list` (twin/cli/study.py), as a user runs them."""
from __future__ import annotations

from typer.testing import CliRunner

from tests.twin.cli.runner import run
from tests.twin.studies.builders import TINY
from tests.twin.studies.test_cluster import free_port
from rfp_twin.twin.cli.study import study_app
from rfp_twin.twin.studies import cluster


def test_run_report_and_errors(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[grid]\nbuffer = 2.0\n")
    r = run("study", "run", str(bad))
    assert r.returncode == 2
    assert r.stderr.strip().count("\n") == 0 and "unknown key 'buffer' in table 'grid'" in r.stderr
    r = run("study", "run", "no-such-study")
    assert r.returncode == 2 and "sim1-small" in r.stderr
    good = tmp_path / "good.toml"
    good.write_text(TINY.replace("trials = 2", "trials = 1"))
    r = run("study", "run", str(good), "--out", str(tmp_path / "o"), "--workers", "1",
            "--threads", "--report")
    assert r.returncode == 0, r.stderr
    assert "throughput" in r.stdout and "report:" in r.stdout
    assert (tmp_path / "o" / "report" / "fig10_efficiency_mean.png").is_file()
    r = run("study", "report", str(tmp_path / "nothing"))
    assert r.returncode == 2 and "no results/ folder" in r.stderr


def test_an_unreachable_scheduler_is_one_line_and_leaves_no_folder(tmp_path, monkeypatch):
    monkeypatch.setattr(cluster, "CONNECT_TIMEOUT_S", 1.0)
    good = tmp_path / "good.toml"
    good.write_text(TINY)
    address = f"tcp://127.0.0.1:{free_port()}"
    r = CliRunner().invoke(study_app, ["run", str(good), "--out", str(tmp_path / "o"),
                                       "--scheduler", address])
    assert r.exit_code == 2, r.output
    errors = [line for line in r.stderr.splitlines() if line.startswith("error:")]
    assert len(errors) == 1 and "cannot reach the Dask scheduler" in errors[0]
    assert address in errors[0]
    assert not (tmp_path / "o").exists()


def test_list_shows_the_shipped_studies():
    r = CliRunner().invoke(study_app, ["list"])
    assert r.exit_code == 0
    for name in ("sim1-small", "sim2", "density"):
        assert name in r.stdout
