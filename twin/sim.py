"""The physics twin: drive a MuJoCo grid model along a Trajectory and report what happened.

Each robot's two position servos (:mod:`models.mjcf`) follow the trajectory: every
physics step the actuator target is the commanded angle plus a velocity feed-forward
``(kv / kp) * d(angle)/dt``, so the servo tracks ramps without the steady lag of a pure
PD loop. The simulator records, per robot, the joint angles and the tracking error
(true angle minus the nominal trajectory), and every contact between two robots (and
between a robot and a fiducial): time, ids, penetration depth.

Faults change what one robot is commanded or measures:

* :class:`Stuck` — from ``time_s`` the robot's motors hold where they were commanded
  to be at that time: its tracking error grows as the trajectory moves on.
* :class:`Slow` — the robot runs its trajectory ``factor`` times slower (time warp
  ``t / factor``): it lags, and the lag grows with time.
* :class:`EncoderOffset` — the encoder reads ``true + offset``; the servo drives the
  reading onto the trajectory, so the true angle is off by ``-offset`` all the time.

All public numbers: mm, degrees, seconds.
"""
from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Union

import mujoco
import numpy as np

from models.errors import TrajectoryError, UnknownRobotError
from models.kinematics import forward
from models.mjcf import TwinModel, collect_mujoco_warnings
from models.files import atomic_write_text
from models.trajectory import Trajectory


# -- faults ---------------------------------------------------------------------------
@dataclass(frozen=True)
class Stuck:
    """Robot ``robot_id`` stops at ``time_s`` and holds that position."""

    robot_id: int
    time_s: float

    def describe(self) -> str:
        return f"robot {self.robot_id} stuck from t = {self.time_s:g} s"


@dataclass(frozen=True)
class Slow:
    """Robot ``robot_id`` runs its trajectory ``factor`` (> 0) times slower."""

    robot_id: int
    factor: float

    def describe(self) -> str:
        return f"robot {self.robot_id} slow by a factor {self.factor:g}"


@dataclass(frozen=True)
class EncoderOffset:
    """Robot ``robot_id``'s encoders read ``true + offset`` (deg) on each axis."""

    robot_id: int
    alpha_deg: float = 0.0
    beta_deg: float = 0.0

    def describe(self) -> str:
        return (f"robot {self.robot_id} encoder offset ({self.alpha_deg:g}, "
                f"{self.beta_deg:g}) deg")


Fault = Union[Stuck, Slow, EncoderOffset]


