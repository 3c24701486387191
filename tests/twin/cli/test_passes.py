"""``rfp-twin plan --catalogue ... --passes K``: a folder per pass, passes.csv, observed.csv."""
from __future__ import annotations

import csv
import json

import pytest

from tests.twin.cli.runner import plan_ok, run


def test_passes_write_one_run_folder_per_pass_and_each_target_once(tmp_path):
    out = tmp_path / "p"
    r, s = plan_ok(out, "--layout", "hex:19", "--buffer", "2.0", "--telescope", "none",
                   "--catalogue", "mock:uniform:3/patrol,sky=0.3,levels=2", "--seed", "2",
                   "--passes", "3")
    assert s["n_passes"] == 3 and [p["pass"] for p in s["passes"]] == [1, 2, 3]
    rows = list(csv.DictReader((out / "passes.csv").open()))
    assert [int(row["pass"]) for row in rows] == [1, 2, 3]
    cum = [float(row["cumulative"]) for row in rows]
    assert cum == sorted(cum) and cum[-1] == pytest.approx(s["completeness"]["science"])
    seen = list(csv.DictReader((out / "observed.csv").open()))
    ids = [row["target_id"] for row in seen]
    assert len(ids) == len(set(ids)) == s["completeness"]["n_observed"] > 0
    for k in (1, 2, 3):
        run_s = json.loads((out / f"pass{k}" / "summary.json").read_text())
        assert run_s["check2d"]["ok"] and run_s["pass"]["kept"] == run_s["pass"]["assigned"]
        assert (out / f"pass{k}" / "assignment.csv").is_file()
    assert "science completeness after 3 pass(es)" in r.stdout


@pytest.mark.parametrize("args,words", [
    (["--passes", "0"], "--passes 0; allowed: an integer in [1, 100]"),
    (["--passes", "-2"], "--passes -2; allowed: an integer in [1, 100]"),
    (["--passes", "101"], "--passes 101; allowed: an integer in [1, 100]"),
])
def test_bad_pass_counts_exit_2_in_one_line_and_write_nothing(tmp_path, args, words):
    out = tmp_path / "p"
    r = run("plan", "--layout", "hex:7", "--telescope", "none", "--catalogue",
            "mock:uniform:1/patrol", *args, "--out", str(out))
    assert r.returncode == 2 and words in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and not out.exists()


def test_passes_without_a_catalogue_exit_2(tmp_path):
    out = tmp_path / "p"
    r = run("plan", "--layout", "hex:7", "--passes", "2", "--out", str(out))
    assert r.returncode == 2 and "--passes 2 without --catalogue" in r.stderr
    assert not out.exists()


def test_a_direct_stuck_share_out_of_range_exits_2(tmp_path):
    out = tmp_path / "p"
    r = run("plan", "--layout", "hex:7", "--telescope", "none", "--catalogue",
            "mock:uniform:1/patrol", "--passes", "2", "--direct-stuck", "1.5", "--out", str(out))
    assert r.returncode == 2 and "--direct-stuck 1.5; allowed: [0, 1]" in r.stderr
    assert not out.exists()


def test_a_mock_whose_targets_need_two_exposures_is_observed_in_two_passes(tmp_path):
    out = tmp_path / "p"
    plan_ok(out, "--layout", "hex:19", "--buffer", "2.0", "--telescope", "none",
            "--catalogue", "mock:uniform:1/patrol,exposures=2", "--seed", "2", "--passes", "2")
    rows = list(csv.DictReader((out / "passes.csv").open()))
    assert int(rows[0]["completed_science"]) == 0 < int(rows[0]["observed_science"])
    seen = [row["target_id"] for row in csv.DictReader((out / "observed.csv").open())]
    twice = {t for t in seen if seen.count(t) == 2}
    assert int(rows[1]["completed_science"]) == len(twice) > 0
    assert max(seen.count(t) for t in seen) <= 2
    r = run("plan", "--layout", "hex:7", "--telescope", "none", "--catalogue",
            "mock:uniform:1/patrol,exposures=0", "--passes", "2", "--out", str(tmp_path / "q"))
    assert r.returncode == 2 and "exposures='0'; allowed: an integer in [1, 1000]" in r.stderr


@pytest.mark.parametrize("key", ["exposures=nan", "levels=inf", "sigma=nan", "exposures=2.5"])
def test_a_mock_key_that_is_not_a_finite_number_or_integer_exits_2(tmp_path, key):
    out = tmp_path / "p"
    r = run("plan", "--layout", "hex:7", "--telescope", "none", "--catalogue",
            f"mock:uniform:1/patrol,{key}", "--out", str(out))
    allowed = "an integer in [1, 1000]" if key == "exposures=2.5" else "a finite number"
    assert r.returncode == 2 and f"{key.split('=')[0]}='{key.split('=')[1]}'; allowed: " \
        f"{allowed}" in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and not out.exists()
