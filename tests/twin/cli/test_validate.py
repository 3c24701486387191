"""`rfp-twin validate` and `rfp-twin calibrate-buffer` (twin/cli/validate.py).

The commands are mounted on a fresh typer app with ``register`` (as rfp_twin.twin.cli does)
and run with typer's CliRunner; run folders are built by hand (spec, layout,
trajectory), so a colliding motion can be checked too.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
import typer
from typer.testing import CliRunner

from rfp_twin.models.geometry import geometry_for_spec
from rfp_twin.models.layout import Layout
from rfp_twin.models.robot import load_spec
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.twin.run_dir import LAYOUT, ROBOT, SUMMARY, TRAJECTORIES, TRAJECTORIES_TO_FOLD, spec_to_toml
from rfp_twin.twin.cli.validate import EXIT_BAD_INPUT, EXIT_COLLISION, VALIDATION_JSON, register

SPEC = load_spec("sdss-v")


@pytest.fixture(scope="module")
def app():
    a = typer.Typer()
    register(a)
    return a


def invoke(app, *args):
    return CliRunner().invoke(app, [str(a) for a in args])


def make_run(folder: Path, beta_deg: float) -> Path:
    """A two-robot run folder: robot 0 (alpha 0) turns its beta arm 90 -> beta_deg -> 90
    towards robot 1, parked at (180, 180) 22.4 mm away (bars touch below 23.25 deg)."""
    folder.mkdir(parents=True)
    lay = Layout([0, 1], [[0.0, 0.0], [22.4, 0.0]], ["robot", "robot"], name="pair")
    traj = Trajectory.from_breakpoints([0, 1], [[0, 2], [0, 2]], [[0, 0], [180, 180]],
                                       [[0, 1, 2], [0, 2]], [[90, beta_deg, 90], [180, 180]])
    (folder / ROBOT).write_text(spec_to_toml(SPEC))
    lay.to_csv(folder / LAYOUT)
    traj.to_json(folder / TRAJECTORIES)
    traj.reversed().to_json(folder / TRAJECTORIES_TO_FOLD)
    (folder / SUMMARY).write_text(json.dumps({"spec": "preset sdss-v"}))
    return folder


def test_register_adds_both_commands(app):
    names = {c.name for c in app.registered_commands}
    assert names == {"validate", "calibrate-buffer"}


def test_clear_run_writes_validation_json_and_exits_0(app, tmp_path):
    # bars 7.6 sin 40 - 3 = 1.885 mm apart at closest; robot 0's bar passes 1.5 mm above
    # robot 1's beta housing (alpha arm top 4.3 mm, bar bottom 5.8 mm)
    run = make_run(tmp_path / "clear", 40.0)
    r = invoke(app, "validate", run)
    assert r.exit_code == 0, r.output
    assert "3D check (FCL): OK" in r.output
    data = json.loads((run / VALIDATION_JSON).read_text())
    assert data["ok"] and data["n_collisions"] == 0 and data["trajectory"] == TRAJECTORIES
    assert 1.5 - 1e-9 <= data["min_distance_mm"] < 1.6
    assert data["pairs"][0]["links"] == ["beta", "alpha"]
    assert data["link_kind_lower_bound_mm"]["beta-beta"] == pytest.approx(
        7.6 * math.sin(math.radians(40)) - 3.0, abs=0.02)
    assert data["geometry"] == "preset sdss-v"
    assert data["seconds_broadphase"] >= 0 and data["seconds_exact"] >= 0


def test_colliding_run_exits_4_and_names_the_robots(app, tmp_path):
    run = make_run(tmp_path / "hit", 15.0)
    r = invoke(app, "validate", run, "--fold")
    assert r.exit_code == EXIT_COLLISION, r.output
    data = json.loads((run / VALIDATION_JSON).read_text())
    assert not data["ok"] and data["trajectory"] == TRAJECTORIES_TO_FOLD
    c = data["collisions"][0]
    assert (c["robot_a"], c["link_a"], c["other"], c["link_b"]) == (0, "beta", 1, "beta")
    assert 0.0 < c["t_start"] < 1.0 < c["t_end"] < 2.0


def test_user_geometry_turns_a_clear_run_into_a_collision(app, tmp_path):
    # a user's 4.4 mm wide beta arm (CAD export) hits where the preset's 3 mm arm does not
    run = make_run(tmp_path / "run", 35.0)        # 7.6 sin 35 = 4.36 < 4.4
    wide = geometry_for_spec(SPEC).with_params(beta_half_width_mm=2.2, beta_rear_mm=2.2)
    wide.links["beta"].visual.export(tmp_path / "wide_beta.stl")
    toml = tmp_path / "my_robot.toml"
    toml.write_text('extends = "sdss-v"\n[geometry.meshes]\nbeta = "wide_beta.stl"\n')
    assert invoke(app, "validate", run).exit_code == 0
    r = invoke(app, "validate", run, "--geometry", toml)
    assert r.exit_code == EXIT_COLLISION, r.output
    assert "my_robot.toml" in json.loads((run / VALIDATION_JSON).read_text())["geometry"]


@pytest.mark.parametrize("args,words", [
    (["validate", "{tmp}/missing"], ["run folder not found"]),
    (["validate", "{run}", "--geometry", "{tmp}/nope.toml"], ["nope.toml", "allowed"]),
    (["validate", "{run}", "--min-gap", "-1"], ["min_gap_mm", "allowed"]),
    (["calibrate-buffer", "--preset", "nope", "--out", "{tmp}/cal"], ["unknown preset"]),
    (["calibrate-buffer", "--out", "{tmp}/cal", "--probability", "2"], ["probability"]),
])
def test_bad_input_is_one_line_and_exit_2(app, tmp_path, args, words):
    run = make_run(tmp_path / "run", 40.0)
    argv = [a.format(tmp=tmp_path, run=run) for a in args]
    r = invoke(app, *argv)
    assert r.exit_code == EXIT_BAD_INPUT, r.output
    line = [ln for ln in r.output.splitlines() if ln.startswith("error:")]
    assert len(line) == 1
    for w in words:
        assert w in line[0]
    assert not (run / VALIDATION_JSON).exists()


def test_calibrate_buffer_writes_report_and_figures(app, tmp_path):
    out = tmp_path / "cal"
    r = invoke(app, "calibrate-buffer", "--preset", "sdss-v", "--out", out, "--samples", "2048",
               "--draws", "10", "--alpha-error", "1.0", "--beta-error", "1.0", "--seed", "2")
    assert r.exit_code == 0, r.output
    md = (out / "buffer_calibration.md").read_text()
    assert "2048 uniform (Sobol) configurations" in md
    assert "rfp-twin" in md
    data = json.loads((out / "calibration.json").read_text())
    assert 1.45 <= data["safe_buffer_mm"] <= 1.5 + 1e-9
    assert data["angular_error_deg"] == [1.0, 1.0]
    assert data["paper_sigma_eps_mm"] == pytest.approx(
        7.4 * math.radians(1.0) + 15.0 * math.radians(2.0))
    for name in ("scatter_2d_3d.png", "wasted_space.png", "mc_buffer.png"):
        assert (out / name).stat().st_size > 5000
    assert f"{data['safe_buffer_mm']:.4f}" in r.output


def test_validate_refuses_angles_beyond_the_joint_limits(app, tmp_path):
    """A trajectory that puts beta at 725 deg is bad input: one line, exit 2, no report."""
    run = make_run(tmp_path / "wild", 725.0)
    r = invoke(app, "validate", run)
    assert r.exit_code == EXIT_BAD_INPUT, r.output
    assert "robot 0: field 'beta' = 725.0 deg" in r.output and "allowed: [" in r.output
    assert len(r.output.strip().splitlines()) == 1
    assert not (run / VALIDATION_JSON).exists()