# -- settings and report -------------------------------------------------------------
@dataclass(frozen=True)
class SimSettings:
    """How to run a simulation.

    settle_s : time simulated after the trajectory's end, s.
    duration_s : total simulated time (default trajectory duration + settle_s).
    record_dt_s : interval of the recorded angles / reference (and of the callback), s.
    chunk_s : commands are computed this many seconds at a time (memory bound).
    reached_tol_deg : a robot whose final |error| on both axes is below this "reached".
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


@dataclass
class ContactLog:
    """Contacts seen at physics steps (one row per contact point per step).

    time_s (k,), robot_a (k,) int64 robot ids, robot_b (k,) int64 robot ids or -1 for a
    fiducial, fiducial (k,) int64 fiducial ids or -1, depth_mm (k,) penetration, pos_mm
    (k, 3) world contact point.
    """

    time_s: np.ndarray
    robot_a: np.ndarray
    robot_b: np.ndarray
    fiducial: np.ndarray
    depth_mm: np.ndarray
    pos_mm: np.ndarray

    @classmethod
    def empty(cls) -> ContactLog:
        z = np.empty(0, dtype=np.int64)
        return cls(np.empty(0), z, z.copy(), z.copy(), np.empty(0), np.empty((0, 3)))

    def __len__(self) -> int:
        return int(self.time_s.size)

    @property
    def robot_robot(self) -> np.ndarray:
        """(k,) bool: rows between two robots."""
        return self.robot_b >= 0

    def pairs(self) -> list[dict]:
        """One summary per touching pair: robots (or robot + fiducial), first and last
        time, largest depth, number of contact rows."""
        out = []
        if len(self) == 0:
            return out
        key = np.column_stack([self.robot_a, self.robot_b, self.fiducial])
        uniq, inv = np.unique(key, axis=0, return_inverse=True)
        inv = inv.ravel()
        for k, (a, b, f) in enumerate(uniq):
            rows = inv == k
            item = {"robot_a": int(a), "first_s": float(self.time_s[rows].min()),
                    "last_s": float(self.time_s[rows].max()),
                    "max_depth_mm": float(self.depth_mm[rows].max()), "rows": int(rows.sum())}
            if b >= 0:
                item["robot_b"] = int(b)
            else:
                item["fiducial"] = int(f)
            out.append(item)
        return out


@dataclass
class SimRecord:
    """Sampled history: times (k,) s; angles (k, n, 2) true joint angles, deg;
    measured (k, n, 2) encoder readings, deg; reference (k, n, 2) nominal trajectory, deg."""

    times: np.ndarray
    angles: np.ndarray
    measured: np.ndarray
    reference: np.ndarray


@dataclass
class SimReport:
    """What happened in one simulation.

    Attributes
    ----------
    robot_ids : (n,) int64, layout robot order
    sim_s, trajectory_s : simulated time and trajectory duration, s
    timestep_s : physics step; n_steps : steps taken
    wall_s : wall time of the stepping loop; realtime_factor : sim_s / wall_s
    max_error_deg, rms_error_deg, final_error_deg : (n, 2) tracking error (true angle -
        nominal trajectory) per robot and axis; max and final are signed-at-max |.|
    final_fiber_error_mm : (n,) distance of the fiber from its nominal end position
    reached : (n,) bool, final |error| <= reached_tol_deg on both axes
    contacts : ContactLog (robot-robot and robot-fiducial)
    faults : list of fault descriptions
    warnings : dict MuJoCo warning name -> count (empty when none)
    warning_messages : MuJoCo's warning texts raised during the run
    record : SimRecord or None
    """

    robot_ids: np.ndarray
    sim_s: float
    trajectory_s: float
    timestep_s: float
    n_steps: int
    wall_s: float
    max_error_deg: np.ndarray
    rms_error_deg: np.ndarray
    final_error_deg: np.ndarray
    final_fiber_error_mm: np.ndarray
    reached: np.ndarray
    contacts: ContactLog
    faults: list[str] = field(default_factory=list)
    warnings: dict[str, int] = field(default_factory=dict)
    warning_messages: list[str] = field(default_factory=list)
    record: SimRecord | None = None

    @property
    def realtime_factor(self) -> float:
        return self.sim_s / self.wall_s if self.wall_s > 0 else math.inf

    @property
    def robot_contacts(self) -> int:
        """Number of robot-robot contact rows."""
        return int(np.count_nonzero(self.contacts.robot_robot))

    @property
    def fiducial_contacts(self) -> int:
        return int(len(self.contacts) - self.robot_contacts)

    @property
    def collided(self) -> bool:
        return len(self.contacts) > 0

    @property
    def ok(self) -> bool:
        """No contact, no MuJoCo warning, every robot reached its end."""
        return (not self.collided and not self.warnings and not self.warning_messages
                and bool(np.all(self.reached)))

    def error_of(self, robot_id: int) -> dict:
        """Max / rms / final error (alpha, beta) deg of one robot."""
        k = np.flatnonzero(self.robot_ids == robot_id)
        if k.size == 0:
            raise UnknownRobotError(f"robot {robot_id} is not in this report; allowed: "
                                    f"{int(self.robot_ids.min())}..{int(self.robot_ids.max())}")
        k = int(k[0])
        return {"max": self.max_error_deg[k].tolist(), "rms": self.rms_error_deg[k].tolist(),
                "final": self.final_error_deg[k].tolist()}

    def to_dict(self) -> dict:
        """JSON-ready summary (per-robot errors, contact pairs; not the sampled record)."""
        worst = int(np.argmax(np.abs(self.max_error_deg).max(axis=1))) if self.robot_ids.size else 0
        return {
            "ok": self.ok, "robots": int(self.robot_ids.size), "sim_s": self.sim_s,
            "trajectory_s": self.trajectory_s, "timestep_s": self.timestep_s,
            "n_steps": self.n_steps, "wall_s": self.wall_s,
            "realtime_factor": self.realtime_factor,
            "robot_contact_rows": self.robot_contacts,
            "fiducial_contact_rows": self.fiducial_contacts,
            "contact_pairs": self.contacts.pairs(),
            "max_depth_mm": float(self.contacts.depth_mm.max()) if len(self.contacts) else 0.0,
            "not_reached": [int(r) for r in self.robot_ids[~self.reached]],
            "worst_robot": int(self.robot_ids[worst]) if self.robot_ids.size else None,
            "faults": list(self.faults), "warnings": dict(self.warnings),
            "warning_messages": list(self.warning_messages),
            "per_robot": {str(int(r)): {"max_error_deg": self.max_error_deg[k].tolist(),
                                        "rms_error_deg": self.rms_error_deg[k].tolist(),
                                        "final_error_deg": self.final_error_deg[k].tolist(),
                                        "final_fiber_error_mm": float(self.final_fiber_error_mm[k])}
                          for k, r in enumerate(self.robot_ids)},
        }

    def to_json(self, path: str | Path) -> None:
        """Write :meth:`to_dict` atomically (temp file + rename)."""
        atomic_write_text(path, json.dumps(self.to_dict(), indent=1))

    def table(self):
        """A rich Table for the terminal."""
        from rich.table import Table

        d = self.to_dict()
        t = Table(title="simulation", show_header=False)
        t.add_column("what")
        t.add_column("value")
        t.add_row("robots", str(d["robots"]))
        t.add_row("simulated / wall", f"{self.sim_s:.2f} s / {self.wall_s:.2f} s "
                                      f"({self.realtime_factor:.1f}x real time)")
        t.add_row("steps", f"{self.n_steps} x {self.timestep_s * 1e3:g} ms")
        pairs = [p for p in d["contact_pairs"] if "robot_b" in p]
        t.add_row("robot-robot contacts", f"{len(pairs)} pairs, max depth {d['max_depth_mm']:.3f} mm"
                  if pairs else "none")
        fpairs = [p for p in d["contact_pairs"] if "fiducial" in p]
        t.add_row("robot-fiducial contacts", f"{len(fpairs)} pairs" if fpairs else "none")
        err = np.abs(self.max_error_deg).max() if self.robot_ids.size else 0.0
        t.add_row("max tracking error", f"{err:.3f} deg (robot {d['worst_robot']})")
        t.add_row("not reached", ", ".join(map(str, d["not_reached"][:20])) or "none")
        t.add_row("faults", "; ".join(self.faults) or "none")
        t.add_row("MuJoCo warnings", ", ".join(f"{k} x{v}" for k, v in self.warnings.items()) or "none")
        return t


# -- the simulator -------------------------------------------------------------------
Callback = Callable[[float, mujoco.MjModel, mujoco.MjData], None]


class Simulator:
    """Runs one trajectory on a :class:`models.mjcf.TwinModel`.

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
        self.twin = twin
        self.trajectory = trajectory
        self.settings = settings or SimSettings()
        self.faults = list(faults)
        lay = twin.layout
        n = twin.n_robots
        # trajectory robot -> layout robot index
        self._traj_index = lay.robot_indices(trajectory.robot_ids) if trajectory.n_robots else \
            np.empty(0, dtype=np.int64)
        if len(set(self._traj_index.tolist())) != self._traj_index.size:
            raise TrajectoryError("trajectory lists a robot twice; allowed: unique robot ids")
        self._warp_scale = np.ones(n)
        self._stuck_at = np.full(n, np.inf)
        self._offset = np.zeros((n, 2))
        for f in self.faults:
            k = lay.robot_index(int(f.robot_id))
            if isinstance(f, Stuck):
                if not (math.isfinite(f.time_s) and f.time_s >= 0):
                    raise TrajectoryError(f"robot {f.robot_id}: field 'time_s' = {f.time_s!r}; "
                                          "allowed: >= 0 s")
                self._stuck_at[k] = min(self._stuck_at[k], f.time_s)
            elif isinstance(f, Slow):
                if not (math.isfinite(f.factor) and f.factor > 0):
                    raise TrajectoryError(f"robot {f.robot_id}: field 'factor' = {f.factor!r}; "
                                          "allowed: > 0 (2 = half speed)")
                self._warp_scale[k] /= f.factor
            elif isinstance(f, EncoderOffset):
                self._offset[k] += (f.alpha_deg, f.beta_deg)
            else:
                raise TrajectoryError(f"unknown fault {f!r}; allowed: Stuck, Slow, EncoderOffset")
        m = twin.model
        act = twin.index.actuator
        kp = m.actuator_gainprm[act, 0]
        kv = -m.actuator_biasprm[act, 2]
        self._ff = np.where(kp > 0, kv / np.where(kp > 0, kp, 1.0), 0.0) if self.settings.feedforward \
            else np.zeros_like(kp)
        self._fold = np.asarray(twin.spec.fold_deg, float)
        self.data = mujoco.MjData(m)
        self.dt = float(m.opt.timestep)
        sim_s = self.settings.duration_s if self.settings.duration_s is not None \
            else trajectory.duration + self.settings.settle_s
        self.n_steps = max(1, int(math.ceil(sim_s / self.dt - 1e-9)))
        self.sim_s = self.n_steps * self.dt
        idx = twin.index
        self._act_flat = _as_slice(idx.actuator.ravel())
        self._qpos_flat = _as_slice(idx.qpos_adr.ravel())

    # -- references --------------------------------------------------------------
    def nominal(self, times: np.ndarray) -> np.ndarray:
        """(len(times), n, 2) nominal angles (the trajectory; fold for others), deg."""
        return self._sample(np.asarray(times, float), warped=False)

    def commanded(self, times: np.ndarray) -> np.ndarray:
        """(len(times), n, 2) angles the servos are asked to reach (faults applied), deg:
        true-angle targets, i.e. already corrected for encoder offsets."""
        return self._sample(np.asarray(times, float), warped=True) - self._offset[None]

    def _sample(self, times: np.ndarray, warped: bool) -> np.ndarray:
        n = self.twin.n_robots
        out = np.empty((times.size, n, 2))
        out[:] = self._fold
        traj = self.trajectory
        for j, k in enumerate(self._traj_index):
            tau = times
            if warped:
                tau = np.minimum(times, self._stuck_at[k]) * self._warp_scale[k]
            for ax in range(2):
                out[:, k, ax] = np.interp(tau, traj.times[ax][j], traj.angles[ax][j])
        return out

    # -- running -------------------------------------------------------------------
    def reset(self) -> None:
        """Put every robot at its commanded start, at rest."""
        start = self.commanded(np.zeros(1))[0]
        self.twin.set_angles(self.data, start, hold=True)
        self.data.time = 0.0

    def run(self, callback: Callback | None = None, record: bool = True) -> SimReport:
        """Simulate; returns the report (with the sampled record if ``record``)."""
        m, d, twin = self.twin.model, self.data, self.twin
        idx = twin.index
        n = twin.n_robots
        s = self.settings
        self.reset()
        rec_every = max(1, int(round(s.record_dt_s / self.dt))) if s.record_dt_s > 0 else 0
        chunk = max(1, int(round(s.chunk_s / self.dt)))
        rec_t, rec_q, rec_ref, contacts = [], [], [], []
        max_err = np.zeros((n, 2))
        sum_sq = np.zeros((n, 2))
        err = np.zeros((n, 2))
        geom_robot, geom_fid = idx.geom_robot, idx.geom_fiducial
        robot_ids, fid_ids = idx.robot_ids, idx.fiducial_ids
        ff = self._ff.ravel()
        act, qadr = self._act_flat, self._qpos_flat
        wall0 = time.perf_counter()
        with collect_mujoco_warnings() as messages:
            step = 0
            while step < self.n_steps:
                k1 = min(self.n_steps, step + chunk)
                t_grid = np.arange(step, k1 + 2) * self.dt
                cmd = np.radians(self.commanded(t_grid)).reshape(t_grid.size, -1)
                # target for step k: where to be at t_(k+1), plus velocity feed-forward
                ctrl = cmd[1:-1] + ff * (cmd[2:] - cmd[1:-1]) / self.dt
                nominal = self.nominal(t_grid[:-2])
                for j in range(k1 - step):
                    q = np.degrees(d.qpos[qadr]).reshape(n, 2)
                    np.subtract(q, nominal[j], out=err)
                    big = np.abs(err) > np.abs(max_err)
                    max_err[big] = err[big]
                    sum_sq += err * err
                    if rec_every and (step + j) % rec_every == 0:
                        rec_t.append(d.time)
                        rec_q.append(q.copy())
                        rec_ref.append(nominal[j].copy())
                        if callback is not None:
                            callback(float(d.time), m, d)
                    d.ctrl[act] = ctrl[j]
                    t_now = d.time
                    mujoco.mj_step(m, d)
                    if d.ncon:  # contacts of the state at t_now
                        contacts.append(_contacts(d, t_now, geom_robot, geom_fid, robot_ids, fid_ids))
                step = k1
        wall = time.perf_counter() - wall0
        # final state against the nominal end
        q_end = twin.angles(d)
        ref_end = self.nominal(np.array([d.time]))[0]
        final = q_end - ref_end
        spec = twin.spec
        base = np.ascontiguousarray(twin.layout.robot_xy, dtype=np.float64)
        f_true, _ = forward(base, np.ascontiguousarray(q_end), spec.alpha_length_mm, spec.beta_length_mm)
        f_ref, _ = forward(base, np.ascontiguousarray(ref_end), spec.alpha_length_mm, spec.beta_length_mm)
        record_obj = None
        if record and rec_t:
            angles = np.array(rec_q)
            record_obj = SimRecord(np.array(rec_t), angles, angles + self._offset[None],
                                   np.array(rec_ref))
        return SimReport(
            robot_ids=robot_ids.copy(), sim_s=float(d.time), trajectory_s=self.trajectory.duration,
            timestep_s=self.dt, n_steps=self.n_steps, wall_s=wall,
            max_error_deg=max_err, rms_error_deg=np.sqrt(sum_sq / self.n_steps),
            final_error_deg=final, final_fiber_error_mm=np.hypot(*(f_true - f_ref).T),
            reached=np.all(np.abs(final) <= s.reached_tol_deg, axis=1),
            contacts=_merge_contacts(contacts), faults=[f.describe() for f in self.faults],
            warnings=mujoco_warnings(d), warning_messages=list(messages), record=record_obj)


