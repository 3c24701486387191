"""Tests of rfp_twin.twin.sim.contacts: a hand-built colliding trajectory makes contacts between
exactly the robots that collide (or the robot and the fiducial it hits), and the contact
log summarises them per pair."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.layout import Layout
from rfp_twin.models.mjcf import build_model
from rfp_twin.models.robot import load_spec
from rfp_twin.twin.sim import ContactLog, simulate
from tests.twin.builders import centre_robot, colliding_trajectory, right_neighbour


def test_hand_built_colliding_trajectory_makes_robot_contacts(twin7):
    """The centre robot unfolds straight towards its +x neighbour (22.4 mm away), whose
    folded beta arm lies across the path: they must touch, and nothing else."""
    lay = twin7.layout
    c, right = centre_robot(lay), right_neighbour(lay)
    report = simulate(twin7, colliding_trajectory(lay))
    assert report.warnings == {}
    assert report.robot_contacts > 0 and report.fiducial_contacts == 0
    log = report.contacts
    assert (log.robot_a == min(c, right)).all() and (log.robot_b == max(c, right)).all()
    assert (log.fiducial == -1).all() and (log.depth_mm >= 0).all()
    assert log.pos_mm.shape == (len(log), 3) and np.all(np.diff(log.time_s) >= 0)
    pairs = log.pairs()
    assert {(p["robot_a"], p["robot_b"]) for p in pairs} == {tuple(sorted((c, right)))}
    assert pairs[0]["max_depth_mm"] > 0 and 2.0 < pairs[0]["first_s"] < 6.0
    assert pairs[0]["rows"] == len(log)
    assert not report.ok
    assert not report.reached[lay.robot_index(c)]                     # blocked


def test_robot_hitting_a_fiducial_is_reported():
    spec = load_spec("sdss-v")
    grid = Layout.hex_grid(1, spec.pitch_mm)
    right = right_neighbour(grid)
    lay = Layout(grid.ids, grid.xy, np.where(grid.ids == right, "fiducial", "robot"))
    twin = build_model(spec, lay)
    c = centre_robot(lay)
    report = simulate(twin, colliding_trajectory(lay))
    assert report.robot_contacts == 0 and report.fiducial_contacts > 0
    assert {(p["robot_a"], p["fiducial"]) for p in report.contacts.pairs()} == {(c, right)}
    assert (report.contacts.robot_b == -1).all()


def test_contact_log_pairs_summarise_rows():
    log = ContactLog(time_s=np.array([0.1, 0.2, 0.3, 0.4]), robot_a=np.array([1, 1, 1, 5]),
                     robot_b=np.array([2, 2, -1, 6]), fiducial=np.array([-1, -1, 9, -1]),
                     depth_mm=np.array([0.01, 0.05, 0.02, 0.03]), pos_mm=np.zeros((4, 3)))
    assert len(log) == 4 and log.robot_robot.tolist() == [True, True, False, True]
    pairs = {(p["robot_a"], p.get("robot_b"), p.get("fiducial")): p for p in log.pairs()}
    assert set(pairs) == {(1, 2, None), (1, None, 9), (5, 6, None)}
    p = pairs[(1, 2, None)]
    assert (p["first_s"], p["last_s"], p["rows"]) == (0.1, 0.2, 2)
    assert p["max_depth_mm"] == pytest.approx(0.05)
    empty = ContactLog.empty()
    assert len(empty) == 0 and empty.pairs() == [] and empty.pos_mm.shape == (0, 3)
