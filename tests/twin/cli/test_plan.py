"""`rfp-twin plan` (twin/cli/plan.py) end to end, as a user runs it (subprocess, exit codes, files)."""
from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from rfp_twin.models.layout import Layout
from rfp_twin.models.robot import load_spec
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.planners.postprocess.timing import pl_kinematics
from rfp_twin.validation.checker2d import check_trajectory
from tests.twin.cli.runner import plan_ok, run


def test_plan_writes_a_complete_checked_run(tmp_path):
    out = tmp_path / "run"
    r, summary = plan_ok(out, "--layout", "hex:37", "--buffer", "2.0", "--step", "0.2",
                         "--seed", "4", "--offline", "3")
    assert "efficiency" in r.stdout and "2D check" in r.stdout
    names = {p.name for p in out.iterdir()}
    assert names == {"trajectories.json", "trajectories_to_fold.json", "layout.csv", "targets.csv",
                     "robot.toml", "summary.json", "check2d.json"}
    for key in ("buffer_mm", "step_deg", "algorithm", "greed", "phobia", "seed", "direction",
                "offline", "metrics", "check2d"):
        assert key in summary
    assert summary["check2d"]["ok"] and summary["check2d"]["n_collisions"] == 0
    for key in ("efficiency", "convergence", "tau_pg_s", "tau_sr_s", "fold_time_s"):
        assert key in summary["metrics"]
    assert summary["offline"] == [3]
    traj = Trajectory.from_json(out / "trajectories.json")
    assert traj.n_robots == 37
    fold = np.array(load_spec("sdss-v").fold_deg)
    moving = traj.robot_ids != 3
    np.testing.assert_allclose(traj.start()[moving], np.tile(fold, (36, 1)))
    with open(out / "targets.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 37
    np.testing.assert_allclose(traj.end(), [[float(r["alpha_deg"]), float(r["beta_deg"])] for r in rows],
                               atol=1e-5)
    assert {r["status"] for r in rows if r["robot_id"] == "3"} == {"offline"}
    assert Layout.from_csv(out / "layout.csv").n_robots == 37
    assert load_spec(out / "robot.toml").buffer_mm == 2.0
    back = Trajectory.from_json(out / "trajectories_to_fold.json")
    np.testing.assert_allclose(back.end()[moving], np.tile(fold, (36, 1)))


def test_targets_csv_by_fiber_position(tmp_path):
    lay = Layout.hex_grid(1, 22.4)
    path = tmp_path / "targets.csv"
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["robot_id", "x_mm", "y_mm"])
        for rid, (x, y) in zip(lay.robot_ids, lay.robot_xy):
            w.writerow([rid, x + 12.0, y + 5.0])
    r = run("plan", "--layout", "hex:7", "--targets", str(path), "--out", str(tmp_path / "o"))
    assert r.returncode == 0, r.stderr


@pytest.mark.parametrize("args,words", [
    (["--preset", "nope"], "unknown preset 'nope'"),
    (["--layout", "hex:40"], "hex"),
    (["--buffer", "-1"], "buffer_mm"),
    (["--algorithm", "astar"], "astar"),
    (["--greed", "2", "--algorithm", "markov"], "greed"),
    (["--offline", "999"], "999"),
    (["--resolve", "maybe"], "--resolve"),
    (["--timing-backend", "scipy"], "--timing-backend"),
    (["--algorithm", "capf", "--lambda3", "5"], "lambda3"),
])
def test_bad_input_is_one_line_nonzero_and_writes_nothing(tmp_path, args, words):
    out = tmp_path / "o"
    r = run("plan", "--layout", "hex:7", *args, "--out", str(out)) if "--layout" not in args else \
        run("plan", *args, "--out", str(out))
    assert r.returncode == 2, r.stderr
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error:") and words in lines[0], r.stderr
    assert not out.exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".o.")]


def test_bad_layout_and_targets_files(tmp_path):
    bad = tmp_path / "lay.csv"
    bad.write_text("id,x_mm,y_mm,kind\n1,0,0,robot\n1,30,0,robot\n")
    r = run("plan", "--layout", str(bad), "--out", str(tmp_path / "o"))
    assert r.returncode == 2 and "duplicate" in r.stderr.lower()
    tg = tmp_path / "t.csv"
    tg.write_text("robot_id,alpha_deg,beta_deg\n" + "".join(f"{i},10,170\n" for i in range(7)) + "77,1,1\n")
    r = run("plan", "--layout", "hex:7", "--targets", str(tg), "--out", str(tmp_path / "o"))
    assert r.returncode == 2 and "unknown robot id 77" in r.stderr
    tg.write_text("robot_id,alpha_deg,beta_deg\n" + "".join(f"{i},10,170\n" for i in range(7))
                  + "3,20,150\n")
    r = run("plan", "--layout", "hex:7", "--targets", str(tg), "--out", str(tmp_path / "o"))
    assert r.returncode == 2 and "t.csv:9: robot 3 has a second target row (first on line 5)" in r.stderr
    tg.write_text("robot_id,x_mm,y_mm\n" + "".join(f"{i},0,0\n" for i in range(7)))
    r = run("plan", "--layout", "hex:7", "--targets", str(tg), "--out", str(tmp_path / "o"))
    assert r.returncode == 2 and "unreachable" in r.stderr and "allowed" in r.stderr
    assert not (tmp_path / "o").exists()


