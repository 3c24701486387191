"""Tests of the tiled simulation (twin/sim/tiled.py): on arrays small enough for one model,
the tiled twin moves every robot exactly as the one model does and reports the same
contacts, each once, also across tile borders and on threads."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.layout import layout_by_name
from rfp_twin.models.mjcf import build_model
from rfp_twin.models.mjcf.tiled_twin import build_tiled
from rfp_twin.models.robot import load_spec
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.twin.sim import SimSettings, Stuck, simulate
from rfp_twin.twin.sim.tiled import TiledSimulator

RAFT = load_spec("raft-6p2")
SDSS = load_spec("sdss-v")


def swings(layout, fold, alpha_deg, beta_deg, duration_s=0.6) -> Trajectory:
    """Each robot leaves its fold by its (alpha, beta) swing and comes back."""
    n = layout.n_robots
    t = [[0.0, duration_s / 2, duration_s]] * n
    a, b = fold
    return Trajectory.from_breakpoints(layout.robot_ids, t, [[a, a + x, a] for x in alpha_deg],
                                       t, [[b, b + x, b] for x in beta_deg])


def pair_set(report):
    return {(p["robot_a"], p.get("robot_b", -1), p.get("fiducial", -1))
            for p in report.contacts.pairs()}


@pytest.mark.parametrize("threads", [1, 2])
def test_colliding_swings_give_the_same_motion_and_contacts_as_one_model(threads):
    lay = layout_by_name("raft:4", RAFT.pitch_mm)
    rng = np.random.default_rng(1)
    traj = swings(lay, RAFT.fold_deg, rng.uniform(-180, 180, lay.n_robots),
                  rng.uniform(-170, 0, lay.n_robots))
    settings = SimSettings(settle_s=0.1)
    one = simulate(build_model(RAFT, lay), traj, settings=settings)
    tiled_twin = build_tiled(RAFT, lay, max_robots=32)
    tiled = TiledSimulator(tiled_twin, traj, settings=settings, threads=threads).run()
    assert len(tiled_twin.tiles) >= 8
    assert np.abs(one.record.angles - tiled.record.angles).max() < 1e-9
    assert len(one.contacts) > 100                      # the swings do collide
    assert pair_set(tiled) == pair_set(one)
    assert len(tiled.contacts) == len(one.contacts)     # each contact row once
    # some of those contacts join robots of two tiles
    owner = {}
    for t, tile in enumerate(tiled_twin.tiles):
        for r in tile.robots[tile.owned]:
            owner[int(lay.robot_ids[r])] = t
    assert any(owner[a] != owner[b] for a, b, _ in pair_set(tiled) if b >= 0)
    assert tiled.reached.tolist() == one.reached.tolist()


def test_a_stuck_robot_on_a_calibrated_wok_with_walls_matches_one_model():
    lay = layout_by_name("sdss-v-apo", SDSS.pitch_mm)
    n = lay.n_robots
    traj = swings(lay, SDSS.fold_deg, np.linspace(-60, 60, n), np.full(n, -30.0), 1.0)
    faults = [Stuck(int(lay.robot_ids[7]), 0.2)]
    settings = SimSettings(settle_s=0.1)
    one = simulate(build_model(SDSS, lay), traj, faults, settings)
    tiled = simulate(build_tiled(SDSS, lay, max_robots=100), traj, faults, settings)
    assert np.abs(one.final_error_deg - tiled.final_error_deg).max() < 1e-9
    assert one.max_error_deg == pytest.approx(tiled.max_error_deg, abs=1e-9)
    assert pair_set(one) == pair_set(tiled)
    assert tiled.faults == one.faults and not tiled.reached[7]


def test_short_command_chunks_change_nothing():
    """Large arrays compute servo targets in shorter chunks (twin/sim/tiled.py CHUNK_VALUES):
    the chunk length must not change the motion."""
    lay = layout_by_name("raft:1", RAFT.pitch_mm)
    traj = swings(lay, RAFT.fold_deg, np.full(lay.n_robots, 30.0), np.full(lay.n_robots, -20.0))
    tiled = build_tiled(RAFT, lay, max_robots=20)
    a = TiledSimulator(tiled, traj, settings=SimSettings(settle_s=0.1)).run()
    b = TiledSimulator(tiled, traj, settings=SimSettings(settle_s=0.1, chunk_s=0.012)).run()
    assert np.array_equal(a.record.angles, b.record.angles)
    assert all(t.twin.mjspec is None for t in tiled.tiles)     # tiles keep no MjSpec


def _same_run(a, b) -> None:
    assert np.array_equal(a.record.angles, b.record.angles)
    assert np.array_equal(a.max_error_deg, b.max_error_deg)
    assert np.array_equal(a.final_error_deg, b.final_error_deg)
    for f in ("time_s", "robot_a", "robot_b", "fiducial", "depth_mm"):
        assert np.array_equal(getattr(a.contacts, f), getattr(b.contacts, f))
    assert a.warnings == b.warnings


@pytest.mark.parametrize("threads", [1, 2])
def test_blocks_without_contact_move_every_robot_as_lock_step(threads):
    """Tiles stepping blocks alone (halos synchronised at the block's end) give the
    lock-step run bit for bit when no robot touches another."""
    lay = layout_by_name("raft:4", RAFT.pitch_mm)
    n = lay.n_robots
    traj = swings(lay, RAFT.fold_deg, np.linspace(-25, 25, n), np.full(n, -15.0))
    tiled_twin = build_tiled(RAFT, lay, max_robots=64)
    settings = SimSettings(settle_s=0.1)
    lock = TiledSimulator(tiled_twin, traj, settings=settings, threads=threads, block_steps=1)
    blocks = TiledSimulator(tiled_twin, traj, settings=settings, threads=threads, block_steps=8)
    a, b = lock.run(), blocks.run()
    assert len(a.contacts) == 0 and blocks.rollbacks == 0 and blocks.blocks >= 10
    _same_run(a, b)
    one = simulate(build_model(RAFT, lay), traj, settings=settings)
    assert np.abs(one.record.angles - b.record.angles).max() < 1e-9


def test_a_block_that_meets_a_contact_is_redone_in_lock_step():
    lay = layout_by_name("raft:4", RAFT.pitch_mm)
    rng = np.random.default_rng(1)
    traj = swings(lay, RAFT.fold_deg, rng.uniform(-180, 180, lay.n_robots),
                  rng.uniform(-170, 0, lay.n_robots))
    tiled_twin = build_tiled(RAFT, lay, max_robots=64)
    settings = SimSettings(settle_s=0.1)
    lock = TiledSimulator(tiled_twin, traj, settings=settings, block_steps=1)
    blocks = TiledSimulator(tiled_twin, traj, settings=settings, block_steps=8)
    a, b = lock.run(), blocks.run()
    assert blocks.rollbacks >= 1 and len(a.contacts) > 100
    _same_run(a, b)
