"""`rfp-twin unwind` and `rfp-twin explode` end to end (subprocess, exit codes, files)."""
from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.layout import Layout
from rfp_twin.models.robot import load_spec
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.planners.stepwise.recovery import min_clearance
from rfp_twin.planners.plan.targets import random_targets
from rfp_twin.validation.checker2d import check_trajectory
from tests.twin.cli.runner import run

SPEC = load_spec("sdss-v").with_overrides(buffer_mm=2.0)


@pytest.fixture(scope="module")
def planned(tmp_path_factory):
    out = tmp_path_factory.mktemp("runs") / "plan"
    r = run("plan", "--layout", "hex:19", "--buffer", "2.0", "--step", "0.2", "--seed", "2",
            "--out", str(out))
    assert r.returncode == 0, r.stderr
    return out


def write_poses(path, ids, poses, header=("robot_id", "alpha_deg", "beta_deg")):
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        for rid, (a, b) in zip(ids, poses):
            w.writerow([int(rid), f"{a:.6f}", f"{b:.6f}"])


def test_unwind_from_a_run_folder_folds_every_robot(planned, tmp_path):
    out = tmp_path / "unwind"
    r = run("unwind", str(planned), "--step", "0.2", "--out", str(out))
    assert r.returncode == 0, r.stderr
    assert "deadlocked" in r.stdout
    start = Trajectory.from_json(planned / "trajectories.json").end()
    traj = Trajectory.from_json(out / "trajectories.json")
    np.testing.assert_allclose(traj.start(), start, atol=1e-9)
    np.testing.assert_allclose(traj.end(), np.tile(SPEC.fold_deg, (traj.n_robots, 1)), atol=1e-6)
    layout = Layout.from_csv(out / "layout.csv")
    assert check_trajectory(traj, load_spec(out / "robot.toml"), layout, 2.0 - 0.03).ok
    summary = json.loads((out / "summary.json").read_text())
    assert summary["kind"] == "unwind" and summary["n_deadlocked"] == 0


def squeezed(layout):
    """Poses drawn at 1.2 mm on ``layout``: some pairs collide at 2.0 mm."""
    geom = ArrayGeometry(SPEC, layout, 2.0)
    tight = ArrayGeometry(SPEC.with_overrides(buffer_mm=1.2), layout, 1.2)
    for s in range(100):
        poses = random_targets(tight, np.random.default_rng(s), margin_mm=0.0)
        if min_clearance(geom, poses) < -0.2:
            return poses
    raise AssertionError("no squeezed draw")


def test_explode_from_a_csv_then_unwind(tmp_path):
    layout = Layout.hex_grid(2, SPEC.pitch_mm)
    poses = squeezed(layout)
    path = tmp_path / "poses.csv"
    write_poses(path, layout.robot_ids, poses)
    common = ("--preset", "sdss-v", "--layout", "hex:19", "--buffer", "2.0", "--step", "0.2")
    # poses that collide cannot be unwound: the error says what to do
    r = run("unwind", str(path), *common, "--out", str(tmp_path / "u0"))
    assert r.returncode == 2 and "run `rfp-twin explode` first" in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and not (tmp_path / "u0").exists()
    r = run("explode", str(path), *common, "--offline", "0", "--out", str(tmp_path / "exp"))
    assert r.returncode == 0, r.stderr
    summary = json.loads((tmp_path / "exp" / "summary.json").read_text())
    m = summary["metrics"]
    assert m["min_clearance_start_mm"] < -0.2 < 0.0 < m["min_clearance_end_mm"]
    assert summary["n_new_collisions"] == 0 and summary["n_start_collisions"] >= 1
    exploded = Trajectory.from_json(tmp_path / "exp" / "trajectories.json")
    np.testing.assert_allclose(exploded.end()[0], poses[0], atol=1e-6)        # offline
    r = run("unwind", str(tmp_path / "exp"), "--step", "0.2", "--out", str(tmp_path / "u1"))
    assert r.returncode in (0, 3), r.stderr          # 3: some robot deadlocked short of the fold
    assert (tmp_path / "u1" / "trajectories.json").is_file()


@pytest.mark.parametrize("rows, message", [
    (lambda ids, p: (ids[:-1], p[:-1]), "has no row (1 robot(s) missing)"),
    (lambda ids, p: ([*ids[:-1], 999], p), "unknown robot id 999"),
    (lambda ids, p: (ids, np.where(np.arange(len(ids))[:, None] == 0, np.nan, p)), "NaN/inf angle"),
    (lambda ids, p: (ids, p + np.array([[0.0, 400.0]])), "allowed: alpha in"),
], ids=["missing", "unknown", "nan", "range"])
def test_bad_poses_csv_is_one_line_and_writes_nothing(tmp_path, rows, message):
    layout = Layout.hex_grid(1, SPEC.pitch_mm)
    poses = np.tile(SPEC.fold_deg, (layout.n_robots, 1)).astype(float)
    ids, p = rows(list(layout.robot_ids), poses)
    path = tmp_path / "poses.csv"
    write_poses(path, ids, p)
    for cmd in ("unwind", "explode"):
        r = run(cmd, str(path), "--preset", "sdss-v", "--layout", "hex:7",
                "--out", str(tmp_path / cmd))
        assert r.returncode == 2 and message in r.stderr, r.stderr
        assert len(r.stderr.strip().splitlines()) == 1 and not (tmp_path / cmd).exists()


def test_unknown_offline_robot_is_named(planned, tmp_path):
    r = run("explode", str(planned), "--offline", "4242", "--out", str(tmp_path / "e"))
    assert r.returncode == 2 and "--offline 4242: unknown robot id" in r.stderr