def _as_slice(ids: np.ndarray):
    """A slice when ids are consecutive (faster indexing), else the array."""
    if ids.size and np.all(np.diff(ids) == 1):
        return slice(int(ids[0]), int(ids[-1]) + 1)
    return ids


def _contacts(d: mujoco.MjData, t: float, geom_robot, geom_fid, robot_ids, fid_ids):
    """Robot-robot and robot-fiducial rows of the current contact list."""
    c = d.contact
    g = np.asarray(c.geom).reshape(-1, 2)
    ra, rb = geom_robot[g[:, 0]], geom_robot[g[:, 1]]
    fa, fb = geom_fid[g[:, 0]], geom_fid[g[:, 1]]
    rr = (ra >= 0) & (rb >= 0) & (ra != rb)
    rf = ((ra >= 0) & (fb >= 0)) | ((rb >= 0) & (fa >= 0))
    keep = rr | rf
    if not keep.any():
        return None
    robot = np.where(ra >= 0, ra, rb)[keep]
    other = np.where(rr, np.where(ra >= 0, rb, ra), -1)[keep]
    fid = np.where(rf, np.maximum(fa, fb), -1)[keep]
    a_id = robot_ids[robot]
    b_id = np.where(other >= 0, robot_ids[np.maximum(other, 0)], -1)
    lo = np.where(b_id >= 0, np.minimum(a_id, b_id), a_id)
    hi = np.where(b_id >= 0, np.maximum(a_id, b_id), -1)
    f_id = np.where(fid >= 0, fid_ids[np.maximum(fid, 0)] if fid_ids.size else -1, -1)
    depth = np.maximum(-np.asarray(c.dist)[keep], 0.0)
    return (np.full(lo.size, t), lo, hi, f_id, depth, np.asarray(c.pos).reshape(-1, 3)[keep])


