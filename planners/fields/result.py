"""What a potential-field run returns: ApfResult, its Trajectory and its Plan.

The kernel (:mod:`rfp_twin.planners.fields.kernel`) records breakpoints (robot, axis, Euler step,
angle rad); :func:`events_trajectory` turns them into a :class:`rfp_twin.models.trajectory.Trajectory`
(deg, s), sending axes with more than ``max_points`` breakpoints through
:func:`rfp_twin.planners.postprocess.simplify.simplify_axis` (RDP, tolerance raised until they fit).
:func:`apf_plan` turns a result into a :class:`rfp_twin.planners.plan.Plan` on a step clock
``step_s = dt`` with the solver's metric keys. Angles in deg, times in s, lengths in mm.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from rfp_twin.models.errors import SpecError, field_error
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.planners.fields.settings import DEG, ApfSettings
from rfp_twin.planners.plan import DEADLOCKED, OFFLINE, REACHED, Plan
from rfp_twin.planners.postprocess.simplify import simplify_axis

#: Why a run stopped (``ApfResult.stop_reason``), by the kernel's stop code.
STOP_REASONS = ("converged", "stalled", "max_time")


@dataclass
class ApfResult:
    """Outcome of one :func:`rfp_twin.planners.fields.plan_apf` run (APF or CAPF).

    Attributes
    ----------
    algorithm : "apf" | "capf"
    robot_ids : (n,) int64
    trajectory : Trajectory or None
        Per robot and axis (time s, angle deg) breakpoints, t = 0 at the start; None
        when planned with ``record=False``.
    start, targets, final : (n, 2) float64, deg
        ``final`` may differ from ``targets`` by the tolerance, by the arm branch, and
        (continuous alpha) by multiples of 360 deg in alpha.
    movable, converged : (n,) bool
        ``converged``: movable and the tip within ``tol_mm`` of its target at the end.
    tip_error_mm : (n,) float64, final tip distance to the target (0 for offline robots)
    settle_time_s : (n,) float64
        Time after which the robot stayed within tolerance (NaN if not converged).
    min_distance_mm : float
        Smallest pair distance of the collision model over all steps (tip distance or
        beta-segment distance), mm (inf without pairs); with per-robot buffers, each
        pair's distance less its two robots' buffer excess (so it compares with ``d_mm``).
    min_tip_distance_mm, min_fiducial_distance_mm : float
        Smallest tip-tip distance, and smallest robot(model)-obstacle distance less the
        robot's and the obstacle's buffer excess (compares with ``d_fid_mm``), seen, mm.
        Obstacles are fiducial points or guide-camera edge segments.
    d_mm, D_mm, d_fid_mm, D_fid_mm, margin_mm : float, resolved nominal distances (run
        buffer, spec fiducial buffer; see :mod:`rfp_twin.planners.fields.settings`)
    motion_time_s : float
        ``steps x dt`` when converged or stopped at ``max_time_s``; for a stalled run the
        time when the stall window began.
    compute_time_s : float, the kernel's wall time (numba compile excluded after the
        first call); total_time_s : the whole call (setup, kernel, trajectory)
    steps : int, Euler steps taken
    stop_reason : one of STOP_REASONS
    n_guard : int, pairs the step guard had to hold back (0: the field alone kept every
        distance > d)
    alpha_out_of_limits : int, robots whose alpha path left the spec's alpha limits
    simplify_tol_used_deg : float, largest tolerance any axis needed to fit max_points
    speed_deg_s : (alpha, beta) saturation speeds used, deg/s
    settings : ApfSettings
    """

    algorithm: str
    robot_ids: np.ndarray
    trajectory: Trajectory | None
    start: np.ndarray
    targets: np.ndarray
    final: np.ndarray
    movable: np.ndarray
    converged: np.ndarray
    tip_error_mm: np.ndarray
    settle_time_s: np.ndarray
    min_distance_mm: float
    min_tip_distance_mm: float
    min_fiducial_distance_mm: float
    d_mm: float
    D_mm: float
    d_fid_mm: float
    D_fid_mm: float
    margin_mm: float
    motion_time_s: float
    compute_time_s: float
    total_time_s: float
    steps: int
    stop_reason: str
    n_guard: int
    alpha_out_of_limits: int
    simplify_tol_used_deg: float
    speed_deg_s: tuple[float, float]
    settings: ApfSettings = field(repr=False)

    @property
    def n_robots(self) -> int:
        return int(self.robot_ids.shape[0])

    @property
    def n_converged(self) -> int:
        return int(self.converged.sum())

    @property
    def complete(self) -> bool:
        """True when every movable robot converged."""
        return bool(np.all(self.converged[self.movable]))

    def metrics(self) -> dict:
        """The solver's metric keys (rfp_twin.planners.plan.reconfigure.plan_reconfiguration) plus APF ones.

        No target is ever replaced, so ``efficiency`` (Eq. 11) and ``convergence`` are
        both the converged fraction of the movable robots; ``tau_pg_s`` is the kernel
        time, ``tau_sr_s`` the whole call, ``fold_time_s`` the motion time.
        """
        n_mov = int(self.movable.sum())
        frac = self.n_converged / max(1, n_mov)
        return {
            "n_robots": self.n_robots, "n_movable": n_mov, "n_offline": self.n_robots - n_mov,
            "n_replaced": 0, "n_deadlocked": n_mov - self.n_converged,
            "efficiency": frac, "convergence": frac, "rounds": 0,
            "tau_pg_s": self.compute_time_s, "tau_sr_s": self.total_time_s,
            "fold_time_s": self.motion_time_s, "n_steps": self.steps,
            "max_displacement_mm": self.margin_mm,
            "algorithm": self.algorithm, "model": self.settings.model,
            "stop_reason": self.stop_reason, "min_distance_mm": self.min_distance_mm,
            "min_tip_distance_mm": self.min_tip_distance_mm,
            "min_fiducial_distance_mm": self.min_fiducial_distance_mm,
            "d_mm": self.d_mm, "D_mm": self.D_mm, "dt_s": self.settings.dt_s,
            "tol_mm": self.settings.tol_mm, "lambda1": self.settings.lambda1,
            "lambda2": self.settings.lambda2, "lambda3": self.settings.lambda3,
            "n_guard": self.n_guard, "alpha_out_of_limits": self.alpha_out_of_limits,
            "max_tip_error_mm": float(self.tip_error_mm[self.movable].max()) if n_mov else 0.0,
        }


def apf_plan(result: ApfResult) -> Plan:
    """A :class:`rfp_twin.planners.plan.Plan` on the Euler step clock (``step_s = dt``).

    Each robot's breakpoints are the union of its alpha and beta breakpoint steps, the
    other axis interpolated linearly (exact: both axes are linear between their own
    breakpoints). ``step_deg`` is the largest angle one step can move an axis
    (``dt x`` the larger saturation speed), which is what the post-processing's step
    bounds need. Status: REACHED (converged), DEADLOCKED (movable, not converged),
    OFFLINE. ``targets`` and ``original_targets`` are the requested targets; ``end()``
    is where each robot stopped (within ``tol_mm`` of the target's tip position).
    """
    traj = result.trajectory
    if traj is None:
        raise field_error(SpecError, "trajectory", None, "a result planned with record=True",
                          "apf_plan")
    dt = result.settings.dt_s
    n = result.n_robots
    steps_l, ang_l = [], []
    for i in range(n):
        ta, aa = traj.times[0][i], traj.angles[0][i]
        tb, ab = traj.times[1][i], traj.angles[1][i]
        st = np.unique(np.rint(np.concatenate([ta, tb]) / dt))
        t = st * dt
        steps_l.append(st)
        ang_l.append(np.column_stack([np.interp(t, ta, aa), np.interp(t, tb, ab)]))
    ptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum([len(s) for s in steps_l], out=ptr[1:])
    status = np.where(result.converged, REACHED, DEADLOCKED).astype(object)
    status[~result.movable] = OFFLINE
    return Plan(
        robot_ids=result.robot_ids.copy(), step_deg=dt * max(result.speed_deg_s), step_s=dt,
        n_steps=int(result.steps), path_ptr=ptr,
        path_step=np.concatenate(steps_l).astype(np.float64) if n else np.empty(0),
        path_angles=np.concatenate(ang_l) if n else np.empty((0, 2)),
        status=status, targets=result.targets.copy(), original_targets=result.targets.copy(),
        metrics=result.metrics())


def events_trajectory(robot_ids, ev_r, ev_a, ev_s, ev_v, n, dt, settings):
    """Kernel breakpoints (rad, steps) -> Trajectory (deg, s), capped at max_points."""
    key = ev_r * 2 + ev_a
    order = np.lexsort((ev_s, key))
    key = key[order]
    t_all = ev_s[order] * dt
    v_all = ev_v[order] / DEG
    bounds = np.searchsorted(key, np.arange(2 * n + 1))
    times = ([], [])
    angles = ([], [])
    used = settings.simplify_tol_deg
    for i in range(n):
        for ax in range(2):
            sl = slice(bounds[2 * i + ax], bounds[2 * i + ax + 1])
            t, v = t_all[sl], v_all[sl]
            if t.size > settings.max_points:
                t, v, tol = simplify_axis(t, v, settings.simplify_tol_deg, settings.max_points)
                used = max(used, tol)
            times[ax].append(np.ascontiguousarray(t))
            angles[ax].append(np.ascontiguousarray(v))
    traj = Trajectory(np.asarray(robot_ids, dtype=np.int64), (tuple(times[0]), tuple(times[1])),
                      (tuple(angles[0]), tuple(angles[1])))
    return traj, float(used)
