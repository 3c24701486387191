"""The driver: step a MuJoCo grid model along a Trajectory and report what happened.

Every physics step the :class:`~rfp_twin.twin.sim.control.Commands` give the servo targets, the
:class:`~rfp_twin.twin.sim.control.TrackingError` accounts the true angles against the nominal
trajectory, the :class:`~rfp_twin.twin.sim.contacts.ContactRecorder` keeps the contacts, and every
``record_dt_s`` the angles are sampled (and a callback runs). The result is a
:class:`~rfp_twin.twin.sim.report.SimReport`.

Units: angles in degrees, times in seconds (simulated, except wall times), lengths in mm.
Robots in layout order (n robots).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Callable

import mujoco
import numpy as np

from rfp_twin.models.errors import TrajectoryError
from rfp_twin.models.mjcf import TwinModel, collect_mujoco_warnings
from rfp_twin.models.mjcf.tiled_twin import TiledTwin
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.twin.sim.contacts import ContactRecorder
from rfp_twin.twin.sim.control import Commands, TrackingError, fiber_error_mm
from rfp_twin.twin.sim.report import SimRecord, SimReport

#: ``callback(t, model, data)``, t in simulated seconds.
Callback = Callable[[float, mujoco.MjModel, mujoco.MjData], None]


@dataclass(frozen=True)
class SimSettings:
    """How to run a simulation.

    settle_s : time simulated after the trajectory's end, s.
    duration_s : total simulated time (default trajectory duration + settle_s), s.
    record_dt_s : interval of the recorded angles / reference (and of the callback), s.
    chunk_s : commands are computed this many seconds at a time (memory bound), s.
    reached_tol_deg : a robot whose final |error| on both axes is below this "reached", deg.
    feedforward : add the velocity feed-forward to the servo target.
    """

    settle_s: float = 0.5
    duration_s: float | None = None
    record_dt_s: float = 0.02
    chunk_s: float = 1.0
    reached_tol_deg: float = 0.05
    feedforward: bool = True

    def __post_init__(self) -> None:
        for name in ("settle_s", "record_dt_s", "chunk_s", "reached_tol_deg"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise TrajectoryError(f"field '{name}' = {v!r}; allowed: a finite number >= 0")
        if self.duration_s is not None and not (math.isfinite(self.duration_s) and self.duration_s > 0):
            raise TrajectoryError(f"field 'duration_s' = {self.duration_s!r}; allowed: > 0 s")


def step_count(settings: SimSettings, trajectory: Trajectory, dt: float) -> int:
    """Physics steps of ``dt`` s a run takes: ``settings.duration_s``, else the trajectory's
    duration plus ``settings.settle_s``, rounded up (at least one)."""
    sim_s = settings.duration_s if settings.duration_s is not None \
        else trajectory.duration + settings.settle_s
    return max(1, int(math.ceil(sim_s / dt - 1e-9)))


def mujoco_warnings(d: mujoco.MjData) -> dict[str, int]:
    """MuJoCo warnings raised so far: name -> count (empty when none)."""
    out = {}
    for w in range(int(mujoco.mjtWarning.mjNWARNING)):
        count = int(d.warning[w].number)
        if count:
            out[mujoco.mjtWarning(w).name] = count
    return out


def _as_slice(ids: np.ndarray):
    """A slice when ids are consecutive (faster indexing), else the array."""
    if ids.size and np.all(np.diff(ids) == 1):
        return slice(int(ids[0]), int(ids[-1]) + 1)
    return ids


class RunSamples:
    """The per-step bookkeeping both simulators share: the tracking error of every step
    and, every ``record_dt_s``, the true and nominal angles (n, 2) deg and the callback."""

    def __init__(self, n: int, settings: SimSettings, dt: float, callback) -> None:
        self.tracking = TrackingError(n)
        self.every = max(1, int(round(settings.record_dt_s / dt))) if settings.record_dt_s > 0 \
            else 0
        self.times: list = []
        self.angles: list = []
        self.nominal: list = []
        self.callback = callback

    def add(self, k: int, t: float, angles: np.ndarray, nominal: np.ndarray, *where) -> None:
        """Step k at time t s: the true ``angles`` and the ``nominal`` ones (n, 2) deg;
        ``where`` follows ``t`` in the callback ((model, data), or (None, None) for tiles)."""
        self.tracking.add(angles, nominal)
        if self.every and k % self.every == 0:
            self.times.append(t)
            self.angles.append(angles.copy())
            self.nominal.append(nominal.copy())
            if self.callback is not None:
                self.callback(float(t), *where)


class RunSetup:
    """What both simulators (one model, tiles) set up the same way: the inputs and the
    :class:`Commands` of the run."""

    def _setup(self, twin, trajectory: Trajectory, faults, settings: SimSettings | None) -> None:
        self.twin = twin
        self.trajectory = trajectory
        self.settings = settings or SimSettings()
        self.faults = list(faults)
        self.commands = Commands(twin, trajectory, self.faults, self.settings.feedforward)

    def _report(self, q_end: np.ndarray, t_end: float, wall: float, samples: RunSamples,
                record: bool, contacts, warnings: dict, messages) -> SimReport:
        """The :class:`SimReport` of a finished run: final angles ``q_end`` (n, 2) deg at
        ``t_end`` s against the nominal end, the stepping loop's ``wall`` s, the tracking
        error and the sampled angles (kept if ``record``), the :class:`ContactLog`, MuJoCo's
        warning counts and messages."""
        ref_end = self.nominal(np.array([t_end]))[0]
        final = q_end - ref_end
        tracking = samples.tracking
        record_obj = None
        if record and samples.times:
            angles = np.array(samples.angles)
            record_obj = SimRecord(np.array(samples.times), angles,
                                   angles + self.commands.effects.offset[None],
                                   np.array(samples.nominal))
        return SimReport(
            robot_ids=np.asarray(self.twin.layout.robot_ids, dtype=np.int64).copy(),
            sim_s=float(t_end), trajectory_s=self.trajectory.duration, timestep_s=self.dt,
            n_steps=self.n_steps, wall_s=wall, max_error_deg=tracking.max_deg,
            rms_error_deg=tracking.rms_deg(self.n_steps), final_error_deg=final,
            final_fiber_error_mm=fiber_error_mm(self.twin, q_end, ref_end),
            reached=np.all(np.abs(final) <= self.settings.reached_tol_deg, axis=1),
            contacts=contacts, faults=[f.describe() for f in self.faults], warnings=warnings,
            warning_messages=list(messages), record=record_obj)

    def nominal(self, times: np.ndarray) -> np.ndarray:
        """(len(times), n, 2) nominal angles (the trajectory; fold for others), deg."""
        return self.commands.nominal(times)

    def _steps(self, chunk: int):
        """Yield ``(k, servo targets (2n,) rad, nominal angles (n, 2) deg)`` for every
        physics step k of the run; the commands are computed ``chunk`` steps at a time."""
        step = 0
        while step < self.n_steps:
            k1 = min(self.n_steps, step + chunk)
            t_grid = np.arange(step, k1 + 2) * self.dt
            ctrl = self.commands.servo_targets(t_grid, self.dt)
            nominal = self.commands.nominal(t_grid[:-2])
            for j in range(k1 - step):
                yield step + j, ctrl[j], nominal[j]
            step = k1


class Simulator(RunSetup):
    """Runs one trajectory on a :class:`rfp_twin.models.mjcf.TwinModel`.

    Parameters
    ----------
    twin : TwinModel
    trajectory : Trajectory; its robot ids must be robots of the twin's layout. Robots of
        the layout that it does not mention hold the spec's fold configuration.
    faults : iterable of Stuck / Slow / EncoderOffset
    settings : SimSettings

    ``data`` is the live MjData (for renderers); :meth:`run` steps to the end and
    returns a :class:`SimReport`, calling ``callback(t, model, data)`` every
    ``record_dt_s`` (at t = 0 too).
    """

    def __init__(self, twin: TwinModel, trajectory: Trajectory, faults=(),
                 settings: SimSettings | None = None) -> None:
        self._setup(twin, trajectory, faults, settings)
        m = twin.model
        self.data = mujoco.MjData(m)
        self.dt = float(m.opt.timestep)
        self.n_steps = step_count(self.settings, trajectory, self.dt)
        self.sim_s = self.n_steps * self.dt
        idx = twin.index
        self._act_flat = _as_slice(idx.actuator.ravel())
        self._qpos_flat = _as_slice(idx.qpos_adr.ravel())

    def commanded(self, times: np.ndarray) -> np.ndarray:
        """(len(times), n, 2) angles the servos are asked to reach (faults applied), deg:
        true-angle targets, i.e. already corrected for encoder offsets."""
        return self.commands.commanded(times)

    def reset(self) -> None:
        """Put every robot at its commanded start, at rest."""
        start = self.commanded(np.zeros(1))[0]
        self.twin.set_angles(self.data, start, hold=True)
        self.data.time = 0.0

    def run(self, callback: Callback | None = None, record: bool = True) -> SimReport:
        """Simulate; returns the report (with the sampled record if ``record``)."""
        m, d, twin = self.twin.model, self.data, self.twin
        n = twin.n_robots
        self.reset()
        chunk = max(1, int(round(self.settings.chunk_s / self.dt)))
        samples = RunSamples(n, self.settings, self.dt, callback)
        contacts = ContactRecorder(twin.index)
        act, qadr = self._act_flat, self._qpos_flat
        wall0 = time.perf_counter()
        with collect_mujoco_warnings() as messages:
            for k, ctrl, nominal in self._steps(chunk):
                samples.add(k, d.time, np.degrees(d.qpos[qadr]).reshape(n, 2), nominal, m, d)
                d.ctrl[act] = ctrl
                t_now = d.time
                mujoco.mj_step(m, d)
                if d.ncon:  # contacts of the state at t_now
                    contacts.add(d, t_now)
        wall = time.perf_counter() - wall0
        return self._report(twin.angles(d), float(d.time), wall, samples, record,
                            contacts.log(), mujoco_warnings(d), messages)


def simulate(twin: TwinModel, trajectory: Trajectory, faults=(), settings: SimSettings | None = None,
             callback: Callback | None = None, record: bool = True) -> SimReport:
    """Simulate ``trajectory`` on ``twin`` (see :class:`Simulator`); a tiled twin
    (:class:`rfp_twin.models.mjcf.tiled_twin.TiledTwin`) runs in its tiles
    (:class:`rfp_twin.twin.sim.tiled.TiledSimulator`, callback ``(t, None, None)``)."""
    if isinstance(twin, TiledTwin):
        from rfp_twin.twin.sim.tiled import TiledSimulator

        return TiledSimulator(twin, trajectory, faults, settings).run(callback, record)
    return Simulator(twin, trajectory, faults, settings).run(callback, record)
