"""Tests of rfp_twin.twin.render.timeline: frame times at fps and speed-up, and the robot states
(moving, arrived, contact) of each frame of a simulated run."""
from __future__ import annotations

import math

import numpy as np
import pytest

import rfp_twin.twin.render  # noqa: F401  (first: picks MUJOCO_GL before mujoco is imported)
from rfp_twin.twin.render import (ARRIVED, CONTACT, MOVING, WAITING, RenderError, RenderSettings,
                         frame_timeline, frame_times)
from rfp_twin.twin.sim import simulate
from tests.twin.builders import centre_robot, colliding_run, moves_trajectory


@pytest.fixture(scope="module")
def colliding7(twin7):
    """The centre robot unfolds into its +x neighbour: (trajectory, SimReport)."""
    return colliding_run(twin7)


def test_frame_times_cover_the_run_at_fps_and_speedup():
    t = frame_times(6.5, RenderSettings(fps=10, speedup=2.0))
    assert t.size == 33 and t[0] == 0.0 and math.isclose(t[-1], 6.4)
    assert frame_times(1.0, RenderSettings(fps=30)).size == 31
    assert frame_times(0.0, RenderSettings()).tolist() == [0.0]


def test_timeline_states_of_a_colliding_run(twin7, colliding7):
    _, report = colliding7
    lay = twin7.layout
    c = lay.robot_index(centre_robot(lay))
    s = RenderSettings(width=160, height=120, fps=10, speedup=2.0)
    tl = frame_timeline(twin7, report, s)
    assert tl.n_frames == int(math.floor(report.sim_s * 10 / 2.0 + 1e-9)) + 1
    assert tl.angles.shape == (tl.n_frames, 7, 2) and tl.states.shape == (tl.n_frames, 7)
    assert tl.states[1, c] == MOVING                       # on its way
    assert np.any(tl.states[:, c] == CONTACT)              # then blocked by its neighbour
    touched = {lay.robot_index(int(r)) for p in report.contacts.pairs()
               for r in (p["robot_a"], p["robot_b"])}
    assert touched == {int(k) for k in np.flatnonzero((tl.states == CONTACT).any(axis=0))}
    others = [k for k in range(7) if k not in touched]
    assert np.all(tl.states[:, others] == ARRIVED)         # never moved, at their end
    counts = tl.state_counts()
    assert sum(counts.values()) == tl.states.size and counts["contact"] > 0


def test_timeline_interpolates_the_record_and_sees_waiting_robots(twin7):
    """A robot that waits 1 s, then turns alpha 10 -> 40 deg in 1 s: waiting, then moving
    at the interpolated angles, then arrived."""
    lay = twin7.layout
    rid = centre_robot(lay)
    k = lay.robot_index(rid)
    traj = moves_trajectory(lay, {rid: ([0.0, 1.0, 2.0], [10.0, 10.0, 40.0],
                                        [170.0, 170.0, 170.0])})
    report = simulate(twin7, traj)
    tl = frame_timeline(twin7, report, RenderSettings(fps=4))
    at = lambda t: int(np.argmin(np.abs(tl.times - t)))  # noqa: E731
    assert tl.states[at(0.5), k] == WAITING
    assert tl.states[at(1.5), k] == MOVING and 20.0 < tl.angles[at(1.5), k, 0] < 30.0
    assert tl.states[-1, k] == ARRIVED
    rec = report.record
    j = int(np.searchsorted(rec.times, 1.5))
    assert rec.times[j - 1] < 1.5 <= rec.times[j]
    assert rec.angles[j - 1, k, 0] <= tl.angles[at(1.5), k, 0] <= rec.angles[j, k, 0]


def test_report_without_record_is_refused(twin7, colliding7):
    traj, _ = colliding7
    report = simulate(twin7, traj, record=False)
    with pytest.raises(RenderError, match="no sampled record"):
        frame_timeline(twin7, report, RenderSettings())
