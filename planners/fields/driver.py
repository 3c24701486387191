"""Entry points of the potential-field planners: plan_apf and the CLI-shaped wrapper.

Direct planning (Makarem et al. 2014; Macktoobian et al. 2019): from any start
configuration straight to the targets, one run of :func:`rfp_twin.planners.fields.kernel.run_apf`,
no reversal, no target replacement. This module checks the inputs, resolves the
settings into the kernel's arguments (neighbour CSR, distances in mm, speeds and angles
in radians) and packs the outcome into an :class:`rfp_twin.planners.fields.result.ApfResult`.

Angles: the public API is in degrees, radians inside the kernel. Alpha is integrated as
a continuous angle by default (the field is 360-periodic in alpha and the papers'
robots have no alpha stop), so a path may leave [0, 360) (``ApfResult.alpha_out_of_limits``
counts the robots whose path did); ``enforce_alpha_limits=True`` clamps alpha to the
robot's limits instead (robots may then stall against a stop). Beta is always clamped to
the robot's beta limits (each robot's range: the spec's, shifted by its encoder offsets,
:attr:`rfp_twin.models.array.ArrayGeometry.limits`). The descent may end on either arm branch (the "faster
configuration" of Makarem 2014 Sect. 4): the goal is the tip position.

Per-robot geometry: the kernel gets each robot's alpha length, beta segment and buffer
excess and each obstacle's segment and keep-out excess from the ArrayGeometry (targets'
tips too: :func:`tip_positions`); on a nominal layout every value equals the spec's and
the run is the same as with scalars.

Cost: O(N k) per step (k neighbours from the layout's CSR), so a run is linear in N.
"""
from __future__ import annotations

import math
import time

import numpy as np

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.errors import TargetError
from rfp_twin.models.kinematics import forward
from rfp_twin.planners.fields.field import start_violation
from rfp_twin.planners.fields.kernel import run_apf
from rfp_twin.planners.fields.result import STOP_REASONS, ApfResult, events_trajectory, apf_plan
from rfp_twin.planners.fields.settings import DEG, ApfSettings, buffer_excess, obstacle_csr
from rfp_twin.planners.plan.offline import apply_offline
from rfp_twin.planners.plan.targets import check_angles
from rfp_twin.planners.plan import Plan


def _neighbours(geom: ArrayGeometry, settings: ApfSettings, D: float, D_f: float,
                ex: np.ndarray):
    """CSR of pairs that can come within D (and obstacles within D_f), coop mask.

    ``ex`` (n,) mm: each robot's threshold excess (:func:`buffer_excess`); reaches use
    the largest alpha length, segment end and excess over the robots.
    """
    spec = geom.spec
    lay = geom.layout
    n = geom.n_robots
    la = float(geom.alpha_len.max()) if n else spec.alpha_length_mm
    if settings.model == "tip":
        r_arm = la + spec.beta_length_mm
    else:
        r_arm = la + max(float(geom.seg_start.max()) if n else spec.segment_start_mm,
                         float(geom.seg_end.max()) if n else 0.0)
    ex_max = float(ex.max()) if n else 0.0
    coop_r = settings.coop_radius_mm
    if coop_r is None:
        coop_r = 1.2 * nearest_spacing_mm(geom)
    ptr, idx = lay.neighbour_csr(max(2.0 * r_arm + D + 2.0 * ex_max, float(coop_r)))
    ptr = np.asarray(ptr, dtype=np.int64)
    idx = np.asarray(idx, dtype=np.int64)
    owner = np.repeat(np.arange(geom.n_robots), np.diff(ptr))
    dist = np.hypot(*(geom.base_xy[owner] - geom.base_xy[idx]).T) if idx.size else np.empty(0)
    coop = np.asarray(dist <= float(coop_r), dtype=np.bool_)
    fptr, fidx = obstacle_csr(geom, r_arm + D_f + ex_max)
    return ptr, idx, coop, fptr, fidx, float(coop_r)


def tip_positions(geom: ArrayGeometry, angles_deg: np.ndarray) -> np.ndarray:
    """(n, 2) fiber tips, mm, at each robot's own alpha length plus the beta length.

    angles_deg : (n, 2) (alpha, beta) deg. Robots sharing an alpha length go through one
    :func:`rfp_twin.models.kinematics.forward` call (a nominal layout: one call).
    """
    la = geom.alpha_len
    lb = geom.spec.beta_length_mm
    angles = np.ascontiguousarray(angles_deg, dtype=np.float64)
    out = np.empty((geom.n_robots, 2))
    for value in np.unique(la):
        rows = np.flatnonzero(la == value)
        out[rows] = forward(np.ascontiguousarray(geom.base_xy[rows]),
                            np.ascontiguousarray(angles[rows]), float(value), lb)[0]
    return out


