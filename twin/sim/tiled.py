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

**Blocks.** Without contacts the robots do not act on each other: a halo robot, driven by
its servo targets, moves in its tile exactly as its owner moves it. So the tiles first
step :data:`BLOCK_STEPS` steps each without exchanging anything (a tile's data stays in
the core's cache for the whole block: a tile step costs ~0.45 ms instead of ~0.7-0.9 ms
when every step visits all tiles, 12,852 robots in 26 square tiles; and one thread-pool
call a block instead of a step), and the halos are set from their owners at the block's
end. If any tile meets a contact during the block, every tile
goes back to the block's start (``mj_getState`` / ``mj_setState``, warning counts
included) and the block is stepped again in lock step with the exchange above; lock step
then goes on for :data:`LOCKSTEP_AFTER_CONTACT` steps before the next block is tried. A
run with contacts is thus stepped exactly as without blocks, and one without contacts
gives every owned robot the same motion.

The report is the same :class:`rfp_twin.twin.sim.report.SimReport` as for one model.
Units: angles in degrees, times in seconds, lengths in mm; n robots in layout order.
"""
from __future__ import annotations

import time
from concurrent.futures import ThreadPoolExecutor

import mujoco
import numpy as np

from rfp_twin.models.mjcf import collect_mujoco_warnings
from rfp_twin.models.mjcf.tiled_twin import Tile, TiledTwin
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.twin.cores import usable_cores
from rfp_twin.twin.sim.contacts import ContactLog, ContactRecorder
from rfp_twin.twin.sim.report import SimReport
from rfp_twin.twin.sim.simulator import RunSamples, RunSetup, mujoco_warnings, step_count

#: Largest number of values in one chunk of servo targets or nominal angles (steps x 2n):
#: a chunk of ``chunk_s`` is shortened on large arrays so that its arrays stay ~64 MB.
CHUNK_VALUES = 8_000_000
#: Steps each tile takes alone before the halos are synchronised (no contact: see the
#: module docstring). A tile stepped many times in a row keeps its data in the core's
#: cache: on raft:204 a tile step costs 0.44 ms in blocks of 16 against 0.87 ms one step
#: at a time (benchmarks/HISTORY.md, "Code comments": twin/sim/tiled.py).
BLOCK_STEPS = 16
#: Steps run in lock step after a block met a contact, before blocks are tried again.
LOCKSTEP_AFTER_CONTACT = 64
_STATE = mujoco.mjtState.mjSTATE_INTEGRATION


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

    def save(self) -> tuple[np.ndarray, list[int]]:
        """The integration state and the warning counts (to go back to them)."""
        m, d = self.model, self.data
        state = np.empty(mujoco.mj_stateSize(m, _STATE))
        mujoco.mj_getState(m, d, state, _STATE)
        return state, [int(w.number) for w in d.warning]

    def restore(self, saved: tuple[np.ndarray, list[int]]) -> None:
        state, counts = saved
        mujoco.mj_setState(self.model, self.data, state, _STATE)
        for w, c in zip(self.data.warning, counts):
            w.number = c

    def block(self, ctrl: np.ndarray, q_out: np.ndarray, v_out: np.ndarray,
              stop: list[bool]) -> None:
        """Step ``len(ctrl)`` steps alone (servo targets ctrl (B, 2n) rad), writing the owned
        robots' state after step j into q_out[j], v_out[j] (B, 2n); on a contact set
        ``stop[0]`` and return (the block is then redone in lock step)."""
        m, d = self.model, self.data
        qpos, qvel, c_in = self._qpos, self._qvel, self._ctrl
        for j in range(ctrl.shape[0]):
            if stop[0]:
                return
            c_in[self.act] = ctrl[j, self.act_g]
            mujoco.mj_step(m, d)
            if d.ncon:
                stop[0] = True
                return
            q_out[j, self.own_g] = qpos[self.own_q]
            v_out[j, self.own_g] = qvel[self.own_v]

    def set_halo(self, q: np.ndarray, v: np.ndarray) -> None:
        """Halo robots to the whole-array state (q, v) (2n,) rad, rad/s."""
        self._qpos[self.halo_q] = q[self.halo_g]
        self._qvel[self.halo_v] = v[self.halo_g]


def _balanced_groups(sizes: list[int], k: int) -> list[list[int]]:
    """Split items of ``sizes`` into ``k`` groups of near-equal total (largest first)."""
    groups: list[list[int]] = [[] for _ in range(k)]
    load = [0] * k
    for i in sorted(range(len(sizes)), key=lambda i: -sizes[i]):
        g = load.index(min(load))
        groups[g].append(i)
        load[g] += sizes[i]
    return [g for g in groups if g]


class TiledSimulator(RunSetup):
    """Runs one trajectory on a :class:`TiledTwin` (see the module docstring); the same
    parameters and result as :class:`rfp_twin.twin.sim.simulator.Simulator`, plus
    ``threads`` (default: the CPUs this process may use). The callback is called as
    ``callback(t, None, None)`` (there is no single model to hand over)."""

    def __init__(self, twin: TiledTwin, trajectory: Trajectory, faults=(), settings=None,
                 threads: int | None = None, block_steps: int = BLOCK_STEPS) -> None:
        self._setup(twin, trajectory, faults, settings)
        self.tiles = [_TileState(t) for t in twin.tiles]
        self.dt = float(self.tiles[0].model.opt.timestep)
        self.n_steps = step_count(self.settings, trajectory, self.dt)
        self.sim_s = self.n_steps * self.dt
        self.threads = max(1, min(int(threads or usable_cores()), len(self.tiles)))
        self._groups = _balanced_groups([t.tile.robots.size for t in self.tiles], self.threads)
        self.block_steps = max(1, int(block_steps))
        self.blocks = 0             # blocks the tiles stepped alone
        self.rollbacks = 0          # blocks that met a contact and were redone in lock step

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
        q, v = self.reset()
        q_next, v_next = np.empty_like(q), np.empty_like(v)     # lock step: swapped each step
        chunk = max(1, min(int(round(self.settings.chunk_s / self.dt)), CHUNK_VALUES // (2 * n)))
        samples = RunSamples(n, self.settings, self.dt, callback)
        B = self.block_steps
        q_blk, v_blk = np.empty((B, 2 * n)), np.empty((B, 2 * n))
        pool = ThreadPoolExecutor(self.threads) if self.threads > 1 else None
        lockstep_until = 0
        self.blocks = self.rollbacks = 0

        def account(k, q_k, nominal):
            """Bookkeeping of the state q_k (2n,) rad at the start of step k."""
            samples.add(k, k * self.dt, np.degrees(q_k).reshape(n, 2), nominal, None, None)

        wall0 = time.perf_counter()
        try:
            with collect_mujoco_warnings() as messages:
                for steps in _batched(self._steps(chunk), B):
                    k0 = steps[0][0]
                    if B > 1 and len(steps) == B and k0 >= lockstep_until:
                        done = self._block(steps, q, v, q_blk, v_blk, pool)
                        if done:
                            self.blocks += 1
                            for j, (k, _, nominal) in enumerate(steps):
                                account(k, q if j == 0 else q_blk[j - 1], nominal)
                            np.copyto(q, q_blk[-1])
                            np.copyto(v, v_blk[-1])
                            continue
                        self.rollbacks += 1
                        lockstep_until = k0 + LOCKSTEP_AFTER_CONTACT
                    for k, c, nominal in steps:
                        account(k, q, nominal)
                        self._lockstep(q, v, c, k * self.dt, pool, q_next, v_next)
                        q, q_next = q_next, q
                        v, v_next = v_next, v
        finally:
            if pool is not None:
                pool.shutdown()
        wall = time.perf_counter() - wall0
        return self._report(np.degrees(q).reshape(n, 2), self.n_steps * self.dt, wall, samples,
                            record, _merged_log([t.contacts.log() for t in self.tiles]),
                            _summed_warnings(self.tiles), messages)

    def _map(self, pool, fn) -> None:
        """``fn(group)`` for every group of tiles (on the pool's threads)."""
        if pool is None:
            fn(self._groups[0])
        else:
            list(pool.map(fn, self._groups))

    def _lockstep(self, q, v, c, t_now, pool, q_next, v_next) -> None:
        """One step of every tile with the halo exchange from the whole-array (q, v): the
        next state into (q_next, v_next) (every robot is owned by one tile)."""
        tiles = self.tiles

        def run_group(g):
            for i in g:
                tiles[i].step(q, v, c, q_next, v_next, t_now)

        self._map(pool, run_group)

    def _block(self, steps, q, v, q_blk, v_blk, pool) -> bool:
        """The steps of one block, every tile alone (see the module docstring): True with
        the states after each step in (q_blk, v_blk); False after a contact, with every
        tile back at the block's start."""
        tiles = self.tiles
        ctrl = np.stack([c for _, c, _ in steps])
        saved = [ts.save() for ts in tiles]
        stop = [False]

        def run_group(g):
            for i in g:
                tiles[i].block(ctrl, q_blk, v_blk, stop)

        self._map(pool, run_group)
        if stop[0]:
            for ts, sv in zip(tiles, saved):
                ts.restore(sv)
            return False
        for ts in tiles:
            ts.set_halo(q_blk[-1], v_blk[-1])
        return True


def _batched(items, size: int):
    """Lists of up to ``size`` consecutive items of an iterable."""
    batch = []
    for it in items:
        batch.append(it)
        if len(batch) == size:
            yield batch
            batch = []
    if batch:
        yield batch


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
