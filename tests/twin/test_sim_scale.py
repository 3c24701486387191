"""Tests of the simulator on a raft array where every robot moves at once: it runs within the
arena sized for the grid, with no MuJoCo warning, and every robot tracks its trajectory."""
from __future__ import annotations

import numpy as np

from rfp_twin.models.layout import layout_by_name
from rfp_twin.models.mjcf import build_model
from rfp_twin.models.robot import load_spec
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.twin.sim import SimSettings, simulate


def everyone_moves(layout, fold, swing_deg: float = 20.0, duration_s: float = 0.4) -> Trajectory:
    """Every robot leaves its fold by ``swing_deg`` on both axes and comes back."""
    n = layout.n_robots
    t = [[0.0, duration_s / 2.0, duration_s]] * n
    a, b = fold
    return Trajectory.from_breakpoints(layout.robot_ids, t, [[a, a + swing_deg, a]] * n,
                                       t, [[b, b - swing_deg, b]] * n)


def test_every_robot_of_four_rafts_moves_without_warning_or_contact():
    spec = load_spec("raft-6p2")
    lay = layout_by_name("raft:4", spec.pitch_mm)
    twin = build_model(spec, lay)
    traj = everyone_moves(lay, spec.fold_deg)
    report = simulate(twin, traj, settings=SimSettings(settle_s=0.3))
    assert report.warnings == {} and report.warning_messages == []
    assert len(report.contacts) == 0
    assert report.reached.all()
    # every robot moved: half-way through, each is ~swing_deg from its fold on both axes
    rec = report.record
    k = int(np.argmin(np.abs(rec.times - 0.2)))
    away = np.abs(rec.angles[k] - np.asarray(spec.fold_deg))
    assert np.all(away > 15.0)
    assert np.abs(report.max_error_deg).max() < 5.0