def test_existing_output_is_kept_unless_forced(tmp_path):
    out = tmp_path / "o"
    out.mkdir()
    (out / "mine.txt").write_text("keep me")
    r = run("plan", "--layout", "hex:7", "--out", str(out))
    assert r.returncode == 2 and "exists" in r.stderr
    assert (out / "mine.txt").read_text() == "keep me"
    r = run("plan", "--layout", "hex:7", "--out", str(out), "--force")
    assert r.returncode == 0 and not (out / "mine.txt").exists()


def test_existing_output_is_refused_before_any_work(tmp_path):
    """The folder is checked first: targets that would fail later are not even read."""
    out = tmp_path / "o"
    out.mkdir()
    tg = tmp_path / "t.csv"
    tg.write_text("robot_id,x_mm,y_mm\n" + "".join(f"{i},0,0\n" for i in range(7)))
    r = run("plan", "--layout", "hex:7", "--targets", str(tg), "--out", str(out))
    assert r.returncode == 2 and "exists" in r.stderr and "unreachable" not in r.stderr


def test_unresolved_deadlock_exits_nonzero_but_keeps_the_evidence(tmp_path):
    out = tmp_path / "o"
    r = run("plan", "--layout", "hex:19", "--buffer", "3.5", "--step", "0.5", "--direction", "forward",
            "--resolve", "none", "--seed", "0", "--out", str(out))
    assert r.returncode == 3, r.stderr
    assert "deadlocked" in r.stderr
    with open(out / "targets.csv") as fh:
        assert "deadlocked" in {row["status"] for row in csv.DictReader(fh)}


def test_fiducials_on_a_generated_grid(tmp_path):
    out = tmp_path / "o"
    r = run("plan", "--layout", "hex:37", "--fiducials", "0,18", "--seed", "2", "--out", str(out))
    assert r.returncode == 0, r.stderr
    lay = Layout.from_csv(out / "layout.csv")
    assert lay.n_robots == 35 and sorted(lay.fiducial_ids.tolist()) == [0, 18]
    r = run("plan", "--layout", "hex:37", "--fiducials", "99", "--out", str(tmp_path / "p"))
    assert r.returncode == 2 and "99" in r.stderr


def test_malformed_robot_toml_and_nan_targets(tmp_path):
    bad = tmp_path / "robot.toml"
    bad.write_text("[robot\nname = 1\n")
    r = run("plan", "--preset", str(bad), "--layout", "hex:7", "--out", str(tmp_path / "o"))
    assert r.returncode == 2 and "malformed TOML" in r.stderr
    tg = tmp_path / "t.csv"
    tg.write_text("robot_id,alpha_deg,beta_deg\n" + "".join(f"{i},10,170\n" for i in range(6))
                  + "6,nan,170\n")
    r = run("plan", "--layout", "hex:7", "--targets", str(tg), "--out", str(tmp_path / "o"))
    assert r.returncode == 2 and "robot 6" in r.stderr and "NaN" in r.stderr
    assert not (tmp_path / "o").exists()


def test_plan_writes_firmware_ready_trajectories_by_default(tmp_path):
    spec = load_spec("sdss-v")
    out, raw = tmp_path / "pp", tmp_path / "raw"
    assert run("plan", "--layout", "hex:37", "--seed", "5", "--out", str(out)).returncode == 0
    assert run("plan", "--layout", "hex:37", "--seed", "5", "--raw", "--out", str(raw)).returncode == 0
    s = json.loads((out / "summary.json").read_text())
    p = s["postprocess"]
    assert p["verified"] and s["check2d"]["ok"]
    assert s["check2d"]["buffer_mm"] == pytest.approx(spec.buffer_mm - 0.03)
    for key in ("duration_s", "max_speed_deg_s", "max_accel_deg_s2", "points_per_axis_max",
                "stage_seconds"):
        assert key in p
    # what makes the reconfiguration long: the stepwise fold, the ratio, the longest group
    assert s["stepwise_fold_s"] == pytest.approx(s["metrics"]["fold_time_s"])
    assert s["duration_ratio"] == pytest.approx(s["duration_s"] / s["stepwise_fold_s"])
    slow = s["slowest_groups"]
    assert 1 <= len(slow) <= 3 and slow[0]["duration_s"] == pytest.approx(s["duration_s"])
    assert [g["duration_s"] for g in slow] == sorted((g["duration_s"] for g in slow), reverse=True)
    assert set(slow[0]["robots"]) <= set(range(37))
    assert 0.0 < slow[0]["stepwise_s"] <= s["stepwise_fold_s"] + 1e-9
    traj = Trajectory.from_json(out / "trajectories.json")
    assert traj.point_counts().max() <= 1024
    assert traj.max_speed().max() <= spec.max_speed_deg_s[0] * 1.01
    # the other direction (targets -> fold) is the same motion backwards: the same
    # guarantees, checked on the file itself
    back = Trajectory.from_json(out / "trajectories_to_fold.json")
    assert back.duration == pytest.approx(traj.duration)
    assert back.point_counts().max() <= 1024
    assert back.max_speed().max() <= spec.max_speed_deg_s[0] * 1.01
    for ax in range(2):
        for i in range(back.n_robots):
            assert pl_kinematics(back.times[ax][i], back.angles[ax][i])[1] <= \
                spec.max_accel_deg_s2[ax] * 1.01
    np.testing.assert_allclose(back.start(), traj.end(), atol=1e-9)
    check = check_trajectory(back, spec, Layout.from_csv(out / "layout.csv"), spec.buffer_mm - 0.03)
    assert check.ok, check.table()
    stepwise = Trajectory.from_json(raw / "trajectories.json")
    np.testing.assert_allclose(traj.end(), stepwise.end(), atol=1e-6)
    np.testing.assert_allclose(traj.start(), stepwise.start(), atol=1e-6)
    assert json.loads((raw / "summary.json").read_text())["postprocess"] is None


