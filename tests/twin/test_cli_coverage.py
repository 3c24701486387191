"""`rfp-twin coverage` (twin/cli/coverage.py): files, table, exit codes."""
from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from rfp_twin.twin.cli import app
from rfp_twin.twin.cli.coverage import COVERAGE_JSON, COVERAGE_PNG
from tests.twin.cli.runner import run


def test_coverage_writes_json_and_png(tmp_path):
    out = tmp_path / "cov"
    r = run("coverage", "--preset", "raft-6p2", "--layout", "raft:2", "--spacing", "0.2",
            "--out", str(out))
    assert r.returncode == 0, r.stderr
    assert ">= 1 / 2 / 3 fibers" in r.stdout and "2 rafts" in r.stdout
    assert sorted(p.name for p in out.iterdir()) == [COVERAGE_JSON, COVERAGE_PNG]
    data = json.loads((out / COVERAGE_JSON).read_text())
    assert data["command"].startswith("rfp-twin coverage --preset raft-6p2")
    assert (data["layout"], data["n_robots"], data["spacing_mm"]) == ("raft-2x63", 126, 0.2)
    assert 0.5 < data["fraction"]["1"] <= 1.0
    assert [r["raft"] for r in data["rafts"]] == [0, 1]
    assert (out / COVERAGE_PNG).read_bytes()[:4] == b"\x89PNG"


@pytest.mark.parametrize("args, words", [
    (["--spacing", "-0.5"], ["'spacing_mm'", "> 0"]),
    (["--spacing", "0"], ["'spacing_mm'"]),
    (["--layout", "raft:R=10"], ["'radius_mm'"]),
    (["--layout", "hex:8"], ["'n_positions'"]),
    (["--preset", "nope"], ["unknown preset 'nope'"]),
])
def test_bad_input_exits_2_and_writes_nothing(tmp_path, args, words):
    out = tmp_path / "cov"
    r = CliRunner().invoke(app, ["coverage", "--preset", "raft-6p2", "--layout", "hex:7",
                                 "--out", str(out), *args])
    assert r.exit_code == 2, r.output
    lines = [ln for ln in r.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error:"), r.output
    assert all(w in lines[0] for w in words), lines[0]
    assert not out.exists()
