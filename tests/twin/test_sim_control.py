"""Tests of rfp_twin.twin.sim.control: the nominal and commanded angles (faults applied), the servo
targets with their velocity feed-forward, and the tracking-error accounting."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.errors import TrajectoryError
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.twin.sim import EncoderOffset, Simulator, Slow, Stuck
from rfp_twin.twin.sim.control import Commands, TrackingError, feedforward_gains, fiber_error_mm
from tests.twin.builders import FOLD, swing_trajectory


def test_nominal_follows_the_trajectory_and_others_hold_the_fold(twin7):
    c, traj = swing_trajectory(twin7.layout)
    k = twin7.layout.robot_index(c)
    cmd = Commands(twin7, traj)
    ref = cmd.nominal([0.0, 1.5, 3.0, 9.0])
    assert ref.shape == (4, 7, 2)
    assert ref[:, k, 0].tolist() == [10.0, 55.0, 100.0, 100.0]      # 30 deg/s, then holds
    others = np.arange(7) != k
    assert (ref[:, others] == FOLD).all() and (ref[:, k, 1] == 170.0).all()
    np.testing.assert_array_equal(cmd.commanded([0.0, 1.5]), ref[:2])   # no fault


def test_faults_change_only_the_commanded_angles(twin7):
    c, traj = swing_trajectory(twin7.layout)
    k = twin7.layout.robot_index(c)
    t = np.array([0.0, 1.0, 2.0, 3.0])
    nominal = Commands(twin7, traj).nominal(t)
    for faults, alpha in (([Stuck(c, 1.0)], [10.0, 40.0, 40.0, 40.0]),
                          ([Slow(c, 2.0)], [10.0, 25.0, 40.0, 55.0]),
                          ([EncoderOffset(c, 0.5, -0.3)], [9.5, 39.5, 69.5, 99.5])):
        cmd = Commands(twin7, traj, faults)
        np.testing.assert_array_equal(cmd.nominal(t), nominal)
        np.testing.assert_allclose(cmd.commanded(t)[:, k, 0], alpha)
    assert Commands(twin7, traj, [EncoderOffset(c, 0.5, -0.3)]).commanded(t)[0, k, 1] == 170.3


def test_servo_targets_lead_by_one_step_plus_feedforward(twin7):
    c, traj = swing_trajectory(twin7.layout)
    k = twin7.layout.robot_index(c)
    dt = float(twin7.model.opt.timestep)
    t = np.arange(6) * dt + 1.0                                       # mid-ramp
    plain = Commands(twin7, traj, feedforward=False)
    target = plain.servo_targets(t, dt)
    assert target.shape == (4, 14)
    np.testing.assert_allclose(target, np.radians(plain.commanded(t[1:-1])).reshape(4, 14))
    ff = feedforward_gains(twin7)
    assert ff.shape == (7, 2) and (ff > 0).all()
    fed = Commands(twin7, traj).servo_targets(t, dt)
    lead = (fed - target).reshape(4, 7, 2)
    np.testing.assert_allclose(lead[:, k, 0], ff[k, 0] * np.radians(30.0), rtol=1e-6)
    assert np.abs(np.delete(lead, k, axis=1)).max() == 0.0            # still robots: no lead


def test_trajectory_must_list_each_robot_once(twin7):
    c = int(twin7.layout.robot_ids[0])
    twice = Trajectory.from_breakpoints([c, c], [[0.0], [0.0]], [[10.0], [10.0]],
                                        [[0.0], [0.0]], [[170.0], [170.0]])
    with pytest.raises(TrajectoryError, match="lists a robot twice"):
        Simulator(twin7, twice)


def test_tracking_error_keeps_the_signed_largest_and_the_rms():
    tr = TrackingError(2)
    nominal = np.zeros((2, 2))
    for e in ([[1.0, -2.0], [0.0, 0.5]], [[-3.0, 1.0], [0.0, -0.25]], [[2.0, 0.0], [0.0, 0.0]]):
        tr.add(np.array(e), nominal)
    assert tr.max_deg.tolist() == [[-3.0, -2.0], [0.0, 0.5]]
    np.testing.assert_allclose(tr.rms_deg(3), np.sqrt([[14 / 3, 5 / 3], [0.0, 0.3125 / 3]]))


def test_fiber_error_is_the_fiber_distance(twin7):
    fold = np.tile(FOLD, (7, 1))
    assert fiber_error_mm(twin7, fold, fold).tolist() == [0.0] * 7
    turned = fold.copy()
    turned[2, 0] += 90.0                                              # alpha turns a quarter
    err = fiber_error_mm(twin7, turned, fold)
    spec = twin7.spec
    # the fiber's radius from the alpha axis, at beta = 170 deg (law of cosines)
    r = np.sqrt(spec.alpha_length_mm ** 2 + spec.beta_length_mm ** 2
                + 2 * spec.alpha_length_mm * spec.beta_length_mm * np.cos(np.radians(170.0)))
    assert err[2] == pytest.approx(r * np.sqrt(2.0)) and np.delete(err, 2).max() == 0.0
