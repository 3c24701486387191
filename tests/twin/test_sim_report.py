"""Tests of rfp_twin.twin.sim.report: the report of a run as JSON, a terminal table, per-robot
errors and the sampled record."""
from __future__ import annotations

import json

import numpy as np
import pytest

from rfp_twin.models.errors import RfpError, UnknownRobotError
from rfp_twin.twin.sim import SimSettings, simulate
from tests.twin.builders import colliding_trajectory, swing_trajectory


@pytest.fixture(scope="module")
def swing7(twin7):
    c, traj = swing_trajectory(twin7.layout)
    return c, simulate(twin7, traj, settings=SimSettings(record_dt_s=0.1))


def test_json_summary_holds_every_robot(twin7, swing7, tmp_path):
    c, report = swing7
    report.to_json(tmp_path / "sim.json")
    data = json.loads((tmp_path / "sim.json").read_text())
    assert data["ok"] is True and data["robots"] == 7 and data["contact_pairs"] == []
    assert set(data["per_robot"]) == {str(int(r)) for r in twin7.layout.robot_ids}
    assert data["worst_robot"] == c                                 # the one that moved
    k = twin7.layout.robot_index(c)
    assert data["per_robot"][str(c)]["max_error_deg"] == report.max_error_deg[k].tolist()
    assert data["sim_s"] == pytest.approx(3.5) and data["n_steps"] == report.n_steps
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sim.json"]


def test_table_and_per_robot_errors(twin7, swing7):
    c, report = swing7
    assert report.table().row_count >= 8
    k = twin7.layout.robot_index(c)
    e = report.error_of(c)
    assert e == {"max": report.max_error_deg[k].tolist(), "rms": report.rms_error_deg[k].tolist(),
                 "final": report.final_error_deg[k].tolist()}
    with pytest.raises(UnknownRobotError, match="robot 999 is not in this report"):
        report.error_of(999)
    assert report.realtime_factor == pytest.approx(report.sim_s / report.wall_s)


def test_sampled_record_or_a_clear_error(twin7, swing7):
    _, report = swing7
    rec = report.sampled_record()
    assert rec.angles.shape == rec.measured.shape == rec.reference.shape == (rec.times.size, 7, 2)
    assert np.allclose(np.diff(rec.times), 0.1)
    _, traj = swing_trajectory(twin7.layout)
    bare = simulate(twin7, traj, record=False)
    assert bare.record is None
    with pytest.raises(RfpError, match="no sampled record"):
        bare.sampled_record()
    with pytest.raises(KeyError):
        bare.sampled_record(KeyError)


def test_a_collision_is_not_ok(twin7):
    report = simulate(twin7, colliding_trajectory(twin7.layout), record=False)
    assert report.collided and not report.ok
    d = report.to_dict()
    assert d["robot_contact_rows"] == report.robot_contacts > 0
    assert d["max_depth_mm"] == pytest.approx(float(report.contacts.depth_mm.max()))
    assert report.to_dict()["not_reached"] == [int(r) for r in report.robot_ids[~report.reached]]
