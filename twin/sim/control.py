"""The controller and the tracking error: what each servo is told, and how far each robot
is from its nominal trajectory.

Each robot's two position servos (:mod:`rfp_twin.models.mjcf`) follow the trajectory: every
physics step the actuator target is the commanded angle at the end of the step plus a
velocity feed-forward ``(kv / kp) * d(angle)/dt``, so the servo tracks ramps without the
steady lag of a pure PD loop. Robots the trajectory does not mention hold the spec's
fold configuration; faults (:mod:`rfp_twin.twin.sim.faults`) change what a robot is commanded.

The tracking error is the true joint angle minus the nominal trajectory (without
faults), per robot and axis.

Shapes: n robots (layout order), T times; angles (T, n, 2) deg (alpha, beta); servo
targets (T, 2n) rad in the model's actuator order (robot-major). Times in s.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from rfp_twin.models.errors import TrajectoryError
from rfp_twin.models.kinematics import forward, forward_fiber
from rfp_twin.models.layout.columns import FIBER_COLUMNS, FIBERS, robot_column, robot_fibers
from rfp_twin.models.mjcf import TwinModel
from rfp_twin.models.mjcf.tiled_twin import TiledTwin
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.twin.sim.faults import fault_effects
from rfp_twin.twin.sim.sampling import TrajectoryTable


def feedforward_gains(twin: TwinModel) -> np.ndarray:
    """(n, 2) velocity feed-forward gain ``kv / kp`` of each servo, s (0 where kp = 0).
    A tiled twin (:class:`rfp_twin.models.mjcf.tiled_twin.TiledTwin`): each robot's from the
    tile that owns it."""
    if isinstance(twin, TiledTwin):
        return twin.gather([feedforward_gains(t.twin) for t in twin.tiles])
    m = twin.model
    act = twin.index.actuator
    kp = m.actuator_gainprm[act, 0]
    kv = -m.actuator_biasprm[act, 2]
    return np.where(kp > 0, kv / np.where(kp > 0, kp, 1.0), 0.0)


class Commands:
    """The nominal and commanded angles of every robot of ``twin`` along ``trajectory``.

    Parameters
    ----------
    twin : TwinModel
    trajectory : Trajectory; its robot ids must be robots of the twin's layout, once each.
    faults : iterable of Stuck / Slow / EncoderOffset (:func:`rfp_twin.twin.sim.faults.fault_effects`)
    feedforward : add the velocity feed-forward to the servo targets.
    """

    def __init__(self, twin: TwinModel, trajectory: Trajectory, faults=(),
                 feedforward: bool = True) -> None:
        lay = twin.layout
        self.n_robots = twin.n_robots
        self.trajectory = trajectory
        # trajectory robot -> layout robot index
        self._traj_index = lay.robot_indices(trajectory.robot_ids) if trajectory.n_robots else \
            np.empty(0, dtype=np.int64)
        if len(set(self._traj_index.tolist())) != self._traj_index.size:
            raise TrajectoryError("trajectory lists a robot twice; allowed: unique robot ids")
        self.effects = fault_effects(faults, lay)
        gains = feedforward_gains(twin)
        self.ff = gains if feedforward else np.zeros_like(gains)
        self._ff_flat = self.ff.ravel()
        self._fold = np.asarray(twin.spec.fold_deg, float)
        self._table = TrajectoryTable(trajectory, self._traj_index)

    def nominal(self, times: np.ndarray) -> np.ndarray:
        """(len(times), n, 2) nominal angles (the trajectory; fold for others), deg."""
        return self._sample(np.asarray(times, float), warped=False)

    def commanded(self, times: np.ndarray) -> np.ndarray:
        """(len(times), n, 2) angles the servos are asked to reach (faults applied), deg:
        true-angle targets, i.e. already corrected for encoder offsets."""
        return self._sample(np.asarray(times, float), warped=True) - self.effects.offset[None]

    def servo_targets(self, t_grid: np.ndarray, dt: float) -> np.ndarray:
        """(len(t_grid) - 2, 2n) actuator targets, rad, for the physics steps starting at
        ``t_grid[:-2]`` (a grid of step ``dt`` s): where to be at the end of the step
        (``t_grid[1:-1]``), plus the velocity feed-forward over the next step."""
        t_grid = np.asarray(t_grid, float)
        raw = self._sample(t_grid, warped=True).reshape(t_grid.size, -1)   # deg, before offsets
        out = np.empty((t_grid.size - 2, raw.shape[1]))
        _targets(raw, self.effects.offset.ravel(), self._ff_flat, float(dt), out)
        return out

    def _sample(self, times: np.ndarray, warped: bool) -> np.ndarray:
        out = np.empty((times.size, self.n_robots, 2))
        out[:] = self._fold
        fx = self.effects
        if warped:
            self._table.sample_into(out, times, fx.stuck_at, fx.warp_scale)
        else:
            self._table.sample_into(out, times)
        return out


@njit(cache=True)
def _targets(raw, offset, ff, dt, out):
    """Servo targets (T - 2, 2n) rad from the commanded angles ``raw`` (T, 2n) deg before
    the encoder offsets ``offset`` (2n,) deg: ``c[r + 1] + ff (c[r + 2] - c[r + 1]) / dt``
    with ``c = radians(raw - offset)`` (:meth:`Commands.servo_targets` in one pass)."""
    rad = np.pi / 180.0
    for r in range(out.shape[0]):
        for c in range(out.shape[1]):
            now = (raw[r + 1, c] - offset[c]) * rad
            nxt = (raw[r + 2, c] - offset[c]) * rad
            out[r, c] = now + ff[c] * (nxt - now) / dt


class TrackingError:
    """Running tracking error of n robots over physics steps.

    max_deg (n, 2) : the signed error of largest magnitude so far, deg.
    sum_sq (n, 2) : sum of squared errors, deg^2.
    """

    def __init__(self, n_robots: int) -> None:
        self.max_deg = np.zeros((n_robots, 2))
        self.sum_sq = np.zeros((n_robots, 2))
        self._err = np.zeros((n_robots, 2))

    def add(self, angles_deg: np.ndarray, nominal_deg: np.ndarray) -> None:
        """Account one step: true angles (n, 2) deg against the nominal (n, 2) deg."""
        err, max_err = self._err, self.max_deg
        np.subtract(angles_deg, nominal_deg, out=err)
        big = np.abs(err) > np.abs(max_err)
        max_err[big] = err[big]
        self.sum_sq += err * err

    def rms_deg(self, n_steps: int) -> np.ndarray:
        """(n, 2) root-mean-square error over ``n_steps`` steps, deg."""
        return np.sqrt(self.sum_sq / n_steps)


def fiber_error_mm(twin: TwinModel, angles_deg: np.ndarray, nominal_deg: np.ndarray) -> np.ndarray:
    """(n,) distance, mm, between the fiber at the true angles (n, 2) deg and at the
    nominal angles (n, 2) deg (planar kinematics).

    Nominal layouts: the paper's fiber at ``beta_length_mm`` on the spec's arms
    (:func:`rfp_twin.models.kinematics.forward`). A layout with per-robot geometry (a
    calibrated instrument): each robot's metrology fiber on its own alpha arm
    (``alpha_len_mm``, ``met_x_mm, met_y_mm``; :func:`rfp_twin.models.kinematics.forward_fiber`).
    """
    spec = twin.spec
    base = np.ascontiguousarray(twin.layout.robot_xy, dtype=np.float64)
    lay = twin.layout
    if any(c in lay.extra for c in ("alpha_len_mm", *FIBER_COLUMNS["metrology"])):
        la = robot_column(lay, "alpha_len_mm", spec.alpha_length_mm)
        fibers = robot_fibers(lay, {"metrology": (spec.beta_length_mm, 0.0)})
        met = fibers[:, FIBERS.index("metrology")]
        f_true = forward_fiber(base, np.asarray(angles_deg, dtype=np.float64), la, met)
        f_ref = forward_fiber(base, np.asarray(nominal_deg, dtype=np.float64), la, met)
        return np.hypot(*(f_true - f_ref).T)
    f_true, _ = forward(base, np.ascontiguousarray(angles_deg), spec.alpha_length_mm,
                        spec.beta_length_mm)
    f_ref, _ = forward(base, np.ascontiguousarray(nominal_deg), spec.alpha_length_mm,
                       spec.beta_length_mm)
    return np.hypot(*(f_true - f_ref).T)
