"""Simulating a tiled twin (:class:`rfp_twin.models.mjcf.tiled_twin.TiledTwin`): every tile
steps its own MuJoCo model, in lock step, its halo robots moved with their owners.

One physics step of the whole array:

1. every tile takes the whole-array state of the step's start (joint angles and speeds,
   ``qpos`` / ``qvel`` of each robot from the tile that owns it) for its halo robots, and
   the servo targets of all its robots;
2. every tile steps (the tiles are shared among ``threads`` threads: MuJoCo releases the
   GIL while it steps);
3. every tile writes its owned robots' new state into the next whole-array state.

So a halo robot starts every step exactly where its owner has it, and each contact between
an owned robot and a halo robot acts on the owned robot in its tile as it would in one
model; the halo robot gets the matching push in its own tile, where the first is halo.
Without contacts every robot's motion is that of the one-model simulation.
A contact across two tiles is seen by both and kept once (by the tile owning the lower
robot id: :class:`rfp_twin.twin.sim.contacts.ContactRecorder`).

The report is the same :class:`rfp_twin.twin.sim.report.SimReport` as for one model.
Units: angles in degrees, times in seconds, lengths in mm; n robots in layout order.
"""
from __future__ import annotations

import os
import time
from concurrent.futures import ThreadPoolExecutor

import mujoco
import numpy as np

from rfp_twin.models.mjcf import collect_mujoco_warnings
from rfp_twin.models.mjcf.tiled_twin import Tile, TiledTwin
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.twin.sim.contacts import ContactLog, ContactRecorder
from rfp_twin.twin.sim.control import TrackingError
from rfp_twin.twin.sim.report import SimReport
from rfp_twin.twin.sim.simulator import _RunSetup, mujoco_warnings, step_count

#: Largest number of values in one chunk of servo targets or nominal angles (steps x 2n):
#: a chunk of ``chunk_s`` is shortened on large arrays so that its arrays stay ~64 MB.
CHUNK_VALUES = 8_000_000


def _flat(robots: np.ndarray) -> np.ndarray:
    """Flat (alpha, beta) indices ``2 r, 2 r + 1`` of robot indices (r,) -> (2r,)."""
    return (2 * np.asarray(robots, dtype=np.int64)[:, None] + np.arange(2)).ravel()


class _TileState:
    """A tile's MjData and the index maps between it and the whole-array arrays."""

    def __init__(self, tile: Tile) -> None:
        self.tile = tile
        tw = tile.twin
        self.model = tw.model
        self.data = mujoco.MjData(tw.model)
        idx = tw.index
        own, halo = tile.owned, ~tile.owned
        self.own_q = idx.qpos_adr[own].ravel()
        self.own_v = idx.dof_adr[own].ravel()
        self.own_g = _flat(tile.robots[own])
        self.halo_q = idx.qpos_adr[halo].ravel()
        self.halo_v = idx.dof_adr[halo].ravel()
        self.halo_g = _flat(tile.robots[halo])
        self.act = idx.actuator.ravel()
        self.act_g = _flat(tile.robots)
        self.contacts = ContactRecorder(idx, owned=tile.owned)
        # views into the MjData buffers, made once (each attribute access builds a new one)
        self._qpos, self._qvel, self._ctrl = self.data.qpos, self.data.qvel, self.data.ctrl

    def step(self, q_now: np.ndarray, v_now: np.ndarray, ctrl: np.ndarray, q_next: np.ndarray,
             v_next: np.ndarray, t_now: float) -> None:
        """One physics step from the whole-array state (q_now, v_now) (2n,) rad, rad/s
        with servo targets ctrl (2n,) rad; writes the owned robots into (q_next, v_next)."""
        d = self.data
        qpos, qvel = self._qpos, self._qvel
        qpos[self.halo_q] = q_now[self.halo_g]
        qvel[self.halo_v] = v_now[self.halo_g]
        self._ctrl[self.act] = ctrl[self.act_g]
        mujoco.mj_step(self.model, d)
        if d.ncon:
            self.contacts.add(d, t_now)
        q_next[self.own_g] = qpos[self.own_q]
        v_next[self.own_g] = qvel[self.own_v]


def _balanced_groups(sizes: list[int], k: int) -> list[list[int]]:
    """Split items of ``sizes`` into ``k`` groups of near-equal total (largest first)."""
    groups: list[list[int]] = [[] for _ in range(k)]
    load = [0] * k
    for i in sorted(range(len(sizes)), key=lambda i: -sizes[i]):
        g = load.index(min(load))
        groups[g].append(i)
        load[g] += sizes[i]
    return [g for g in groups if g]