def nearest_spacing_mm(geom: ArrayGeometry) -> float:
    """Median over robots of the distance to the nearest other robot base, mm."""
    if geom.n_robots < 2:
        return float(geom.spec.pitch_mm)
    from scipy.spatial import cKDTree

    dist, _ = cKDTree(geom.base_xy).query(geom.base_xy, k=2)
    return float(np.median(dist[:, 1]))


def plan_apf(geom: ArrayGeometry, start, targets, settings: ApfSettings | None = None,
             movable=None, *, record: bool = True, algorithm: str = "apf") -> ApfResult:
    """Plan from ``start`` straight to ``targets`` with the navigation function.

    Parameters
    ----------
    geom : ArrayGeometry
        Layout, spec and buffer (the buffer matters in segment mode only).
    start, targets : (n, 2) float, deg
        (alpha, beta) per robot, within each robot's limits. Rows of robots that cannot
        move are ignored in ``targets``.
    settings : ApfSettings (default: the paper's tip model)
    movable : (n,) bool, optional
        False for offline robots (they stay at ``start`` and repel their neighbours).
    record : bool
        Build the Trajectory (False: only the figures, for benchmarks).
    algorithm : label stored in the result ("apf", or "capf" with CapfSettings).

    Returns
    -------
    ApfResult

    Targets closer than about ``d + 1`` mm (tip model; the equilibrium of attraction
    and repulsion) cannot be reached within 100 um, and targets within ``d`` never:
    those robots end not converged. :func:`rfp_twin.planners.fields.tips.random_tip_configs` and
    :func:`apf_target_margin_mm` draw targets that can.

    Raises
    ------
    TargetError
        Bad shapes, NaN or out-of-limit angles, or a start configuration with a pair
        within ``d`` (or a robot within ``d_fid`` of a fiducial): the barrier cannot
        start there.
    """
    t_call = time.perf_counter()
    settings = settings or ApfSettings()
    spec = geom.spec
    n = geom.n_robots
    start = check_angles(geom, start, "start")
    targets = check_angles(geom, targets, "targets").copy()
    mov = np.ones(n, dtype=bool) if movable is None else np.asarray(movable, dtype=bool).copy()
    if mov.shape != (n,):
        raise TargetError(f"movable: shape {mov.shape}; allowed: ({n},) bool")
    targets[~mov] = start[~mov]
    d, D, d_f, D_f, margin = settings.distances(geom)
    wa_deg, wb_deg = settings.speeds_deg_s(geom)
    segment = settings.model == "segment"
    ex, fex = buffer_excess(geom, settings.model)
    ptr, idx, coop, fptr, fidx, _ = _neighbours(geom, settings, D, D_f, ex)
    la = np.ascontiguousarray(geom.alpha_len, dtype=np.float64)
    lb = spec.beta_length_mm
    s0 = np.ascontiguousarray(geom.seg_start, dtype=np.float64)
    s1 = np.ascontiguousarray(geom.seg_end, dtype=np.float64)
    fid_a = np.ascontiguousarray(geom.fid_xy, dtype=np.float64).reshape(-1, 2)
    fid_b = np.ascontiguousarray(geom.fid_end_xy, dtype=np.float64).reshape(-1, 2)
    th0 = np.ascontiguousarray(start * DEG)
    i, j, s = start_violation(geom.base_xy, th0, la, lb, s0, s1, segment, ptr, idx, fptr, fidx,
                               fid_a, fid_b, ex, fex, d, d_f, mov)
    if i >= 0:
        what = "tips" if not segment else "beta segments"
        if j >= 0:
            lim = d + (ex[i] + ex[j])
            raise TargetError(f"start: robots {int(geom.robot_ids[i])} and {int(geom.robot_ids[j])}: "
                              f"{what} {s:.4f} mm apart; allowed: > d = {lim:.4f} mm")
        f = -1 - j
        kind = str(np.asarray(geom.layout.kinds)[~np.asarray(geom.layout.robot_mask)][f])
        raise TargetError(f"start: robot {int(geom.robot_ids[i])}: {s:.4f} mm from {kind} "
                          f"{int(geom.fiducial_ids[f])}; allowed: > {d_f + (ex[i] + fex[f]):.4f} mm")
    target_xy = tip_positions(geom, targets)
    dt = settings.dt_s
    max_steps = int(math.ceil(settings.max_time_s / dt - 1e-9))
    stall_steps = max(1, int(round(settings.stall_window_s / dt)))
    alo, ahi, blo, bhi = (np.ascontiguousarray(geom.limits[:, c]) for c in range(4))
    t0 = time.perf_counter()
    (k, stop, th, ev_r, ev_a, ev_s, ev_v, n_ev, stats, settle, err, th_min, th_max) = run_apf(
        geom.base_xy, th0, np.ascontiguousarray(targets * DEG), np.ascontiguousarray(target_xy),
        mov, ptr, idx, coop, fptr, fidx, fid_a, fid_b, la, lb, s0, s1, ex, fex, segment,
        d, D, d_f, D_f,
        settings.lambda1, settings.lambda2, settings.lambda3, settings.gain, wa_deg * DEG, wb_deg * DEG,
        blo * DEG, bhi * DEG, alo * DEG, ahi * DEG, settings.enforce_alpha_limits, dt,
        settings.tol_mm, max_steps, stall_steps, settings.stall_deg * DEG,
        math.sin(settings.singular_band_deg * DEG), settings.axis_radius_mm,
        settings.implicit_attraction, settings.guard,
        settings.simplify_tol_deg * DEG, max(1024, 8 * n))
    compute = time.perf_counter() - t0
    reason = STOP_REASONS[int(stop)]
    motion = (k - stall_steps if reason == "stalled" else k) * dt
    final = th / DEG
    conv = mov & (err < settings.tol_mm)
    settle_t = np.where(conv & (settle >= 0), settle * dt, np.nan)
    out_alpha = int(np.sum(mov & ((th_min[:, 0] / DEG < alo - 1e-9) | (th_max[:, 0] / DEG > ahi + 1e-9))))
    traj, tol_used = None, settings.simplify_tol_deg
    if record:
        traj, tol_used = events_trajectory(geom.robot_ids, ev_r[:n_ev], ev_a[:n_ev], ev_s[:n_ev],
                                     ev_v[:n_ev], n, dt, settings)
    return ApfResult(
        algorithm=algorithm, robot_ids=geom.robot_ids.copy(), trajectory=traj,
        start=start.copy(), targets=targets, final=final, movable=mov, converged=conv,
        tip_error_mm=np.where(mov, err, 0.0), settle_time_s=settle_t,
        min_distance_mm=float(stats[0]), min_tip_distance_mm=float(stats[1]),
        min_fiducial_distance_mm=float(stats[2]), d_mm=d, D_mm=D, d_fid_mm=d_f, D_fid_mm=D_f,
        margin_mm=margin, motion_time_s=float(motion), compute_time_s=compute,
        total_time_s=time.perf_counter() - t_call, steps=int(k), stop_reason=reason,
        n_guard=int(stats[3]), alpha_out_of_limits=out_alpha, simplify_tol_used_deg=tol_used,
        speed_deg_s=(wa_deg, wb_deg), settings=settings)


