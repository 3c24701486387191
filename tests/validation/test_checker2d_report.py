"""Tests of the 2D check's report (validation/checker2d/report.py)."""
from __future__ import annotations

import json

import numpy as np

from rfp_twin.models.trajectory import Trajectory
from tests.validation.conftest import SPEC, pair_layout, swing
from rfp_twin.validation.checker2d import CheckReport, Collision, check_trajectory

BUF = 2.5


def test_report_serialises_to_json():
    traj = swing([0.0, 0.1, 0.1025, 0.105, 0.2], [90.0, 90.0, 39.0, 90.0, 90.0], 0.2)
    report = check_trajectory(traj, SPEC, pair_layout(), BUF)
    assert isinstance(report, CheckReport) and isinstance(report.collisions[0], Collision)
    data = json.loads(json.dumps(report.to_dict(), allow_nan=False))
    assert data["ok"] is False and data["n_collisions"] == 1
    assert data["pair_ids"] == [[0, 1]] and len(data["pair_min_distance_mm"]) == 1
    assert data["collisions"][0]["kind"] == "robot"
    assert "COLLISION" in report.table()
    # a lone robot has no pair: clearance is inf and serialises as null
    lone = Trajectory.from_breakpoints([0], [[0.0]], [[0.0]], [[0.0]], [[180.0]])
    alone = check_trajectory(lone, SPEC, pair_layout(), BUF)
    assert alone.ok and alone.n_pairs == 0 and alone.to_dict()["min_clearance_mm"] is None




def test_table_lists_every_collision_and_marks_bounds():
    none = np.empty((0, 2), dtype=np.int64)
    report = CheckReport(buffer_mm=2.0, n_robots=3, n_pairs=2, n_fiducial_pairs=1,
                         duration_s=4.0, n_samples=99, pair_ids=none, pair_min_distance_mm=[],
                         fiducial_pair_ids=none, fiducial_min_distance_mm=[],
                         min_clearance_mm=-0.5,
                         collisions=[Collision("robot", 3, 14, 0.1, 0.2, 0.15, 3.5, 4.0),
                                     Collision("fiducial", 7, 1001, 1.0, 1.1, 1.05, 2.9, 3.0,
                                               conservative=True)])
    assert not report.ok
    lines = report.table().splitlines()
    assert lines[0].startswith("2D dense check: COLLISION  buffer 2.0 mm, 3 robots")
    assert "min clearance -0.5000 mm" in lines[0]
    assert lines[1].split() == ["kind", "robot", "other", "t_start", "t_end", "t_min", "min",
                                "mm", "thr", "mm"]
    assert lines[2].split() == ["robot", "3", "14", "0.10000", "0.20000", "0.15000", "3.5000",
                                "4.000"]
    assert lines[3].endswith("2.9000   3.000  (bound)")
    assert report.to_dict()["collisions"][1] == {
        "kind": "fiducial", "robot_a": 7, "other": 1001, "t_start": 1.0, "t_end": 1.1,
        "t_min": 1.05, "min_distance_mm": 2.9, "threshold_mm": 3.0, "conservative": True}
