"""`rfp-twin validate / simulate / render / record` on a probe-arm run folder, and bad input."""
from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from rfp_twin.models.kinds import ProbeArmKind, load_kind
from rfp_twin.twin.cli import app


def _write_run(folder, moves, n_arms=3, t_end=2.0):
    """A hand-made probe run folder: ``n_arms`` arms from park, arm k ending at
    ``moves[k]`` (deg, default park) at ``t_end`` s."""
    kind = ProbeArmKind(load_kind("miradas-probe").spec.with_overrides(n_arms=n_arms))
    park = np.array(kind.spec.park_deg)
    folder.mkdir()
    plan = {}
    for k in range(n_arms):
        end = np.asarray(moves.get(k, park), dtype=float)
        plan[str(k)] = {"theta1": [[park[0], 0.0], [end[0], t_end]],
                        "theta2": [[park[1], 0.0], [end[1], t_end]]}
    (folder / "plan.json").write_text(json.dumps(plan))
    (folder / "summary.json").write_text(json.dumps({"kind": "miradas-probe",
                                                     "preset": "miradas-probe"}))
    return kind


def _one_error_line(r):
    lines = [ln for ln in r.output.splitlines() if ln.strip()]
    assert r.exit_code == 2 and len(lines) == 1 and lines[0].startswith("error:"), r.output
    return lines[0]


@pytest.fixture()
def tiny(tmp_path):
    run = tmp_path / "run"
    _write_run(run, {0: (178.0, 2.0), 2: (177.0, 0.0)})
    return run


def test_validate_runs_2d_and_3d(tiny):
    r = CliRunner().invoke(app, ["validate", str(tiny)])
    assert r.exit_code == 0, r.output
    assert "2D check" in r.output and "3D check (FCL" in r.output
    rep = json.loads((tiny / "validation.json").read_text())
    assert rep["check2d"]["ok"] and rep["check3d"]["ok"] and rep["check3d"]["n_samples"] == 21


def test_validate_finds_arms_driven_into_each_other(tmp_path):
    run = tmp_path / "clash"
    kind = ProbeArmKind(load_kind("miradas-probe").spec.with_overrides(n_arms=2))
    centre = kind.inverse(kind.to_arm(0, np.zeros((1, 2))))[0]    # both heads on the centre
    _write_run(run, {0: centre, 1: centre}, n_arms=2, t_end=120.0)
    r = CliRunner().invoke(app, ["validate", str(run)])
    assert r.exit_code == 4, r.output
    rep = json.loads((run / "validation.json").read_text())
    assert not rep["check2d"]["ok"] and not rep["check3d"]["ok"] and rep["check3d"]["contacts"]


def test_simulate_a_short_run(tiny):
    r = CliRunner().invoke(app, ["simulate", str(tiny)])
    assert r.exit_code == 0, r.output
    sim = json.loads((tiny / "sim.json").read_text())
    assert sim["ok"] and sim["n_contact_steps"] == 0 and sim["max_tracking_deg"] < 0.5
    assert sim["steps"] == 1500                       # 2 s plan + 1 s settle at 2 ms


def test_render_a_short_run(tiny, tmp_path):
    import imageio.v3 as iio

    out = tmp_path / "probe.mp4"
    r = CliRunner().invoke(app, ["render", str(tiny), "--out", str(out), "--width", "64",
                                 "--height", "64", "--fps", "4", "--speedup", "1"])
    assert r.exit_code == 0, r.output
    frames = iio.imread(out, index=None)
    assert frames.shape == (9, 64, 64, 3) and frames[0].std() > 5


def test_record_a_short_run(tiny, tmp_path):
    out = tmp_path / "probe.rrd"
    r = CliRunner().invoke(app, ["record", str(tiny), "--out", str(out), "--dt", "0.5"])
    assert r.exit_code == 0, r.output
    assert out.stat().st_size > 1000 and not list(tmp_path.glob(".probe.*"))


@pytest.mark.parametrize("command", [["validate"], ["simulate"], ["render"], ["record"]])
def test_a_broken_probe_run_is_one_line_exit_2(tmp_path, command):
    run = tmp_path / "run"
    _write_run(run, {})
    (run / "plan.json").write_text('{"0": {"theta1": [[180, 0]]}}')
    line = _one_error_line(CliRunner().invoke(app, [*command, str(run)]))
    assert "plan.json" in line and "allowed" in line
    assert not (run / "validation.json").exists() and not (run / "sim.json").exists()


def test_alpha_beta_options_are_refused_for_a_probe_run(tiny):
    line = _one_error_line(CliRunner().invoke(app, ["simulate", str(tiny), "--layout", "hex:2"]))
    assert "--layout does not apply to a probe-arm run" in line


@pytest.mark.parametrize("csv_text, words", [
    ("arm,x_mm,y_mm\n3,2000.0,0.0\n", ["arm 3", "has no pose", "allowed", "ZoA"]),  # out of reach
    ("arm,theta1_deg,theta2_deg\n5,0.0,0.0\n", ["arm 5", "is in the ZoA", "d34 = 5.00 mm",
                                               "allowed: (100, 300) mm"]),
    ("arm,theta1_deg,theta2_deg\n5,200.0,0.0\n", ["arm 5", "allowed: theta1 in [0, 180]"]),
    ("arm,theta1_deg,theta2_deg\n14,90.0,0.0\n", ["arm 14", "allowed: each of 0..11"]),
    ("robot,a,b\n1,2,3\n", ["columns", "allowed: arm and theta1_deg"]),
])
def test_bad_probe_targets_exit_2_with_nothing_written(tmp_path, csv_text, words):
    targets = tmp_path / "targets.csv"
    targets.write_text(csv_text)
    out = tmp_path / "run"
    r = CliRunner().invoke(app, ["plan", "--preset", "miradas-probe", "--algorithm", "roadmap",
                                 "--targets", str(targets), "--out", str(out)])
    line = _one_error_line(r)
    assert str(targets) in line and all(w in line for w in words), line
    assert not out.exists()


def test_probe_targets_csv_is_planned(tmp_path):
    kind = load_kind("miradas-probe")
    tip = kind.tips_world(kind.park())[4] * 0.5                 # halfway in from park
    targets = tmp_path / "targets.csv"
    targets.write_text(f"arm,x_mm,y_mm\n4,{tip[0]},{tip[1]}\n")
    out = tmp_path / "run"
    r = CliRunner().invoke(app, ["plan", "--preset", "miradas-probe", "--algorithm", "roadmap",
                                 "--targets", str(targets), "--out", str(out)])
    assert r.exit_code == 0, r.output
    plan = json.loads((out / "plan.json").read_text())
    end = np.array([plan["4"]["theta1"][-1][0], plan["4"]["theta2"][-1][0]])
    assert np.allclose(kind.tips_world(np.tile(end, (12, 1)))[4], tip, atol=1e-6)
    assert {deg for deg, _ in plan["0"]["theta1"] + plan["0"]["theta2"]} <= {180.0, 0.0}  # stays
