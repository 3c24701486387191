"""Tests of twin/record_poses.py: a tiled twin gives the recording the same link poses,
fiber tips and static parts as the one-model twin (calibrated SDSS-V APO wok with walls), and
a recording of a tiled run verifies and names every robot and obstacle once."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.layout import layout_by_name
from rfp_twin.models.mjcf import build_model
from rfp_twin.models.mjcf.tiled_twin import build_tiled
from rfp_twin.models.robot import load_spec
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.twin.record import record_run
from rfp_twin.twin.record_poses import link_poses, quat_conj, quat_mul
from rfp_twin.twin.sim import SimSettings, simulate
from tests.twin.test_record import chunks_by_entity, rows, rrd_verify

SPEC = load_spec("sdss-v")


def test_quaternion_product_and_conjugate():
    q = np.array([np.cos(0.3), 0.0, 0.0, np.sin(0.3)])        # 0.6 rad about z
    assert quat_mul(q, quat_conj(q)) == pytest.approx([1, 0, 0, 0])
    assert quat_mul(q, q) == pytest.approx([np.cos(0.6), 0, 0, np.sin(0.6)])


def test_tiled_poses_equal_the_one_model_poses():
    lay = layout_by_name("sdss-v-apo", SPEC.pitch_mm)
    n = lay.n_robots
    rng = np.random.default_rng(3)
    angles = np.stack([np.column_stack([rng.uniform(0, 360, n), rng.uniform(0, 180, n)])
                       for _ in range(3)])
    one = link_poses(build_model(SPEC, lay), angles, [0, 2])
    tiled = link_poses(build_tiled(SPEC, lay, max_robots=150), angles, [0, 2])
    for name in one.__dataclass_fields__:
        a, b = getattr(one, name), getattr(tiled, name)
        assert a.shape == b.shape, name
        np.testing.assert_allclose(np.nan_to_num(a, nan=-7.0), np.nan_to_num(b, nan=-7.0),
                                   atol=1e-9, err_msg=name)
    assert np.isnan(one.tips).any()              # robots without a BOSS / APOGEE fiber


def _one_move(lay, t_end: float, alpha: tuple, beta: tuple) -> Trajectory:
    """Every robot of ``lay`` moves from (alpha[0], beta[0]) to (alpha[1], beta[1]) deg in
    ``t_end`` s."""
    n = lay.robot_ids.size
    t = [[0.0, t_end]] * n
    return Trajectory.from_breakpoints(lay.robot_ids, t, [list(alpha)] * n, t, [list(beta)] * n)


def test_a_tiled_recording_verifies_with_each_robot_and_wall_once(tmp_path):
    lay = layout_by_name("sdss-v-apo", SPEC.pitch_mm)
    n = lay.robot_ids.size
    traj = _one_move(lay, 0.4, (0.0, 30.0), (180.0, 150.0))
    tiled = build_tiled(SPEC, lay, max_robots=150)
    report = simulate(tiled, traj, settings=SimSettings(settle_s=0.0))
    out = record_run(tiled, traj, tmp_path / "t.rrd", sim_report=report)
    assert rrd_verify(out, tmp_path / "config").returncode == 0
    ent = chunks_by_entity(out)
    assert sum(1 for e in ent if e.count("/") == 2 and e.startswith("/robots/")) == n
    gfa = [e for e in ent if e.startswith("/gfa/")]
    assert len(gfa) == 6 and all(rows(ent[e], static=True) == 1 for e in gfa)
    assert rows(ent["/plate"], static=True) == 1


def test_record_reports_its_progress_over_every_robot(tmp_path):
    lay = layout_by_name("hex:37", SPEC.pitch_mm)
    n = lay.robot_ids.size
    traj = _one_move(lay, 0.2, (0.0, 10.0), (180.0, 170.0))
    calls = []
    record_run(build_tiled(SPEC, lay, max_robots=10), traj, tmp_path / "p.rrd",
               progress=lambda done, total: calls.append((done, total)))
    assert len(calls) >= 4 and calls[-1] == (n, n)
    assert [c[0] for c in calls] == sorted(c[0] for c in calls)
