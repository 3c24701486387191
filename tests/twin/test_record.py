"""Tests of rfp_twin.twin.record: a Rerun .rrd of a run that `rerun rrd verify` accepts and that
holds the arm poses over time, the fiber traces and the contacts."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from collections import defaultdict
from pathlib import Path

import mujoco
import numpy as np
import pytest
from rerun.chunk import RrdReader

from rfp_twin.models.trajectory import Trajectory
from rfp_twin.twin.record import RecordError, RecordSettings, record_run
from rfp_twin.twin.sim import simulate
from tests.twin.builders import centre_robot, colliding_run, moves_trajectory


def rerun_cli() -> str:
    exe = Path(sys.executable).parent / "rerun"
    found = str(exe) if exe.exists() else shutil.which("rerun")
    assert found, "the `rerun` command (rerun-sdk) is not installed next to this Python"
    return found


def rrd_verify(path: Path, config_home: Path) -> subprocess.CompletedProcess:
    """`rerun rrd verify PATH`, with analytics off in a private config folder."""
    env = dict(os.environ, XDG_CONFIG_HOME=str(config_home))
    subprocess.run([rerun_cli(), "analytics", "disable"], env=env, capture_output=True,
                   timeout=120)
    return subprocess.run([rerun_cli(), "rrd", "verify", str(path)], env=env,
                          capture_output=True, text=True, timeout=300)


def chunks_by_entity(path: Path) -> dict[str, list]:
    out = defaultdict(list)
    for chunk in RrdReader(path).stream():
        out[str(chunk.entity_path)].append(chunk)
    return out


def rows(chunks, static: bool | None = None) -> int:
    return sum(c.num_rows for c in chunks if static is None or c.is_static == static)


@pytest.fixture(scope="module")
def colliding7(twin7):
    """The centre robot unfolds into its +x neighbour: (trajectory, SimReport)."""
    return colliding_run(twin7)


def test_recording_verifies_and_holds_poses_traces_and_contacts(tmp_path, twin7, colliding7):
    traj, report = colliding7
    out = tmp_path / "run.rrd"
    assert record_run(twin7, traj, out, sim_report=report) == out
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.rrd"]     # no temp file left
    v = rrd_verify(out, tmp_path / "config")
    assert v.returncode == 0, v.stdout + v.stderr
    ent = chunks_by_entity(out)
    lay = twin7.layout
    centre = centre_robot(lay)
    for rid in lay.robot_ids:
        assert rows(ent[f"/robots/{int(rid)}"], static=True) == 1
        for link in ("body", "alpha", "alpha/beta", "alpha/beta/fibers"):
            assert rows(ent[f"/robots/{int(rid)}/{link}"], static=True) >= 1
    # poses over time: the moving robot has one per sample while it moves, still ones one
    samples = report.record.times.size
    moving = rows(ent[f"/robots/{centre}/alpha/beta"], static=False)
    assert 0.5 * samples < moving <= samples
    touched = {int(r) for p in report.contacts.pairs() for r in (p["robot_a"], p["robot_b"])}
    still = [int(r) for r in lay.robot_ids if int(r) not in touched]       # never pushed
    assert len(still) == 5
    assert all(rows(ent[f"/robots/{r}/alpha/beta"], static=False) == 1 for r in still)
    for fiber in twin7.index.fiber_names:
        assert rows(ent[f"/traces/{fiber}"], static=True) == 1
    assert rows(ent["/contacts"], static=False) >= 2      # contact points, then the clearing
    assert rows(ent["/summary"], static=True) == 1 and rows(ent["/plate"], static=True) == 1


def _transform(chunks, row: int = 0):
    """(translation (3,), rotation (3, 3), time s or None) of one row of Transform3D data."""
    for ch in chunks:
        rb = ch.to_record_batch()
        if "Transform3D:translation" in rb.schema.names and rb.num_rows > row:
            t = np.array(rb.column("Transform3D:translation").to_pylist()[row][0])
            x, y, z, w = rb.column("Transform3D:quaternion").to_pylist()[row][0]
            mat = np.zeros(9)
            mujoco.mju_quat2Mat(mat, np.array([w, x, y, z]))
            when = rb.column("sim_time").to_pylist()[row] if "sim_time" in rb.schema.names else None
            return t, mat.reshape(3, 3), (when.total_seconds() if when is not None else None)
    raise AssertionError("no Transform3D row")


def test_logged_transforms_compose_to_the_mujoco_poses(tmp_path, twin7):
    """robot frame * alpha (relative) * beta (relative) = the beta body's world pose."""
    ids = twin7.layout.robot_ids
    n = ids.size
    traj = Trajectory.from_breakpoints(ids, [[0.0, 2.0]] * n, [[10.0, 100.0]] * n,
                                       [[0.0, 2.0]] * n, [[170.0, 60.0]] * n)
    report = simulate(twin7, traj)
    out = record_run(twin7, traj, tmp_path / "a.rrd", sim_report=report)
    ent = chunks_by_entity(out)
    k = 3
    rid = int(ids[k])
    t0, r0, _ = _transform(ent[f"/robots/{rid}"])
    t1, r1, s1 = _transform(ent[f"/robots/{rid}/alpha"], 40)
    t2, r2, s2 = _transform(ent[f"/robots/{rid}/alpha/beta"], 40)
    assert s1 == s2 and 0.5 < s1 < 1.5
    i = int(np.argmin(np.abs(report.record.times - s1)))
    d = mujoco.MjData(twin7.model)
    d.qpos[twin7.index.qpos_adr.ravel()] = np.radians(report.record.angles[i]).ravel()
    mujoco.mj_kinematics(twin7.model, d)
    b = twin7.index.beta_body[k]
    np.testing.assert_allclose(t0 + r0 @ (t1 + r1 @ t2), d.xpos[b], atol=1e-4)
    np.testing.assert_allclose(r0 @ r1 @ r2, d.xmat[b].reshape(3, 3), atol=1e-5)


