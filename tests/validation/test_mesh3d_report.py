"""Tests of the 3D check's report (validation/mesh3d/report.py)."""
from __future__ import annotations

import json
import math

from tests.validation.conftest import SPEC, pair_layout, sdss_models, swing
from rfp_twin.validation.mesh3d import Check3DReport, Collision3D, PairDistance, validate_trajectory

MODELS = sdss_models()


def test_report_serialises_and_counts_work():
    traj = swing([0.0, 1.0], [90.0, 30.0], 1.0)
    rep = validate_trajectory(traj, SPEC, pair_layout(), MODELS)
    assert isinstance(rep, Check3DReport)
    d = json.loads(json.dumps(rep.to_dict()))
    assert d["ok"] and d["n_pairs"] == 1 and d["n_collisions"] == 0
    assert d["n_fcl_calls"] >= 1 and d["n_exact_evals"] >= 1 and d["n_capsule_evals"] > 0
    assert set(d["link_kind_min_mm"]) == {"alpha-beta", "beta-beta"}
    assert "3D check (FCL): OK" in rep.table()


def test_hand_built_report_json_and_table():
    pairs = [PairDistance("robot", (3, 14), ("beta", "beta"), 0.0, 0.15),
             PairDistance("fiducial", (3, 7), ("", ""), math.inf, math.nan)]
    coll = [Collision3D("robot", 3, "beta", 14, "beta", 0.1, 0.2, 0.15, 0.0),
            Collision3D("fiducial", 3, "beta", 7, "fiducial", 1.0, 1.0, 1.0, 0.25, True)]
    rep = Check3DReport(min_gap_mm=0.5, geometry="procedural", n_robots=2, n_fiducials=1,
                        n_pairs=2, n_link_pairs=4, duration_s=2.0, pairs=pairs,
                        min_distance_mm=0.0, link_kind_min_mm={"beta-beta": 0.0,
                                                               "alpha-beta": math.inf},
                        collisions=coll)
    assert not rep.ok and rep.min_clearance_mm == -0.5
    d = json.loads(json.dumps(rep.to_dict(), allow_nan=False))
    assert d["pairs"][1] == {"kind": "fiducial", "ids": [3, 7], "links": ["", ""],
                             "min_distance_mm": None, "t_min": None}
    assert d["link_kind_min_mm"] == {"beta-beta": 0.0, "alpha-beta": None}
    assert d["collisions"][1] == {"kind": "fiducial", "robot_a": 3, "link_a": "beta",
                                  "other": 7, "link_b": "fiducial", "t_start": 1.0,
                                  "t_end": 1.0, "t_min": 1.0, "min_distance_mm": 0.25,
                                  "conservative": True}
    lines = rep.table().splitlines()
    assert lines[0].startswith("3D check (FCL): COLLISION  2 robots, 1 fiducials, 2 pairs")
    assert lines[1] == "  per link pair (mm): beta-beta 0.000"        # inf left out
    assert lines[3].split() == ["kind", "robot", "link", "other", "link", "t_start", "t_end",
                                "t_min", "min", "mm"]
    assert lines[4].split() == ["robot", "3", "beta", "14", "beta", "0.10000", "0.20000",
                                "0.15000", "0.0000"]
    assert lines[5].endswith("0.2500  (bound)")
