"""Tests of rfp_twin.twin.sim.simulator: a checked collision-free plan makes no contact in 3D and
the servos track it; partial trajectories, callbacks, durations and settings."""
from __future__ import annotations

import mujoco
import numpy as np
import pytest

from rfp_twin.models.errors import TrajectoryError
from rfp_twin.models.mjcf import build_model
from rfp_twin.models.trajectory import Trajectory
from tests.planners.conftest import make_geom, plan_random
from rfp_twin.twin.sim import SimSettings, Simulator, mujoco_warnings, simulate
from tests.twin.builders import FOLD, centre_robot


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


def test_partial_trajectory_holds_the_others_and_callback_runs(twin7):
    c = centre_robot(twin7.layout)
    traj = Trajectory.from_breakpoints([c], [[0.0, 1.0]], [[10.0, 40.0]], [[0.0, 1.0]],
                                       [[170.0, 170.0]])
    seen = []
    report = simulate(twin7, traj, settings=SimSettings(record_dt_s=0.1, settle_s=0.2),
                      callback=lambda t, m, d: seen.append(t))
    assert seen[0] == 0.0 and len(seen) == len(report.record.times) == 12
    assert report.reached.all() and report.ok
    others = np.arange(7) != twin7.layout.robot_index(c)
    assert np.abs(report.record.angles[:, others] - FOLD).max() < 0.05


def test_duration_is_whole_steps_covering_the_trajectory(twin7):
    c = centre_robot(twin7.layout)
    traj = Trajectory.from_breakpoints([c], [[0.0, 0.5]], [[10.0, 20.0]], [[0.0, 0.5]],
                                       [[170.0, 170.0]])
    dt = float(twin7.model.opt.timestep)
    sim = Simulator(twin7, traj, settings=SimSettings(settle_s=0.1))
    assert sim.n_steps == round(0.6 / dt) and sim.sim_s == pytest.approx(0.6)
    fixed = Simulator(twin7, traj, settings=SimSettings(duration_s=0.2 + dt / 3))
    assert fixed.n_steps == round(0.2 / dt) + 1           # rounded up to whole steps
    report = fixed.run(record=False)
    assert report.n_steps == fixed.n_steps and report.sim_s == pytest.approx(fixed.sim_s)
    assert report.record is None and mujoco_warnings(fixed.data) == {}
    fixed.reset()
    assert fixed.data.time == 0.0
    np.testing.assert_allclose(twin7.angles(fixed.data), fixed.nominal([0.0])[0])


@pytest.mark.parametrize("kwargs, message", [
    ({"settle_s": -1.0}, "field 'settle_s' = -1.0"),
    ({"record_dt_s": float("nan")}, "field 'record_dt_s'"),
    ({"duration_s": 0.0}, "field 'duration_s' = 0.0; allowed: > 0 s"),
])
def test_bad_settings_are_refused(kwargs, message):
    with pytest.raises(TrajectoryError, match=message):
        SimSettings(**kwargs)


def test_mujoco_warnings_are_named_and_counted(twin7):
    d = mujoco.MjData(twin7.model)
    assert mujoco_warnings(d) == {}
    d.warning[int(mujoco.mjtWarning.mjWARN_BADQACC)].number = 2
    assert mujoco_warnings(d) == {"mjWARN_BADQACC": 2}