def test_record_runs_the_simulation_itself(tmp_path, twin7):
    lay = twin7.layout
    traj = moves_trajectory(lay, {centre_robot(lay): ([0.0, 1.0], [10.0, 40.0], [170.0, 170.0])})
    out = record_run(twin7, traj, tmp_path / "sub" / "a.rrd",
                     settings=RecordSettings(dt_s=0.1, trace_fibers=("metrology",)))
    assert rrd_verify(out, tmp_path / "config").returncode == 0
    ent = chunks_by_entity(out)
    assert "/contacts" not in ent and "/traces/boss" not in ent and "/traces/metrology" in ent


def test_bad_requests_raise_and_leave_nothing(tmp_path, twin7, colliding7):
    traj, _ = colliding7
    with pytest.raises(RecordError, match="field 'trace_fibers' = \\['nope'\\]; allowed: metrology"):
        record_run(twin7, traj, tmp_path / "a.rrd", sim_report=colliding7[1],
                   settings=RecordSettings(trace_fibers=("nope",)))
    with pytest.raises(RecordError, match="no sampled record"):
        record_run(twin7, traj, tmp_path / "a.rrd", sim_report=simulate(twin7, traj, record=False))
    with pytest.raises(RecordError, match="dt_s"):
        RecordSettings(dt_s=-1.0)
    assert list(tmp_path.iterdir()) == []




def test_fibers_a_robot_lacks_are_not_drawn_and_a_guide_camera_edge_is_its_wall(tmp_path):
    """Robot 0 carries no BOSS fiber (blank columns); robot 1 does; a gfa row is a segment:
    the recording draws robot 0's metrology fiber only, a BOSS trace for robot 1 only (no
    stray point at another robot's site), and the wall box where the model has it."""
    from rfp_twin.models.layout import Layout
    from rfp_twin.models.mjcf import build_model
    from rfp_twin.models.robot import load_spec

    lay = Layout([0, 1, 9], [[0.0, 0.0], [60.0, 0.0], [-30.0, 20.0]], ["robot", "robot", "gfa"],
                 name="wall", extra={"x2_mm": ["", "", "30.0"], "y2_mm": ["", "", "20.0"],
                                     "boss_x_mm": ["", "14.965", ""],
                                     "boss_y_mm": ["", "-0.376", ""]})
    twin = build_model(load_spec("sdss-v"), lay)
    assert twin.index.fiber_site[0, 1] < 0 <= twin.index.fiber_site[1, 1]
    traj = moves_trajectory(lay, {0: ([0.0, 1.0], [10.0, 200.0], [170.0, 150.0]),
                                  1: ([0.0, 1.0], [10.0, 200.0], [170.0, 150.0])})
    out = record_run(twin, traj, tmp_path / "w.rrd", settings=RecordSettings(contacts=False))
    assert rrd_verify(out, tmp_path / "config").returncode == 0
    ent = chunks_by_entity(out)

    def column(path, name):
        for ch in ent[path]:
            rb = ch.to_record_batch()
            if name in rb.schema.names:
                return rb.column(name).to_pylist()[0]
        raise AssertionError(f"{path}: no {name}")

    assert column("/robots/0/alpha/beta/fibers", "Points3D:labels") == ["metrology"]
    assert sorted(column("/robots/1/alpha/beta/fibers", "Points3D:labels")) == ["boss",
                                                                                 "metrology"]
    assert column("/traces/boss", "LineStrips3D:labels") == ["r1"]
    strips = column("/traces/boss", "LineStrips3D:strips")
    assert len(strips) == 1 and np.isfinite(np.array(strips[0])).all()
    assert len(column("/traces/metrology", "LineStrips3D:strips")) == 2
    # the wall: the model's visual box, in the world
    m = twin.model
    g = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, [mujoco.mj_id2name(
        m, mujoco.mjtObj.mjOBJ_GEOM, int(i)) for i in np.flatnonzero(twin.index.geom_fiducial == 0)
        if "visual" in mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, int(i))][0])
    d = twin.make_data(np.zeros((2, 2)))
    assert "/fiducials/9" not in ent
    np.testing.assert_allclose(column("/gfa/9", "Boxes3D:centers"), [d.geom_xpos[g]], atol=1e-5)
    np.testing.assert_allclose(column("/gfa/9", "Boxes3D:half_sizes"), [m.geom_size[g]], atol=1e-5)