class TiledSimulator(_RunSetup):
    """Runs one trajectory on a :class:`TiledTwin` (see the module docstring); the same
    parameters and result as :class:`rfp_twin.twin.sim.simulator.Simulator`, plus
    ``threads`` (default: the CPUs this process may use). The callback is called as
    ``callback(t, None, None)`` (there is no single model to hand over)."""

    def __init__(self, twin: TiledTwin, trajectory: Trajectory, faults=(), settings=None,
                 threads: int | None = None) -> None:
        self._setup(twin, trajectory, faults, settings)
        self.tiles = [_TileState(t) for t in twin.tiles]
        self.dt = float(self.tiles[0].model.opt.timestep)
        self.n_steps = step_count(self.settings, trajectory, self.dt)
        self.sim_s = self.n_steps * self.dt
        cpus = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
        self.threads = max(1, min(int(threads or cpus or 1), len(self.tiles)))
        self._groups = _balanced_groups([t.tile.robots.size for t in self.tiles], self.threads)

    def reset(self) -> tuple[np.ndarray, np.ndarray]:
        """Every robot at its commanded start, at rest: returns the whole-array (q, v)
        (2n,) rad, rad/s."""
        start = self.commands.commanded(np.zeros(1))[0]
        for ts in self.tiles:
            ts.tile.twin.set_angles(ts.data, start[ts.tile.robots], hold=True)
            ts.data.time = 0.0
        q = np.radians(start).ravel()
        return q, np.zeros_like(q)

    def run(self, callback=None, record: bool = True) -> SimReport:
        """Simulate; returns the report (with the sampled record if ``record``)."""
        n = self.twin.n_robots
        s = self.settings
        q, v = self.reset()
        q_next, v_next = q.copy(), v.copy()
        rec_every = max(1, int(round(s.record_dt_s / self.dt))) if s.record_dt_s > 0 else 0
        chunk = max(1, min(int(round(s.chunk_s / self.dt)), CHUNK_VALUES // (2 * n)))
        rec_t, rec_q, rec_ref = [], [], []
        tracking = TrackingError(n)
        tiles, groups = self.tiles, self._groups
        pool = ThreadPoolExecutor(self.threads) if self.threads > 1 else None
        wall0 = time.perf_counter()
        try:
            with collect_mujoco_warnings() as messages:
                for k, c, nominal in self._steps(chunk):
                    t_now = k * self.dt
                    angles = np.degrees(q).reshape(n, 2)
                    tracking.add(angles, nominal)
                    if rec_every and k % rec_every == 0:
                        rec_t.append(t_now)
                        rec_q.append(angles.copy())
                        rec_ref.append(nominal.copy())
                        if callback is not None:
                            callback(float(t_now), None, None)

                    def run_group(g, q=q, v=v, c=c, qn=q_next, vn=v_next, t=t_now):
                        for i in g:
                            tiles[i].step(q, v, c, qn, vn, t)

                    if pool is None:
                        run_group(groups[0])
                    else:
                        list(pool.map(run_group, groups))
                    q, q_next = q_next, q
                    v, v_next = v_next, v
        finally:
            if pool is not None:
                pool.shutdown()
        wall = time.perf_counter() - wall0
        return self._report(np.degrees(q).reshape(n, 2), self.n_steps * self.dt, wall, tracking,
                            (rec_t, rec_q, rec_ref) if record else None,
                            _merged_log([t.contacts.log() for t in tiles]), _summed_warnings(tiles),
                            messages)


def _merged_log(logs: list[ContactLog]) -> ContactLog:
    """One log of every tile's rows, in time order (stable: tile order within a step)."""
    logs = [lg for lg in logs if len(lg)]
    if not logs:
        return ContactLog.empty()
    cat = ContactLog(*(np.concatenate([getattr(lg, f) for lg in logs]) for f in
                       ("time_s", "robot_a", "robot_b", "fiducial", "depth_mm", "pos_mm")))
    order = np.argsort(cat.time_s, kind="stable")
    return ContactLog(cat.time_s[order], cat.robot_a[order], cat.robot_b[order],
                      cat.fiducial[order], cat.depth_mm[order], cat.pos_mm[order])


def _summed_warnings(tiles: list[_TileState]) -> dict[str, int]:
    """MuJoCo warning counts summed over the tiles."""

    out: dict[str, int] = {}
    for ts in tiles:
        for k, c in mujoco_warnings(ts.data).items():
            out[k] = out.get(k, 0) + c
    return out