@pytest.mark.parametrize("algorithm", ["apf", "capf"])
def test_field_planners_write_checked_runs(tmp_path, algorithm):
    """apf / capf go fold -> targets directly; robots that stall are reported, not hidden."""
    out = tmp_path / algorithm
    r = run("plan", "--layout", "hex:19", "--algorithm", algorithm, "--seed", "2", "--out", str(out))
    assert r.returncode in (0, 3), r.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["algorithm"] == algorithm and summary["step_deg"] is None
    assert summary["field"]["model"] == "segment"
    assert summary["check2d"]["ok"] and summary["check2d"]["n_collisions"] == 0
    n_dead = summary["metrics"]["n_deadlocked"]
    assert (r.returncode == 3) == (n_dead > 0)
    assert summary["metrics"]["efficiency"] == pytest.approx(1 - n_dead / 19)
    if algorithm == "capf":
        assert summary["field"]["lambda3"] == pytest.approx(0.03)


def test_roadmap_planner_and_search_resolution_from_the_cli(tmp_path):
    """--algorithm roadmap (Sabater on every robot); --resolve search is the default."""
    out = tmp_path / "roadmap"
    r = run("plan", "--layout", "hex:19", "--algorithm", "roadmap", "--buffer", "3.0",
            "--step", "0.2", "--seed", "1", "--out", str(out))
    assert r.returncode == 0, r.stderr
    assert "kept by search" in r.stdout
    summary = json.loads((out / "summary.json").read_text())
    assert summary["algorithm"] == "roadmap" and summary["resolve"] == "search"
    assert summary["metrics"]["efficiency"] == 1.0
    assert summary["check2d"]["ok"] and summary["check2d"]["n_collisions"] == 0


def test_timing_backend_from_the_cli(tmp_path):
    """Our kernel times the groups by default; --timing-backend toppra uses the library
    (the same algorithm): same durations, both within the limits."""
    runs = {}
    for backend in ("toppra", "numba"):
        out = tmp_path / backend
        args = ["plan", "--layout", "hex:19", "--buffer", "2.0", "--seed", "3", "--out", str(out)]
        if backend == "toppra":
            args += ["--timing-backend", "toppra"]
        r = run(*args)
        assert r.returncode == 0, r.stderr
        assert "groups timed by" in r.stdout
        runs[backend] = json.loads((out / "summary.json").read_text())
    solvers = {b: runs[b]["postprocess"]["timing_solvers"] for b in runs}
    assert set(solvers["toppra"]) == {"toppra"} and set(solvers["numba"]) == {"numba"}
    assert runs["toppra"]["duration_s"] == pytest.approx(runs["numba"]["duration_s"], rel=1e-3)
    for s in runs.values():
        assert max(s["postprocess"]["max_speed_deg_s"]) <= 30.0 * 1.01
        assert s["check2d"]["ok"]


def test_a_bad_calibration_folder_is_one_line_exit_2_and_writes_nothing(tmp_path):
    import shutil

    from rfp_twin.models.instrument import calibration_folder

    cal = tmp_path / "cal"
    shutil.copytree(calibration_folder("sdss-v-lco"), cal)
    table = cal / "positionerTable.csv"
    table.chmod(0o644)
    lines = table.read_text().splitlines()
    head = lines[0].split(",")
    row = lines[3].split(",")
    row[head.index("alphaArmLen")] = "nan"
    lines[3] = ",".join(row)
    table.write_text("\n".join(lines) + "\n")
    out = tmp_path / "o"
    r = run("plan", "--preset", "sdss-v-production", "--calibration", str(cal), "--out", str(out))
    assert r.returncode == 2 and not out.exists()
    msg = r.stderr.strip()
    assert "\n" not in msg and "positionerTable.csv:4: field 'alphaArmLen' = 'nan'" in msg, msg