def plan_apf_reconfiguration(geom: ArrayGeometry, targets, settings: ApfSettings | None = None, *,
                             start=None, offline: dict[int, tuple[float, float]] | None = None,
                             algorithm: str = "apf") -> tuple[Plan, ApfResult]:
    """CLI-shaped entry: plan from the folded state (or ``start``) to ``targets``.

    Like :func:`rfp_twin.planners.plan.reconfigure.plan_reconfiguration` but direct (forward), single run,
    no target replacement: robots that do not converge are DEADLOCKED.

    Parameters
    ----------
    geom : ArrayGeometry
    targets : (n, 2) deg
    settings : ApfSettings (or CapfSettings)
    start : (n, 2) deg, optional (default: ``spec.fold_deg`` for every robot)
    offline : {robot_id: (alpha, beta)} robots that never move, at these angles

    Returns
    -------
    (Plan on the step clock ``step_s = dt``, the ApfResult with its Trajectory)

    Raises
    ------
    UnknownRobotError, TargetError
        Bad offline robots (:func:`rfp_twin.planners.plan.offline.apply_offline`), or as :func:`plan_apf`.
    """
    n = geom.n_robots
    if start is None:
        start = np.tile(np.asarray(geom.spec.fold_deg, dtype=np.float64), (n, 1))
    start = np.array(start, dtype=np.float64, copy=True)
    movable = apply_offline(geom, offline, start)
    targets = np.array(targets, dtype=np.float64, copy=True)
    if targets.shape == (n, 2):
        targets[~movable] = start[~movable]
    result = plan_apf(geom, start, targets, settings, movable, algorithm=algorithm)
    return apf_plan(result), result


def apf_target_margin_mm(geom: ArrayGeometry, settings: ApfSettings) -> float:
    """Clearance beyond Eq. 3 (segment mode) that targets need so the barrier allows them.

    Pass it as ``margin_mm`` to :func:`rfp_twin.planners.plan.targets.random_targets`. In tip mode the
    capsule clearance does not bound the tip distance; use
    :func:`rfp_twin.planners.fields.tips.random_tip_configs`.
    """
    d, D, _, _, _ = settings.distances(geom)
    if settings.model == "segment":
        return max(0.0, d - 2.0 * geom.buffer_mm)
    return 0.0
