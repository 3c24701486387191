"""Tests of twin.sim: the physics twin (MuJoCo) driven along trajectories.

A checked collision-free plan makes no contact in 3D; a hand-built colliding trajectory
does, between exactly the robots that collide; faults show as the tracking errors they
should: a stuck robot's error grows, a slow robot lags, an encoder offset is a constant
error.
"""
from __future__ import annotations

import json

import numpy as np
import pytest

from models.errors import TrajectoryError, UnknownRobotError
from models.layout import Layout
from models.mjcf import build_model
from models.robot import load_spec
from models.trajectory import Trajectory
from tests.planners.conftest import make_geom, plan_random
from twin.sim import EncoderOffset, SimSettings, Simulator, Slow, Stuck, simulate
from tests.twin.builders import centre_robot as _centre, moves_trajectory as _moves



def test_checked_collision_free_plan_makes_no_contact():
    geom = make_geom(37, 2.0)
    _, plan = plan_random(geom, 1)
    assert plan.complete
    traj = Trajectory.from_plan(plan)
    twin = build_model(geom.spec, geom.layout)
    report = simulate(twin, traj)
    assert report.warnings == {} and report.warning_messages == []
    assert len(report.contacts) == 0 and not report.collided
    assert report.reached.all() and report.ok
    assert np.abs(report.max_error_deg).max() < 1.0                 # the servos track
    assert report.final_fiber_error_mm.max() < 0.01
    assert report.sim_s >= traj.duration


def test_hand_built_colliding_trajectory_makes_robot_contacts(twin7):
    """The centre robot unfolds straight towards its +x neighbour (22.4 mm away), whose
    folded beta arm lies across the path: they must touch, and nothing else."""
    lay = twin7.layout
    c = _centre(lay)
    right = int(lay.robot_ids[np.argmin(np.hypot(lay.robot_xy[:, 0] - 22.4, lay.robot_xy[:, 1]))])
    traj = _moves(lay, {c: ([0.0, 6.0], [10.0, 0.0], [170.0, 0.0])})
    report = simulate(twin7, traj)
    assert report.warnings == {}
    assert report.robot_contacts > 0 and report.fiducial_contacts == 0
    pairs = report.contacts.pairs()
    assert {(p["robot_a"], p["robot_b"]) for p in pairs} == {tuple(sorted((c, right)))}
    assert pairs[0]["max_depth_mm"] > 0 and 2.0 < pairs[0]["first_s"] < 6.0
    assert not report.ok
    assert not report.reached[lay.robot_index(c)]                     # blocked


def test_robot_hitting_a_fiducial_is_reported():
    spec = load_spec("sdss-v")
    grid = Layout.hex_grid(1, spec.pitch_mm)
    right = int(grid.ids[np.argmin(np.hypot(grid.xy[:, 0] - 22.4, grid.xy[:, 1]))])
    lay = Layout(grid.ids, grid.xy, np.where(grid.ids == right, "fiducial", "robot"))
    twin = build_model(spec, lay)
    c = _centre(lay)
    traj = _moves(lay, {c: ([0.0, 6.0], [10.0, 0.0], [170.0, 0.0])})
    report = simulate(twin, traj)
    assert report.robot_contacts == 0 and report.fiducial_contacts > 0
    assert {(p["robot_a"], p["fiducial"]) for p in report.contacts.pairs()} == {(c, right)}


def _swing(lay: Layout) -> tuple[int, Trajectory]:
    """Centre robot turns alpha 10 -> 100 deg in 3 s (30 deg/s), beta folded."""
    c = _centre(lay)
    return c, _moves(lay, {c: ([0.0, 3.0], [10.0, 100.0], [170.0, 170.0])})