def _merge_contacts(rows) -> ContactLog:
    rows = [r for r in rows if r is not None]
    if not rows:
        return ContactLog.empty()
    cols = list(zip(*rows))
    return ContactLog(np.concatenate(cols[0]), np.concatenate(cols[1]).astype(np.int64),
                      np.concatenate(cols[2]).astype(np.int64),
                      np.concatenate(cols[3]).astype(np.int64), np.concatenate(cols[4]),
                      np.vstack(cols[5]))


def mujoco_warnings(d: mujoco.MjData) -> dict[str, int]:
    """MuJoCo warnings raised so far: name -> count (empty when none)."""
    out = {}
    for w in range(int(mujoco.mjtWarning.mjNWARNING)):
        count = int(d.warning[w].number)
        if count:
            out[mujoco.mjtWarning(w).name] = count
    return out


def simulate(twin: TwinModel, trajectory: Trajectory, faults=(), settings: SimSettings | None = None,
             callback: Callback | None = None, record: bool = True) -> SimReport:
    """Simulate ``trajectory`` on ``twin`` (see :class:`Simulator`)."""
    return Simulator(twin, trajectory, faults, settings).run(callback, record)


__all__ = ["ContactLog", "EncoderOffset", "Fault", "SimRecord", "SimReport", "SimSettings",
           "Simulator", "Slow", "Stuck", "mujoco_warnings", "simulate"]
