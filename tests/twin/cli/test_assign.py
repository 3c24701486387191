"""``rfp-twin assign``: a catalogue in, assignment.csv + report.json out, planned by ``plan``."""
from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from tests.twin.cli.runner import run


def test_assign_a_mock_then_plan_the_assignment(tmp_path):
    out = tmp_path / "a"
    r = run("assign", "--layout", "hex:19", "--buffer", "2.0",
            "--catalogue", "mock:uniform:1.5/patrol,sky=0.3,levels=2", "--seed", "3",
            "--sky-quota", "1", "--out", str(out))
    assert r.returncode == 0, r.stderr
    rows = list(csv.DictReader((out / "assignment.csv").open()))
    assert len(rows) == 19
    rep = json.loads((out / "report.json").read_text())
    assert rep["status"] == "optimal" and rep["solver"] == "highs"
    assert rep["assigned"] == sum(1 for row in rows if row["kind"] != "parked")
    assert rep["counts"]["sky"] >= 1
    assert rep["objective"] == pytest.approx(sum(float(row["priority"]) for row in rows
                                                 if row["priority"]))
    ids = [row["target_id"] for row in rows if row["target_id"]]
    assert len(ids) == len(set(ids))
    assert "rfp-twin assign" in r.stdout and "objective / bound" in r.stdout
    plan = run("plan", "--layout", "hex:19", "--buffer", "2.0", "--targets",
               str(out / "assignment.csv"), "--out", str(tmp_path / "p"))
    assert plan.returncode == 0, plan.stderr
    planned = list(csv.DictReader((tmp_path / "p" / "targets.csv").open()))
    for got, want in zip(planned, rows):
        assert int(got["robot_id"]) == int(want["robot_id"])
        assert np.allclose([float(got["original_alpha_deg"]), float(got["original_beta_deg"])],
                           [float(want["alpha_deg"]), float(want["beta_deg"])], atol=1e-5)


@pytest.mark.parametrize("catalogue,words", [
    ("mock:uniform:0/patrol", "density 0.0"),
    ("mock:uniform:1e9/patrol", "allowed: at most 1e+07 targets"),
    ("mock:gaussian:1/patrol", "process 'gaussian'"),
    ("mock:uniform:300/deg2", "needs a plate scale"),
    ("BAD", "cat.csv:3: field 'kind' = 'galaxy'"),
])
def test_bad_catalogues_are_one_line_exit_2_and_nothing_written(tmp_path, catalogue, words):
    if catalogue == "BAD":
        catalogue = str(tmp_path / "cat.csv")
        (tmp_path / "cat.csv").write_text("id,x_mm,y_mm,kind\n1,0,0,sky\n2,5,5,galaxy\n")
    out = tmp_path / "a"
    r = run("assign", "--layout", "hex:7", "--telescope", "none", "--catalogue", catalogue,
            "--out", str(out))
    assert r.returncode == 2, r.stderr
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error:") and words in lines[0], r.stderr
    assert not out.exists()


def test_an_unmeetable_quota_names_region_and_best_count(tmp_path):
    cat = tmp_path / "cat.csv"
    cat.write_text("id,x_mm,y_mm,kind\n1,10,0,sky\n2,10.1,0,sky\n3,-10,0,science\n")
    out = tmp_path / "a"
    r = run("assign", "--layout", "hex:7", "--catalogue", str(cat), "--sky-quota", "2",
            "--out", str(out))
    assert r.returncode == 2
    assert "sky quota in the whole plane: needs 2; the best count reachable is 1" in r.stderr
    assert not out.exists()


def test_plan_a_catalogue_keeps_every_assigned_target(tmp_path):
    out = tmp_path / "p"
    r = run("plan", "--layout", "hex:19", "--buffer", "2.0", "--telescope", "none",
            "--catalogue", "mock:uniform:1.5/patrol,sky=0.3", "--sky-quota", "2", "--seed", "2",
            "--out", str(out))
    assert r.returncode == 0, r.stderr
    s = json.loads((out / "summary.json").read_text())
    a = s["assignment"]
    assert a["counts"]["sky"] >= 2
    assert a["kept"] == a["assigned"] > 0 and a["lost"] == 0 and a["n_rounds"] >= 1
    assert s["check2d"]["ok"]
    rows = list(csv.DictReader((out / "assignment.csv").open()))
    assert sum(1 for row in rows if row["target_id"]) == a["assigned"]
    assert "assigned / kept by the plan" in r.stdout
    r = run("plan", "--layout", "hex:7", "--catalogue", "mock:uniform:1/patrol", "--targets",
            str(out / "assignment.csv"), "--out", str(tmp_path / "q"))
    assert r.returncode == 2 and "allowed: one of them" in r.stderr
    assert not (tmp_path / "q").exists()


def test_a_sky_catalogue_on_the_calibrated_instrument(tmp_path):
    """ra/dec about a field centre, APO plate scale, wok frame -> planning frame; the
    written target positions are the projected ones and each lands within reach."""
    from rfp_twin.models.catalogue import TELESCOPES, sky_to_focal
    from rfp_twin.models.instrument import wok_to_plane

    rng = np.random.default_rng(4)
    ra = 150.0 + rng.uniform(-1.2, 1.2, 400) / np.cos(np.radians(20.0))
    dec = 20.0 + rng.uniform(-1.2, 1.2, 400)
    cat = tmp_path / "sky.csv"
    with cat.open("w") as fh:
        fh.write("id,ra_deg,dec_deg,fiber\n")
        for k in range(ra.size):
            fh.write(f"{1000 + k},{float(ra[k])!r},{float(dec[k])!r},boss\n")
    out = tmp_path / "a"
    r = run("assign", "--preset", "sdss-v-production", "--layout", "sdss-v-apo",
            "--buffer", "2.0", "--catalogue", str(cat), "--field-centre", "150,20",
            "--out", str(out))
    assert r.returncode == 0, r.stderr
    rows = [row for row in csv.DictReader((out / "assignment.csv").open()) if row["target_id"]]
    assert len(rows) > 50
    x, y = sky_to_focal(ra, dec, 150.0, 20.0, TELESCOPES["apo"].plate_scale_mm_per_deg)
    plane = wok_to_plane(np.column_stack([x, y]))
    for row in rows[:20]:
        k = int(row["target_id"]) - 1000
        assert np.allclose([float(row["x_mm"]), float(row["y_mm"])], plane[k], atol=1e-3)
        assert row["robot_fiber"] == "boss"
    r = run("assign", "--layout", "sdss-v-apo", "--catalogue", str(cat), "--field-centre",
            "150,95", "--out", str(tmp_path / "b"))
    assert r.returncode == 2 and "field 'dec' = 95.0; allowed: [-90, 90] deg" in r.stderr
