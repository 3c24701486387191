"""Tests of rfp_twin.twin.sim.faults: faults show as the tracking errors they should (a stuck
robot's error grows, a slow robot lags, an encoder offset is a constant error), combine
per robot, and are checked."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.errors import TrajectoryError, UnknownRobotError
from rfp_twin.twin.sim import EncoderOffset, SimSettings, Simulator, Slow, Stuck, simulate
from rfp_twin.twin.sim.faults import fault_effects
from tests.twin.builders import swing_trajectory


def _alpha_error_at(report, k: int):
    """Function t -> alpha tracking error (true - nominal, deg) of robot index k at the
    recorded sample nearest t s."""
    rec = report.record
    err = rec.angles[:, k, 0] - rec.reference[:, k, 0]
    return lambda t: err[np.argmin(np.abs(rec.times - t))]


def test_stuck_robot_error_grows(twin7):
    c, traj = swing_trajectory(twin7.layout)
    report = simulate(twin7, traj, [Stuck(c, 1.0)])
    k = twin7.layout.robot_index(c)
    at = _alpha_error_at(report, k)
    assert abs(at(1.0)) < 0.5
    assert at(2.0) == pytest.approx(-30.0, abs=1.0)
    assert at(3.0) == pytest.approx(-60.0, abs=1.0)
    assert report.final_error_deg[k, 0] == pytest.approx(-60.0, abs=0.5)
    assert not report.reached[k] and report.reached[np.arange(7) != k].all()
    assert report.faults == [f"robot {c} stuck from t = 1 s"]


def test_slow_robot_lags(twin7):
    c, traj = swing_trajectory(twin7.layout)
    report = simulate(twin7, traj, [Slow(c, 2.0)])
    at = _alpha_error_at(report, twin7.layout.robot_index(c))
    assert -at(1.0) == pytest.approx(15.0, abs=0.7)                  # half speed
    assert -at(2.0) == pytest.approx(30.0, abs=0.7)
    assert -at(3.0) == pytest.approx(45.0, abs=0.7)
    assert report.faults == [f"robot {c} slow by a factor 2"]
    # given the time, it gets there
    long = simulate(twin7, traj, [Slow(c, 2.0)], SimSettings(duration_s=6.5), record=False)
    assert long.reached.all()


def test_encoder_offset_is_a_constant_error(twin7):
    c, traj = swing_trajectory(twin7.layout)
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
    assert report.faults == [f"robot {c} encoder offset (0.5, -0.3) deg"]


def test_faults_combine_per_robot(twin7):
    lay = twin7.layout
    a, b = (int(r) for r in lay.robot_ids[:2])
    fx = fault_effects([Slow(a, 2.0), Slow(a, 3.0), Stuck(b, 4.0), Stuck(b, 1.5),
                        EncoderOffset(b, 0.5), EncoderOffset(b, 0.25, -1.0)], lay)
    ka, kb = lay.robot_index(a), lay.robot_index(b)
    assert fx.warp_scale[ka] == pytest.approx(1 / 6) and fx.stuck_at[kb] == 1.5
    assert fx.offset[kb].tolist() == [0.75, -1.0]
    others = np.ones(lay.n_robots, bool)
    others[[ka, kb]] = False
    assert (fx.warp_scale[others] == 1).all() and np.isinf(fx.stuck_at[others]).all()
    assert (fx.offset[others] == 0).all() and fx.offset.shape == (lay.n_robots, 2)


def test_faults_are_checked(twin7):
    _, traj = swing_trajectory(twin7.layout)
    with pytest.raises(UnknownRobotError):
        Simulator(twin7, traj, [Stuck(99, 1.0)])
    with pytest.raises(TrajectoryError, match="factor"):
        Simulator(twin7, traj, [Slow(3, 0.0)])
    with pytest.raises(TrajectoryError, match="time_s"):
        Simulator(twin7, traj, [Stuck(3, -1.0)])
    with pytest.raises(TrajectoryError, match="unknown fault"):
        fault_effects([type("Broken", (), {"robot_id": 3})()], twin7.layout)


def test_faults_are_values():
    assert Stuck(3, 1.0) == Stuck(robot_id=3, time_s=1.0) and Stuck(3, 1.0) != Slow(3, 1.0)
    assert len({Stuck(3, 1.0), Stuck(3, 1.0), EncoderOffset(3)}) == 2
    assert repr(EncoderOffset(3, beta_deg=1.0)) == \
        "EncoderOffset(robot_id=3, alpha_deg=0.0, beta_deg=1.0)"