def test_stuck_robot_error_grows(twin7):
    c, traj = _swing(twin7.layout)
    report = simulate(twin7, traj, [Stuck(c, 1.0)])
    k = twin7.layout.robot_index(c)
    rec = report.record
    err = rec.angles[:, k, 0] - rec.reference[:, k, 0]
    at = lambda t: err[np.argmin(np.abs(rec.times - t))]  # noqa: E731
    assert abs(at(1.0)) < 0.5
    assert at(2.0) == pytest.approx(-30.0, abs=1.0)
    assert at(3.0) == pytest.approx(-60.0, abs=1.0)
    assert report.final_error_deg[k, 0] == pytest.approx(-60.0, abs=0.5)
    assert not report.reached[k] and report.reached[np.arange(7) != k].all()
    assert "stuck" in report.faults[0]


def test_slow_robot_lags(twin7):
    c, traj = _swing(twin7.layout)
    report = simulate(twin7, traj, [Slow(c, 2.0)])
    k = twin7.layout.robot_index(c)
    rec = report.record
    lag = rec.reference[:, k, 0] - rec.angles[:, k, 0]
    at = lambda t: lag[np.argmin(np.abs(rec.times - t))]  # noqa: E731
    assert at(1.0) == pytest.approx(15.0, abs=0.7)                   # half speed
    assert at(2.0) == pytest.approx(30.0, abs=0.7)
    assert at(3.0) == pytest.approx(45.0, abs=0.7)
    # given the time, it gets there
    long = simulate(twin7, traj, [Slow(c, 2.0)], SimSettings(duration_s=6.5), record=False)
    assert long.reached.all()


def test_encoder_offset_is_a_constant_error(twin7):
    c, traj = _swing(twin7.layout)
    report = simulate(twin7, traj, [EncoderOffset(c, alpha_deg=0.5, beta_deg=-0.3)])
    k = twin7.layout.robot_index(c)
    rec = report.record
    err = rec.angles[:, k] - rec.reference[:, k]
    assert err[:, 0] == pytest.approx(np.full(len(err), -0.5), abs=0.2)
    assert err[:, 1] == pytest.approx(np.full(len(err), 0.3), abs=1e-3)
    assert report.final_error_deg[k] == pytest.approx([-0.5, 0.3], abs=1e-3)
    # the encoder thinks all is well
    meas = rec.measured[:, k] - rec.reference[:, k]
    assert np.abs(meas[-10:]).max() < 1e-3


def test_fault_and_trajectory_errors(twin7):
    _, traj = _swing(twin7.layout)
    with pytest.raises(UnknownRobotError):
        Simulator(twin7, traj, [Stuck(99, 1.0)])
    with pytest.raises(TrajectoryError, match="factor"):
        Simulator(twin7, traj, [Slow(3, 0.0)])
    with pytest.raises(TrajectoryError, match="time_s"):
        Simulator(twin7, traj, [Stuck(3, -1.0)])
    bad = Trajectory.from_breakpoints([3, 42], [[0.0], [0.0]], [[10.0], [10.0]],
                                      [[0.0], [0.0]], [[170.0], [170.0]])
    with pytest.raises(UnknownRobotError):
        Simulator(twin7, bad)


def test_partial_trajectory_holds_the_others_and_callback_runs(twin7, tmp_path):
    c = _centre(twin7.layout)
    traj = Trajectory.from_breakpoints([c], [[0.0, 1.0]], [[10.0, 40.0]], [[0.0, 1.0]],
                                       [[170.0, 170.0]])
    seen = []
    report = simulate(twin7, traj, settings=SimSettings(record_dt_s=0.1, settle_s=0.2),
                      callback=lambda t, m, d: seen.append(t))
    assert seen[0] == 0.0 and len(seen) == len(report.record.times) == 12
    assert report.reached.all() and report.ok
    report.to_json(tmp_path / "sim.json")
    data = json.loads((tmp_path / "sim.json").read_text())
    assert data["ok"] is True and data["robots"] == 7 and str(c) in data["per_robot"]
    assert report.table().row_count >= 8
