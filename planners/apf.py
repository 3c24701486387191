"""Decentralized navigation function planner (Makarem et al. 2014), repulsion sign fixed.

Every robot ``i`` descends its own potential (Makarem 2014 Eq. 2)::

    psi_i = lambda1 |q_i - q_iT|^2 + lambda2 sum_j rep(s_ij)

with joint velocities ``u_i = -J_i^T grad_q psi_i`` (Eqs. 3-4), integrated by explicit
Euler steps of ``dt`` (10 ms) until every fiber tip is within ``tol_mm`` (100 um) of its
target. Direct planning: from any start configuration straight to the targets, no
reversal, no target replacement. :mod:`planners.capf` adds Macktoobian's cooperative
term on top of the same kernel.

Paper errors, and what this module does instead
------------------------------------------------
* **Repulsion sign (Makarem 2014 Eq. 2, Table 2, Eq. 7).** As printed,
  ``min(0, (s^2 - D^2) / (s^2 - d^2))`` is negative inside the envelope and decreases as
  the tips approach, so descending it pulls tips *together*. We use (shared/references
  README)::

      rep(s) = (D^2 - s^2) / (s^2 - d^2)   for d < s < D,   0 for s >= D
      d rep / d q_i = -2 (D^2 - d^2) (q_i - q_j) / (s^2 - d^2)^2

  which is zero at ``s = D``, grows to +inf at ``s = d`` and pushes the tips apart.
  ``s <= d`` counts as a collision. See :func:`rep_potential` / :func:`rep_dpsi_ds`.
* **Speed saturation** (not given in the paper). ``u = (u_alpha, u_beta)`` rad/s is
  scaled by ``1 / max(1, |u_alpha| / vmax_alpha, |u_beta| / vmax_beta)``: both joints
  slow down together, so the joint-space direction of the descent is kept.
* **Theorem 1 / "lambda1 < 72 lambda2"** do not check out in any unit: convergence is
  verified by simulation (benchmarks/bench_apf.py), and every run reports its smallest
  distance, because discrete steps can break the barrier.
* **Units / time scale.** The paper states no units. Here lengths are mm, psi is
  mm^2 and ``u = -gain J^T grad psi`` is rad/s with ``gain`` in 1/s (default 1: the
  weights read in mm and s). The gain sets how fast robots descend before the speed
  limit, not where the field's equilibria are; with the DESI preset ``gain = 10`` gives
  the paper's ~2.5 s motion time, ``gain = 1`` about 3-4 s (benchmarks/RESULTS.md).

Singularities (beta = 0 and 180 deg)
------------------------------------
There ``J`` loses rank: the tip cannot move along the beta arm to first order, so a
push along the arm (e.g. a target closer to the base than a fully stretched arm) gives
``u = 0`` and the robot would sit on the singular configuration forever (the hardware
stop at beta = 0 makes this reachable). Makarem 2014 Sect. 5 only says to avoid them.
Rule used here: inside a band ``|sin beta| < sin(singular_band_deg)``, when the
attractive (and cooperative) push ``f`` points where moving beta helps (inwards at
beta ~ 0, outwards at beta ~ 180), beta additionally gets
``sign(beta_T - beta) * |f . r| * l_beta * (1 - |sin beta| / sin(band))`` rad/s, ``r``
the unit vector from the base to the tip: the push the Jacobian cannot transmit is
handed to beta, towards the target's beta (right-armed targets: away from 0 and 180),
fading out at the band edge.

When ``l_alpha ~ l_beta`` (DESI: 3 + 3 mm) beta = 180 deg also puts the tip on the alpha
axis, where alpha moves the tip with gain ``r = |tip - base|`` only: with ``J^T`` the
tangential approach to a target near the centre slows as ``r^2`` (a robot with its
target 0.3 mm from its axis needed ~10 s). Alpha-axis rule: for ``r < axis_radius_mm``
(default 1.5 mm) alpha's velocity is multiplied by ``(axis_radius / max(r, axis_radius
/ 10))^2``. A positive diagonal scaling of ``u`` keeps it a descent direction and moves
no equilibrium. It never acts when ``|l_alpha - l_beta| >= axis_radius_mm`` (SDSS-V).
Outside these bands the field is exactly the paper's.

Numerical safeguards (not in the paper, documented so results can be judged)
-----------------------------------------------------------------------------
* *Linearly implicit attraction.* Near its target the attractive field is stiff: its
  joint-space Hessian is ``2 lambda1 J^T J``, and for SDSS-V arms (|J| ~ 22 mm) explicit
  Euler at 10 ms overshoots by a factor ~10 and ends in a saturated chatter. The step is
  therefore ``dtheta = dt (I + 2 lambda1 dt J^T J)^-1 u`` (then saturated): exact for the
  quadratic attraction, and since the matrix is positive definite it keeps ``u``'s
  descent property and changes no equilibrium (``dtheta = 0`` iff ``u = 0``). For DESI
  arms it shortens steps by at most ~2x, and only when unsaturated.
  ``implicit_attraction=False`` gives the paper's explicit Euler. The matrix uses
  ``2 lambda1 gain dt``.
* *Step guard.* After all robots propose their step (Jacobi: every robot sees the same
  state), any pair whose new distance is ``<= d`` (or robot-fiducial ``<= d_fid``) has
  the steps of both of its robots halved, up to 4 times, then cancelled. The state at
  every step thus keeps all distances ``> d``; ``ApfResult.n_guard`` counts how often
  the field alone would not have.

Collision models
----------------
``"tip"`` (Makarem 2014): fiber tips are points; pairs repel on the tip distance,
defaults ``d = 2``, ``D = 4`` mm (DESI, Table 3). A fiducial is a disk of radius
``spec.fiducial_buffer_mm`` that the tip (radius ``d / 2``) must not touch.

``"segment"`` (Sayres 2021 Eq. 3): the beta collision segment of each robot
(``segment_start_mm .. segment_end`` along the beta arm). ``s`` is the segment distance,
``grad`` acts at the closest point ``p`` of the segment, whose Jacobian is the tip's with
``l_beta`` replaced by its distance ``r`` along the arm. Default ``d = 2 buffer +
margin``, ``D = d + 2`` mm. The margin (default :func:`default_margin_mm`) covers the
motion between two Euler steps and the simplification tolerance, so that a trajectory
whose sampled distances are all ``> d`` passes the dense capsule check
(validation/checker2d.py) at ``buffer``: two points of two arms move at most
``V dt`` closer between samples, ``V = l_alpha w_a + r_max (w_a + w_b)`` (rad/s speeds).
Fiducials: point-segment distance, ``d_fid = buffer + fiducial_buffer + margin``. (If
an axis needed more than ``max_points`` breakpoints, its tolerance was raised:
``ApfResult.simplify_tol_used_deg``; above ``simplify_tol_deg`` the margin no longer
covers it and the trajectory should be checked, as the CLI always does.)

In both models ``D_fid = d_fid + (D - d)``. Offline robots never move and repel their
neighbours like any other robot; they take no part in the cooperative term.

Angles
------
Public API in degrees; radians inside the kernel. Alpha is integrated as a continuous
angle by default (the field is 360-periodic in alpha and the paper's robots have no
alpha stop), so a path may leave [0, 360) (``ApfResult.alpha_out_of_limits`` counts the
robots whose path did); ``enforce_alpha_limits=True`` clamps alpha to the spec's limits
instead (robots may then stall against a stop). Beta is always clamped to the spec's
beta limits (no wrap through the beta stop). The descent may end on either arm branch
(the "faster configuration" of Makarem 2014 Sect. 4): the goal is the tip position.

Output
------
The kernel records each axis's path online with a swing-door filter (kept points are
original Euler samples; linear interpolation between them is within
``simplify_tol_deg`` of every sample), then axes with more than ``max_points``
breakpoints go through :func:`planners.simplify.simplify_axis` (RDP, tolerance raised
until they fit). :class:`ApfResult` holds the :class:`models.trajectory.Trajectory`;
:func:`apf_plan` turns a result into a :class:`planners.plan.Plan` on a step clock
``step_s = dt`` with the solver's metric keys.

Cost: O(N k) per step (k neighbours from the layout's CSR), so a run is linear in N.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from models.array import ArrayGeometry
from models.errors import SpecError, TargetError, UnknownRobotError, field_error
from models.kinematics import forward, sample_patrol_zone
from planners.plan import DEADLOCKED, OFFLINE, REACHED, Plan
from planners.simplify import simplify_axis
from models.trajectory import Trajectory

DEG = math.pi / 180.0
#: Collision models of :class:`ApfSettings`.
MODELS = ("tip", "segment")
#: Makarem 2014 Table 3 / Table 4 defaults.
TIP_D_MM = 2.0
TIP_ENVELOPE_MM = 4.0
#: Default envelope width ``D - d`` in segment mode (the paper's 4 - 2 mm), mm.
SEGMENT_ENVELOPE_MM = 2.0
#: Why a run stopped (``ApfResult.stop_reason``).
STOP_REASONS = ("converged", "stalled", "max_time")
#: Halvings of a guarded step before it is cancelled.
GUARD_HALVINGS = 4
#: Safety added to the computed segment-mode margin, mm.
MARGIN_SAFETY_MM = 0.005


# =====================================================================================
# Settings
# =====================================================================================
def _num(value, name: str, lo: float, hi: float, allowed: str, lo_open=True, hi_open=False,
         where="ApfSettings") -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = math.nan
    ok = math.isfinite(v) and (v > lo if lo_open else v >= lo) and (v < hi if hi_open else v <= hi)
    if not ok:
        raise field_error(SpecError, name, value, allowed, where)
    return v


@dataclass(frozen=True)
class ApfSettings:
    """Parameters of the navigation-function planner. Units: mm, deg, s.

    Attributes
    ----------
    model : "tip" | "segment"
        Collision model (see module docstring).
    lambda1, lambda2 : float
        Attractive and repulsive weights (Makarem 2014: 1 and 0.05), in (0, 1000].
    lambda3 : float
        Cooperative weight (Macktoobian Eq. 5); 0 = plain APF. :class:`planners.capf.
        CapfSettings` sets it; here it must be in [0, lambda1).
    gain : float
        ``u = -gain J^T grad psi`` (1/s, lengths in mm), in (0, 1000]. The paper states
        no units, so its weights fix the shape of the field but not its time scale:
        scaling the gain changes how fast the robots descend before saturating, not where
        the field's equilibria are. 1 = the weights read in mm and seconds.
    d_mm, D_mm : float or None
        Safety distance and envelope radius, ``0 < d < D <= 100``. None: tip 2 / 4 mm;
        segment ``2 buffer + margin`` / ``d + 2``.
    margin_mm : float or None
        Segment mode: added to ``2 buffer`` for ``d`` (and to the fiducial threshold),
        in [0, 10]; None = :func:`default_margin_mm`. Ignored in tip mode.
    dt_s : float
        Euler step, (0, 0.1] s (paper: 0.01).
    tol_mm : float
        Convergence distance of the tip, (0, 10] mm (paper: 0.1).
    max_time_s : float
        Motion time limit, (0, 3600] s.
    speed_deg_s : (float, float) or None
        Saturation speeds (alpha, beta) deg/s, each in (0, 3600]; None = the spec's
        ``max_speed_deg_s`` (DESI preset: 30 / 20 rpm as in Makarem 2014 Table 4).
    enforce_alpha_limits : bool
        Clamp alpha to the spec's limits (default False: continuous alpha).
    singular_band_deg : float
        Width of the singularity rule's band around beta = 0 and 180, [0, 45] deg
        (0 turns the rule off).
    axis_radius_mm : float
        Alpha-axis rule radius, [0, 100] mm (0 = off); acts only when the tip comes
        closer than this to the alpha axis, i.e. for |l_alpha - l_beta| below it (DESI).
    implicit_attraction : bool
        Linearly implicit Euler step in the attractive term (see module docstring);
        False = plain explicit Euler as in the paper.
    guard : bool
        Halve/cancel steps that would bring a pair within ``d`` (see module docstring).
    stall_window_s, stall_deg : float
        Stop early when no robot's net displacement over the last ``stall_window_s``
        (in (0, 600] s) exceeds ``stall_deg`` (in [0, 10] deg) on either axis.
    simplify_tol_deg : float
        Recording tolerance of each axis, (0, 1] deg.
    max_points : int
        Most breakpoints per axis in the trajectory, >= 2 (firmware: 1024).
    coop_radius_mm : float or None
        Base distance within which robots are cooperative neighbours (CAPF only), > 0;
        None = 1.2 x the layout's median nearest-neighbour base distance (the 6 hex
        neighbours).
    """

    model: str = "tip"
    lambda1: float = 1.0
    lambda2: float = 0.05
    lambda3: float = 0.0
    gain: float = 1.0
    d_mm: float | None = None
    D_mm: float | None = None
    margin_mm: float | None = None
    dt_s: float = 0.01
    tol_mm: float = 0.1
    max_time_s: float = 60.0
    speed_deg_s: tuple[float, float] | None = None
    enforce_alpha_limits: bool = False
    singular_band_deg: float = 5.0
    axis_radius_mm: float = 1.5
    implicit_attraction: bool = True
    guard: bool = True
    stall_window_s: float = 1.0
    stall_deg: float = 0.05
    simplify_tol_deg: float = 0.01
    max_points: int = 1024
    coop_radius_mm: float | None = None

    def __post_init__(self) -> None:
        if self.model not in MODELS:
            raise field_error(SpecError, "model", self.model, " | ".join(MODELS), "ApfSettings")
        l1 = _num(self.lambda1, "lambda1", 0.0, 1000.0, "(0, 1000]")
        _num(self.lambda2, "lambda2", 0.0, 1000.0, "(0, 1000]")
        _num(self.gain, "gain", 0.0, 1000.0, "(0, 1000] 1/s")
        _num(self.lambda3, "lambda3", 0.0, l1, f"[0, lambda1 = {l1}) (Macktoobian: lambda3 < "
             "lambda1)", lo_open=False, hi_open=True)
        if self.d_mm is not None:
            _num(self.d_mm, "d_mm", 0.0, 100.0, "(0, 100] mm")
        if self.D_mm is not None:
            lo = float(self.d_mm) if self.d_mm is not None else 0.0
            _num(self.D_mm, "D_mm", lo, 100.0, f"({lo}, 100] mm (D > d)")
        if self.margin_mm is not None:
            _num(self.margin_mm, "margin_mm", 0.0, 10.0, "[0, 10] mm", lo_open=False)
        _num(self.dt_s, "dt_s", 0.0, 0.1, "(0, 0.1] s")
        _num(self.tol_mm, "tol_mm", 0.0, 10.0, "(0, 10] mm")
        _num(self.max_time_s, "max_time_s", 0.0, 3600.0, "(0, 3600] s")
        if self.speed_deg_s is not None:
            sp = tuple(self.speed_deg_s)
            if len(sp) != 2:
                raise field_error(SpecError, "speed_deg_s", self.speed_deg_s,
                                  "(alpha, beta) deg/s, each in (0, 3600]", "ApfSettings")
            for v in sp:
                _num(v, "speed_deg_s", 0.0, 3600.0, "(alpha, beta) deg/s, each in (0, 3600]")
        _num(self.singular_band_deg, "singular_band_deg", 0.0, 45.0, "[0, 45] deg", lo_open=False)
        _num(self.axis_radius_mm, "axis_radius_mm", 0.0, 100.0, "[0, 100] mm", lo_open=False)
        _num(self.stall_window_s, "stall_window_s", 0.0, 600.0, "(0, 600] s")
        _num(self.stall_deg, "stall_deg", 0.0, 10.0, "[0, 10] deg", lo_open=False)
        _num(self.simplify_tol_deg, "simplify_tol_deg", 0.0, 1.0, "(0, 1] deg")
        if isinstance(self.max_points, bool) or not isinstance(self.max_points, (int, np.integer)) \
                or self.max_points < 2:
            raise field_error(SpecError, "max_points", self.max_points, "an integer >= 2",
                              "ApfSettings")
        if self.coop_radius_mm is not None:
            _num(self.coop_radius_mm, "coop_radius_mm", 0.0, 1e4, "(0, 1e4] mm")

    # -- resolved values ------------------------------------------------------------
    def speeds_deg_s(self, geom: ArrayGeometry) -> tuple[float, float]:
        sp = self.speed_deg_s if self.speed_deg_s is not None else geom.spec.max_speed_deg_s
        return float(sp[0]), float(sp[1])

    def distances(self, geom: ArrayGeometry) -> tuple[float, float, float, float, float]:
        """Resolved ``(d, D, d_fid, D_fid, margin)`` for this array, mm."""
        spec = geom.spec
        if self.model == "tip":
            margin = 0.0
            d = TIP_D_MM if self.d_mm is None else float(self.d_mm)
            D = (d + TIP_ENVELOPE_MM - TIP_D_MM) if self.D_mm is None else float(self.D_mm)
            d_f = d / 2.0 + spec.fiducial_buffer_mm
        else:
            margin = default_margin_mm(geom, self) if self.margin_mm is None else float(self.margin_mm)
            d = 2.0 * geom.buffer_mm + margin if self.d_mm is None else float(self.d_mm)
            D = d + SEGMENT_ENVELOPE_MM if self.D_mm is None else float(self.D_mm)
            d_f = geom.buffer_mm + spec.fiducial_buffer_mm + margin
        if not D > d:
            raise field_error(SpecError, "D_mm", D, f"> d = {d:.4f} mm", "ApfSettings")
        return d, D, d_f, d_f + (D - d), margin


def default_margin_mm(geom: ArrayGeometry, settings: ApfSettings) -> float:
    """Segment-mode margin over ``2 buffer`` that makes sampled clearance continuous, mm.

    ``V dt`` (two arm points approach by at most ``(V_i + V_j) dt / 2`` below the mean
    of their sampled distances, ``V = l_alpha w_a + r_max (w_a + w_b)``, speeds in
    rad/s) plus the simplification error of two arms, ``2 (l_alpha + r_max) tol``, plus
    ``MARGIN_SAFETY_MM``.
    """
    spec = geom.spec
    wa, wb = (v * DEG for v in settings.speeds_deg_s(geom))
    rmax = max(float(geom.seg_end.max()) if geom.n_robots else spec.beta_length_mm,
               spec.segment_start_mm)
    v = spec.alpha_length_mm * wa + rmax * (wa + wb)
    simp = 2.0 * (spec.alpha_length_mm + rmax) * settings.simplify_tol_deg * DEG
    return v * settings.dt_s + simp + MARGIN_SAFETY_MM


# =====================================================================================
# Repulsion (sign-corrected Makarem 2014 Eq. 2)
# =====================================================================================
@njit(cache=True)
def rep_potential(s, d, D):
    """Sign-corrected repulsion ``(D^2 - s^2) / (s^2 - d^2)`` for ``d < s < D``, else 0.

    +inf for ``s <= d`` (collision). Dimensionless; s, d, D in mm.
    """
    if s >= D:
        return 0.0
    if s <= d:
        return np.inf
    return (D * D - s * s) / (s * s - d * d)


@njit(cache=True)
def rep_dpsi_ds(s, d, D):
    """``d rep / d s = -2 s (D^2 - d^2) / (s^2 - d^2)^2`` (< 0 inside the envelope), 1/mm."""
    if s >= D:
        return 0.0
    if s <= d:
        return -np.inf
    q = s * s - d * d
    return -2.0 * s * (D * D - d * d) / (q * q)


# =====================================================================================
# Kernel
# =====================================================================================
@njit(cache=True)
def _pose(base, th, la, out):
    """out[i] = (cos a, sin a, cos(a+b), sin(a+b), elbow x, elbow y) for every robot."""
    for i in range(base.shape[0]):
        a = th[i, 0]
        ab = th[i, 0] + th[i, 1]
        ca = math.cos(a)
        sa = math.sin(a)
        out[i, 0] = ca
        out[i, 1] = sa
        out[i, 2] = math.cos(ab)
        out[i, 3] = math.sin(ab)
        out[i, 4] = base[i, 0] + la * ca
        out[i, 5] = base[i, 1] + la * sa


@njit(cache=True)
def _closest_on_segment(px, py, ax, ay, bx, by):
    """Closest point of segment AB to P: (distance, t in [0, 1], x, y)."""
    ux = bx - ax
    uy = by - ay
    den = ux * ux + uy * uy
    t = 0.0
    if den > 0.0:
        t = min(1.0, max(0.0, ((px - ax) * ux + (py - ay) * uy) / den))
    x = ax + t * ux
    y = ay + t * uy
    return math.sqrt((px - x) ** 2 + (py - y) ** 2), t, x, y


@njit(cache=True)
def _seg_closest(ax, ay, bx, by, cx, cy, dx, dy):
    """Closest points of segments AB and CD: (distance, t on AB, P on AB, Q on CD).

    Crossing segments return distance 0 (P = Q = the crossing point).
    """
    # proper crossing test
    d1 = (dx - cx) * (ay - cy) - (dy - cy) * (ax - cx)
    d2 = (dx - cx) * (by - cy) - (dy - cy) * (bx - cx)
    d3 = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    d4 = (bx - ax) * (dy - ay) - (by - ay) * (dx - ax)
    if ((d1 > 0.0 and d2 < 0.0) or (d1 < 0.0 and d2 > 0.0)) and \
            ((d3 > 0.0 and d4 < 0.0) or (d3 < 0.0 and d4 > 0.0)):
        t = d1 / (d1 - d2)
        x = ax + t * (bx - ax)
        y = ay + t * (by - ay)
        return 0.0, t, x, y, x, y
    best, _, qx, qy = _closest_on_segment(ax, ay, cx, cy, dx, dy)
    tb, px, py = 0.0, ax, ay
    dd, _, fx, fy = _closest_on_segment(bx, by, cx, cy, dx, dy)
    if dd < best:
        best, tb, px, py, qx, qy = dd, 1.0, bx, by, fx, fy
    dd, t, fx, fy = _closest_on_segment(cx, cy, ax, ay, bx, by)
    if dd < best:
        best, tb, px, py, qx, qy = dd, t, fx, fy, cx, cy
    dd, t, fx, fy = _closest_on_segment(dx, dy, ax, ay, bx, by)
    if dd < best:
        best, tb, px, py, qx, qy = dd, t, fx, fy, dx, dy
    return best, tb, px, py, qx, qy


@njit(cache=True)
def _pair(P, i, j, segment, lb, s0, s1):
    """Distance of robots i, j and i's closest point: (s, r_i, px, py, qx, qy).

    Tip mode: the tips (r_i = l_beta). Segment mode: the beta collision segments; r_i is
    the distance of i's closest point from its beta axis.
    """
    if not segment:
        px = P[i, 4] + lb * P[i, 2]
        py = P[i, 5] + lb * P[i, 3]
        qx = P[j, 4] + lb * P[j, 2]
        qy = P[j, 5] + lb * P[j, 3]
        return math.sqrt((px - qx) ** 2 + (py - qy) ** 2), lb, px, py, qx, qy
    s, t, px, py, qx, qy = _seg_closest(
        P[i, 4] + s0 * P[i, 2], P[i, 5] + s0 * P[i, 3], P[i, 4] + s1 * P[i, 2], P[i, 5] + s1 * P[i, 3],
        P[j, 4] + s0 * P[j, 2], P[j, 5] + s0 * P[j, 3], P[j, 4] + s1 * P[j, 2], P[j, 5] + s1 * P[j, 3])
    return s, s0 + t * (s1 - s0), px, py, qx, qy


@njit(cache=True)
def _fid(P, i, fx, fy, segment, lb, s0, s1):
    """Distance of robot i (tip or segment) to point (fx, fy): (s, r_i, px, py)."""
    if not segment:
        px = P[i, 4] + lb * P[i, 2]
        py = P[i, 5] + lb * P[i, 3]
        return math.sqrt((px - fx) ** 2 + (py - fy) ** 2), lb, px, py
    s, t, px, py = _closest_on_segment(fx, fy, P[i, 4] + s0 * P[i, 2], P[i, 5] + s0 * P[i, 3],
                                       P[i, 4] + s1 * P[i, 2], P[i, 5] + s1 * P[i, 3])
    return s, s0 + t * (s1 - s0), px, py


@njit(cache=True)
def _jt(P, i, la, r, fx, fy):
    """J^T f for the point at r along robot i's beta arm: (f . dp/dalpha, f . dp/dbeta)."""
    # dp/dalpha = la perp(e_a) + r perp(e_ab); dp/dbeta = r perp(e_ab); perp(c, s) = (-s, c)
    fb = r * (-fx * P[i, 3] + fy * P[i, 2])
    fa = la * (-fx * P[i, 1] + fy * P[i, 0]) + fb
    return fa, fb


@njit(cache=True)
def _emit(ev_r, ev_a, ev_s, ev_v, n_ev, robot, axis, step, value):
    """Append one breakpoint, growing the buffers when full. Returns the new buffers."""
    if n_ev >= ev_r.shape[0]:
        m = ev_r.shape[0] * 2
        r2 = np.empty(m, dtype=np.int64)
        a2 = np.empty(m, dtype=np.int64)
        s2 = np.empty(m, dtype=np.int64)
        v2 = np.empty(m)
        r2[:n_ev] = ev_r[:n_ev]
        a2[:n_ev] = ev_a[:n_ev]
        s2[:n_ev] = ev_s[:n_ev]
        v2[:n_ev] = ev_v[:n_ev]
        ev_r, ev_a, ev_s, ev_v = r2, a2, s2, v2
    ev_r[n_ev] = robot
    ev_a[n_ev] = axis
    ev_s[n_ev] = step
    ev_v[n_ev] = value
    return ev_r, ev_a, ev_s, ev_v, n_ev + 1


@njit(cache=True)
def run_apf(base, th0, th_target, target_xy, movable, nbr_ptr, nbr_idx, nbr_coop,
            fid_ptr, fid_idx, fid_xy, la, lb, s0, s1, segment, d, D, d_f, D_f,
            l1, l2, l3, gain, w_a, w_b, beta_lo, beta_hi, alpha_lo, alpha_hi, clamp_alpha,
            dt, tol, max_steps, stall_steps, stall_rad, band_sin, axis_r, implicit, guard,
            simp_tol, cap):
    """Integrate the (cooperative) navigation field. Angles in radians, lengths in mm.

    Parameters
    ----------
    base : (n, 2) base positions; th0, th_target : (n, 2) start / target angles (rad)
    target_xy : (n, 2) target tip positions; movable : (n,) bool
    nbr_ptr, nbr_idx : CSR robot neighbours (pairs that can come within D)
    nbr_coop : (len(nbr_idx),) bool, entry is a cooperative neighbour (CAPF)
    fid_ptr, fid_idx, fid_xy : CSR robot -> fiducials and fiducial centres
    la, lb, s0, s1 : alpha / beta arm lengths, beta segment start / end along the arm
    segment : bool, segment model (else tip model)
    d, D, d_f, D_f : robot and fiducial safety / envelope distances
    l1, l2, l3 : field weights; gain : 1/s factor on u; w_a, w_b : saturation speeds (rad/s)
    beta_lo, beta_hi, alpha_lo, alpha_hi : joint limits (rad); clamp_alpha : bool
    dt : Euler step (s); tol : convergence distance; max_steps, stall_steps : ints
    stall_rad, band_sin, axis_r, implicit, guard, simp_tol : see ApfSettings
    cap : initial breakpoint buffer size

    Returns
    -------
    n_steps, stop (0 converged, 1 stalled, 2 max steps), th (n, 2) final,
    ev_r, ev_a, ev_s, ev_v, n_ev : breakpoints (robot, axis, step, angle rad),
    stats (4,) = min pair distance, min tip distance, min fiducial distance,
    guard events; settle (n,) int64 step of last entry into
    tolerance (-1 if not converged); err (n,) final tip errors (mm); th_min, th_max
    (n, 2) angle ranges visited.
    """
    n = base.shape[0]
    th = th0.copy()
    P = np.empty((n, 6))
    Q = np.empty((n, 6))
    prop = np.empty((n, 2))
    frac = np.ones(n)
    moved = np.zeros(n, dtype=np.bool_)
    u = np.zeros((n, 2))
    err = np.zeros(n)
    settle = -np.ones(n, dtype=np.int64)
    ckpt = th0.copy()
    th_min = th0.copy()
    th_max = th0.copy()
    # swing-door state per robot and axis: anchor step/value, slope cone, last sample
    anc_k = np.zeros((n, 2), dtype=np.int64)
    anc_v = th0.copy()
    lo = np.full((n, 2), -np.inf)
    hi = np.full((n, 2), np.inf)
    last_v = th0.copy()
    ev_r = np.empty(cap, dtype=np.int64)
    ev_a = np.empty(cap, dtype=np.int64)
    ev_s = np.empty(cap, dtype=np.int64)
    ev_v = np.empty(cap)
    n_ev = 0
    for i in range(n):
        for ax in range(2):
            ev_r, ev_a, ev_s, ev_v, n_ev = _emit(ev_r, ev_a, ev_s, ev_v, n_ev, i, ax, 0, th0[i, ax])
    min_pair = np.inf
    min_tip = np.inf
    min_fid = np.inf
    n_guard = 0
    dD2 = D * D - d * d
    dDf2 = D_f * D_f - d_f * d_f
    tiny = 1e-6 * d * d
    tiny_f = 1e-6 * d_f * d_f
    k = 0
    stop = 2
    while True:
        _pose(base, th, la, P)
        # --- state statistics, convergence -------------------------------------------
        all_conv = True
        for i in range(n):
            tx = P[i, 4] + lb * P[i, 2]
            ty = P[i, 5] + lb * P[i, 3]
            for kk in range(nbr_ptr[i], nbr_ptr[i + 1]):
                j = nbr_idx[kk]
                if j <= i:
                    continue
                ux = P[j, 4] + lb * P[j, 2] - tx
                uy = P[j, 5] + lb * P[j, 3] - ty
                st = math.sqrt(ux * ux + uy * uy)
                if st < min_tip:
                    min_tip = st
                if segment:
                    s, _, _, _, _, _ = _pair(P, i, j, segment, lb, s0, s1)
                    if s < min_pair:
                        min_pair = s
                elif st < min_pair:
                    min_pair = st
            for kk in range(fid_ptr[i], fid_ptr[i + 1]):
                f = fid_idx[kk]
                s, _, _, _ = _fid(P, i, fid_xy[f, 0], fid_xy[f, 1], segment, lb, s0, s1)
                if s < min_fid:
                    min_fid = s
            if movable[i]:
                e = math.sqrt((tx - target_xy[i, 0]) ** 2 + (ty - target_xy[i, 1]) ** 2)
                err[i] = e
                if e < tol:
                    if settle[i] < 0:
                        settle[i] = k
                else:
                    settle[i] = -1
                    all_conv = False
        if all_conv:
            stop = 0
            break
        if k >= max_steps:
            stop = 2
            break
        if stall_steps > 0 and k > 0 and k % stall_steps == 0:
            net = 0.0
            for i in range(n):
                if movable[i]:
                    net = max(net, abs(th[i, 0] - ckpt[i, 0]), abs(th[i, 1] - ckpt[i, 1]))
                    ckpt[i, 0] = th[i, 0]
                    ckpt[i, 1] = th[i, 1]
            if net <= stall_rad:
                stop = 1
                break
        # --- velocities --------------------------------------------------------------
        for i in range(n):
            u[i, 0] = 0.0
            u[i, 1] = 0.0
            moved[i] = False
            if not movable[i]:
                continue
            tx = P[i, 4] + lb * P[i, 2]
            ty = P[i, 5] + lb * P[i, 3]
            gx = 2.0 * l1 * (tx - target_xy[i, 0])
            gy = 2.0 * l1 * (ty - target_xy[i, 1])
            if l3 > 0.0:   # Macktoobian Eq. 5: neighbours' remaining errors, as a vector field
                for kk in range(nbr_ptr[i], nbr_ptr[i + 1]):
                    j = nbr_idx[kk]
                    if nbr_coop[kk] and movable[j]:
                        gx += 2.0 * l3 * (P[j, 4] + lb * P[j, 2] - target_xy[j, 0])
                        gy += 2.0 * l3 * (P[j, 5] + lb * P[j, 3] - target_xy[j, 1])
            fa, fb = _jt(P, i, la, lb, -gx, -gy)
            sb = P[i, 2] * P[i, 1] - P[i, 3] * P[i, 0]     # sin(beta)
            if band_sin > 0.0 and abs(sb) < band_sin:
                cb = P[i, 2] * P[i, 0] + P[i, 3] * P[i, 1]  # cos(beta)
                rx = tx - base[i, 0]
                ry = ty - base[i, 1]
                rn = math.sqrt(rx * rx + ry * ry)
                if rn > 1e-9:
                    fr = -(gx * rx + gy * ry) / rn
                    helps = fr < 0.0 if cb > 0.0 else fr > 0.0
                else:
                    fr = math.sqrt(gx * gx + gy * gy)
                    helps = True
                if helps:
                    sgn = 1.0
                    if th_target[i, 1] < th[i, 1] or (th_target[i, 1] == th[i, 1] and cb < 0.0):
                        sgn = -1.0
                    fb += sgn * abs(fr) * lb * (1.0 - abs(sb) / band_sin)
            ua = fa
            ub = fb
            # repulsion from neighbours (sign-corrected Eq. 2)
            for kk in range(nbr_ptr[i], nbr_ptr[i + 1]):
                j = nbr_idx[kk]
                s, r, px, py, qx, qy = _pair(P, i, j, segment, lb, s0, s1)
                if s >= D:
                    continue
                q = s * s - d * d
                if q < tiny:
                    q = tiny
                w = 2.0 * l2 * dD2 / (q * q)
                vx = px - qx
                vy = py - qy
                if s < 1e-12:
                    vx = base[i, 0] - base[j, 0]
                    vy = base[i, 1] - base[j, 1]
                    nv = math.sqrt(vx * vx + vy * vy)
                    vx *= d / nv
                    vy *= d / nv
                ra, rb = _jt(P, i, la, r, w * vx, w * vy)
                ua += ra
                ub += rb
            for kk in range(fid_ptr[i], fid_ptr[i + 1]):
                f = fid_idx[kk]
                s, r, px, py = _fid(P, i, fid_xy[f, 0], fid_xy[f, 1], segment, lb, s0, s1)
                if s >= D_f:
                    continue
                q = s * s - d_f * d_f
                if q < tiny_f:
                    q = tiny_f
                w = 2.0 * l2 * dDf2 / (q * q)
                ra, rb = _jt(P, i, la, r, w * (px - fid_xy[f, 0]), w * (py - fid_xy[f, 1]))
                ua += ra
                ub += rb
            # alpha-axis rule: alpha moves the tip with gain r = |tip - base|; below
            # axis_r its push is scaled by (axis_r / r)^2 (capped at 100)
            if axis_r > 0.0:
                rx = tx - base[i, 0]
                ry = ty - base[i, 1]
                rn = max(math.sqrt(rx * rx + ry * ry), 0.1 * axis_r)
                if rn < axis_r:
                    ua *= (axis_r / rn) ** 2
            ua *= gain
            ub *= gain
            if implicit:
                # linearly implicit Euler in the attractive term: (I + 2 l1 dt J^T J) du = u
                c1x = -la * P[i, 1] - lb * P[i, 3]
                c1y = la * P[i, 0] + lb * P[i, 2]
                c2x = -lb * P[i, 3]
                c2y = lb * P[i, 2]
                h = 2.0 * l1 * dt * gain
                m11 = 1.0 + h * (c1x * c1x + c1y * c1y)
                m12 = h * (c1x * c2x + c1y * c2y)
                m22 = 1.0 + h * (c2x * c2x + c2y * c2y)
                det = m11 * m22 - m12 * m12
                ua, ub = (m22 * ua - m12 * ub) / det, (m11 * ub - m12 * ua) / det
            # saturation: scale both joints, keep the direction
            sat = max(1.0, abs(ua) / w_a, abs(ub) / w_b)
            u[i, 0] = ua / sat
            u[i, 1] = ub / sat
            moved[i] = u[i, 0] != 0.0 or u[i, 1] != 0.0
        # --- proposals, guard ----------------------------------------------------------
        for i in range(n):
            frac[i] = 1.0 if moved[i] else 0.0
        changed = True
        first = True
        while changed:
            changed = False
            for i in range(n):
                if first or frac[i] < 1.0:
                    a = th[i, 0] + frac[i] * dt * u[i, 0]
                    b = th[i, 1] + frac[i] * dt * u[i, 1]
                    if b < beta_lo:
                        b = beta_lo
                    elif b > beta_hi:
                        b = beta_hi
                    if clamp_alpha:
                        if a < alpha_lo:
                            a = alpha_lo
                        elif a > alpha_hi:
                            a = alpha_hi
                    prop[i, 0] = a
                    prop[i, 1] = b
            _pose(base, prop, la, Q)
            first = False
            if not guard:
                break
            for i in range(n):
                if frac[i] == 0.0:
                    continue
                bad = False
                for kk in range(nbr_ptr[i], nbr_ptr[i + 1]):
                    j = nbr_idx[kk]
                    s, _, _, _, _, _ = _pair(Q, i, j, segment, lb, s0, s1)
                    if s <= d:
                        bad = True
                        if frac[j] > 0.0:
                            frac[j] = frac[j] * 0.5 if frac[j] > 0.5 ** GUARD_HALVINGS else 0.0
                        break
                if not bad:
                    for kk in range(fid_ptr[i], fid_ptr[i + 1]):
                        f = fid_idx[kk]
                        s, _, _, _ = _fid(Q, i, fid_xy[f, 0], fid_xy[f, 1], segment, lb, s0, s1)
                        if s <= d_f:
                            bad = True
                            break
                if bad:
                    frac[i] = frac[i] * 0.5 if frac[i] > 0.5 ** GUARD_HALVINGS else 0.0
                    changed = True
                    n_guard += 1
            if changed:
                for i in range(n):
                    if frac[i] == 0.0:
                        prop[i, 0] = th[i, 0]
                        prop[i, 1] = th[i, 1]
        # --- commit and record -----------------------------------------------------------
        k += 1
        for i in range(n):
            th[i, 0] = prop[i, 0]
            th[i, 1] = prop[i, 1]
            for ax in range(2):
                v = th[i, ax]
                if v < th_min[i, ax]:
                    th_min[i, ax] = v
                if v > th_max[i, ax]:
                    th_max[i, ax] = v
                span = k - anc_k[i, ax]
                sl = (v - anc_v[i, ax]) / span
                if lo[i, ax] <= sl <= hi[i, ax]:
                    lo[i, ax] = max(lo[i, ax], (v - simp_tol - anc_v[i, ax]) / span)
                    hi[i, ax] = min(hi[i, ax], (v + simp_tol - anc_v[i, ax]) / span)
                else:
                    ev_r, ev_a, ev_s, ev_v, n_ev = _emit(ev_r, ev_a, ev_s, ev_v, n_ev, i, ax, k - 1,
                                                         last_v[i, ax])
                    anc_k[i, ax] = k - 1
                    anc_v[i, ax] = last_v[i, ax]
                    lo[i, ax] = v - simp_tol - last_v[i, ax]
                    hi[i, ax] = v + simp_tol - last_v[i, ax]
                last_v[i, ax] = v
    for i in range(n):
        for ax in range(2):
            ev_r, ev_a, ev_s, ev_v, n_ev = _emit(ev_r, ev_a, ev_s, ev_v, n_ev, i, ax, k, th[i, ax])
    stats = np.array([min_pair, min_tip, min_fid, float(n_guard)])
    return k, stop, th, ev_r, ev_a, ev_s, ev_v, n_ev, stats, settle, err, th_min, th_max


# =====================================================================================
# Results
# =====================================================================================
@dataclass
class ApfResult:
    """Outcome of one :func:`plan_apf` / :func:`planners.capf.plan_capf` run.

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
        beta-segment distance), mm (inf without pairs).
    min_tip_distance_mm, min_fiducial_distance_mm : float
        Smallest tip-tip and robot(model)-fiducial-centre distance seen, mm.
    d_mm, D_mm, d_fid_mm, D_fid_mm, margin_mm : float, resolved distances
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
        """The solver's metric keys (planners.solver.plan_reconfiguration) plus APF ones.

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
    """A :class:`planners.plan.Plan` on the Euler step clock (``step_s = dt``).

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


# =====================================================================================
# Driver
# =====================================================================================
def _neighbours(geom: ArrayGeometry, settings: ApfSettings, D: float, D_f: float):
    """CSR of pairs that can come within D (and fiducials within D_f), coop mask."""
    spec = geom.spec
    lay = geom.layout
    if settings.model == "tip":
        r_arm = spec.alpha_length_mm + spec.beta_length_mm
    else:
        r_arm = spec.alpha_length_mm + max(spec.segment_start_mm,
                                           float(geom.seg_end.max()) if geom.n_robots else 0.0)
    coop_r = settings.coop_radius_mm
    if coop_r is None:
        coop_r = 1.2 * nearest_spacing_mm(geom)
    ptr, idx = lay.neighbour_csr(max(2.0 * r_arm + D, float(coop_r)))
    ptr = np.asarray(ptr, dtype=np.int64)
    idx = np.asarray(idx, dtype=np.int64)
    owner = np.repeat(np.arange(geom.n_robots), np.diff(ptr))
    dist = np.hypot(*(geom.base_xy[owner] - geom.base_xy[idx]).T) if idx.size else np.empty(0)
    coop = np.asarray(dist <= float(coop_r), dtype=np.bool_)
    fptr, fidx = lay.robot_fiducial_csr(r_arm + D_f)
    return (ptr, idx, coop, np.asarray(fptr, dtype=np.int64), np.asarray(fidx, dtype=np.int64),
            float(coop_r))


def nearest_spacing_mm(geom: ArrayGeometry) -> float:
    """Median over robots of the distance to the nearest other robot base, mm."""
    if geom.n_robots < 2:
        return float(geom.spec.pitch_mm)
    from scipy.spatial import cKDTree

    dist, _ = cKDTree(geom.base_xy).query(geom.base_xy, k=2)
    return float(np.median(dist[:, 1]))


@njit(cache=True)
def _start_violation(base, th, la, lb, s0, s1, segment, nbr_ptr, nbr_idx, fid_ptr, fid_idx,
                     fid_xy, d, d_f, movable_only_mask):
    """First (i, j_or_-1-f, s) with s <= threshold at configuration th, or (-1, 0, inf)."""
    n = base.shape[0]
    P = np.empty((n, 6))
    _pose(base, th, la, P)
    for i in range(n):
        for kk in range(nbr_ptr[i], nbr_ptr[i + 1]):
            j = nbr_idx[kk]
            if j <= i or not (movable_only_mask[i] or movable_only_mask[j]):
                continue
            s, _, _, _, _, _ = _pair(P, i, j, segment, lb, s0, s1)
            if s <= d:
                return i, j, s
        if movable_only_mask[i]:
            for kk in range(fid_ptr[i], fid_ptr[i + 1]):
                f = fid_idx[kk]
                s, _, _, _ = _fid(P, i, fid_xy[f, 0], fid_xy[f, 1], segment, lb, s0, s1)
                if s <= d_f:
                    return i, -1 - f, s
    return -1, 0, np.inf


def _check_angles(geom: ArrayGeometry, angles, what: str) -> np.ndarray:
    a = np.asarray(angles, dtype=np.float64)
    if a.shape != (geom.n_robots, 2):
        raise TargetError(f"{what}: shape {a.shape}; allowed: ({geom.n_robots}, 2) (one (alpha, "
                          "beta) row per robot, deg)")
    spec = geom.spec
    for axis, col, (lo, hi) in (("alpha", 0, spec.alpha_limits_deg), ("beta", 1, spec.beta_limits_deg)):
        v = a[:, col]
        bad = np.flatnonzero(~np.isfinite(v) | (v < lo) | (v > hi))
        if bad.size:
            k = int(bad[0])
            raise TargetError(f"{what}: robot {int(geom.robot_ids[k])}: field '{axis}' = "
                              f"{float(v[k])!r}; allowed: [{lo}, {hi}] deg")
    return a


def plan_apf(geom: ArrayGeometry, start, targets, settings: ApfSettings | None = None,
             movable=None, *, record: bool = True, algorithm: str = "apf") -> ApfResult:
    """Plan from ``start`` straight to ``targets`` with the navigation function.

    Parameters
    ----------
    geom : ArrayGeometry
        Layout, spec and buffer (the buffer matters in segment mode only).
    start, targets : (n, 2) float, deg
        (alpha, beta) per robot, within the spec's limits. Rows of robots that cannot
        move are ignored in ``targets``.
    settings : ApfSettings (default: the paper's tip model)
    movable : (n,) bool, optional
        False for offline robots (they stay at ``start`` and repel their neighbours).
    record : bool
        Build the Trajectory (False: only the figures, for benchmarks).
    algorithm : label stored in the result ("apf"; :mod:`planners.capf` passes "capf").

    Returns
    -------
    ApfResult

    Targets closer than about ``d + 1`` mm (tip model; the equilibrium of attraction
    and repulsion) cannot be reached within 100 um, and targets within ``d`` never:
    those robots end not converged. :func:`random_tip_configs` and
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
    start = _check_angles(geom, start, "start")
    targets = _check_angles(geom, targets, "targets").copy()
    mov = np.ones(n, dtype=bool) if movable is None else np.asarray(movable, dtype=bool).copy()
    if mov.shape != (n,):
        raise TargetError(f"movable: shape {mov.shape}; allowed: ({n},) bool")
    targets[~mov] = start[~mov]
    d, D, d_f, D_f, margin = settings.distances(geom)
    wa_deg, wb_deg = settings.speeds_deg_s(geom)
    ptr, idx, coop, fptr, fidx, _ = _neighbours(geom, settings, D, D_f)
    la, lb = spec.alpha_length_mm, spec.beta_length_mm
    s0 = spec.segment_start_mm
    s1 = float(geom.seg_end[0]) if n else spec.segment_end()
    segment = settings.model == "segment"
    fid_xy = np.ascontiguousarray(geom.fid_xy, dtype=np.float64).reshape(-1, 2)
    th0 = np.ascontiguousarray(start * DEG)
    i, j, s = _start_violation(geom.base_xy, th0, la, lb, s0, s1, segment, ptr, idx, fptr, fidx,
                               fid_xy, d, d_f, mov)
    if i >= 0:
        what = "tips" if not segment else "beta segments"
        if j >= 0:
            raise TargetError(f"start: robots {int(geom.robot_ids[i])} and {int(geom.robot_ids[j])}: "
                              f"{what} {s:.4f} mm apart; allowed: > d = {d:.4f} mm")
        raise TargetError(f"start: robot {int(geom.robot_ids[i])}: {s:.4f} mm from fiducial "
                          f"{int(geom.fiducial_ids[-1 - j])}; allowed: > {d_f:.4f} mm")
    target_xy, _ = forward(geom.base_xy, np.ascontiguousarray(targets), la, lb)
    dt = settings.dt_s
    max_steps = int(math.ceil(settings.max_time_s / dt - 1e-9))
    stall_steps = max(1, int(round(settings.stall_window_s / dt)))
    blo, bhi = spec.beta_limits_deg
    alo, ahi = spec.alpha_limits_deg
    t0 = time.perf_counter()
    (k, stop, th, ev_r, ev_a, ev_s, ev_v, n_ev, stats, settle, err, th_min, th_max) = run_apf(
        geom.base_xy, th0, np.ascontiguousarray(targets * DEG), np.ascontiguousarray(target_xy),
        mov, ptr, idx, coop, fptr, fidx, fid_xy, la, lb, s0, s1, segment, d, D, d_f, D_f,
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
        traj, tol_used = _trajectory(geom.robot_ids, ev_r[:n_ev], ev_a[:n_ev], ev_s[:n_ev],
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


def _trajectory(robot_ids, ev_r, ev_a, ev_s, ev_v, n, dt, settings):
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


def offline_mask(geom: ArrayGeometry, start: np.ndarray,
                 offline: dict[int, tuple[float, float]] | None) -> tuple[np.ndarray, np.ndarray]:
    """(start with offline rows set, movable mask) from ``{robot_id: (alpha, beta)}``."""
    start = np.array(start, dtype=np.float64, copy=True)
    movable = np.ones(geom.n_robots, dtype=bool)
    for rid, ang in (offline or {}).items():
        hits = np.flatnonzero(geom.robot_ids == int(rid))
        if hits.size == 0:
            raise UnknownRobotError(f"offline robot {rid}: unknown robot id; allowed ids: "
                                    f"{int(geom.robot_ids.min())}..{int(geom.robot_ids.max())}")
        movable[hits[0]] = False
        start[hits[0]] = ang
    return start, movable


def plan_apf_reconfiguration(geom: ArrayGeometry, targets, settings: ApfSettings | None = None, *,
                             start=None, offline: dict[int, tuple[float, float]] | None = None,
                             algorithm: str = "apf") -> tuple[Plan, ApfResult]:
    """CLI-shaped entry: plan from the folded state (or ``start``) to ``targets``.

    Like :func:`planners.solver.plan_reconfiguration` but direct (forward), single run,
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
    """
    n = geom.n_robots
    if start is None:
        start = np.tile(np.asarray(geom.spec.fold_deg, dtype=np.float64), (n, 1))
    start, movable = offline_mask(geom, start, offline)
    targets = np.array(targets, dtype=np.float64, copy=True)
    if targets.shape == (n, 2):
        targets[~movable] = start[~movable]
    result = plan_apf(geom, start, targets, settings, movable, algorithm=algorithm)
    return apf_plan(result), result


def apf_target_margin_mm(geom: ArrayGeometry, settings: ApfSettings) -> float:
    """Clearance beyond Eq. 3 (segment mode) that targets need so the barrier allows them.

    Pass it as ``margin_mm`` to :func:`planners.targets.random_targets`. In tip mode the
    capsule clearance does not bound the tip distance; use :func:`random_tip_configs`.
    """
    d, D, _, _, _ = settings.distances(geom)
    if settings.model == "segment":
        return max(0.0, d - 2.0 * geom.buffer_mm)
    return 0.0


# =====================================================================================
# Random tip configurations (Makarem 2014 Sect. 6: random starts and targets)
# =====================================================================================
@njit(cache=True)
def _assign_tips(base, pool, fixed, out, nbr_ptr, nbr_idx, fid_ptr, fid_idx, fid_xy, la, lb,
                 sep, fid_sep):
    """For each robot in order, the first pool entry whose tip is > sep from the tips of
    robots already placed and > fid_sep from fiducial centres. Returns the first robot
    without a fit, or -1."""
    n = base.shape[0]
    placed = fixed.copy()
    for i in range(n):
        if fixed[i]:
            continue
        ok_any = False
        for c in range(pool.shape[1]):
            a = pool[i, c, 0] * DEG
            b = pool[i, c, 1] * DEG
            tx = base[i, 0] + la * math.cos(a) + lb * math.cos(a + b)
            ty = base[i, 1] + la * math.sin(a) + lb * math.sin(a + b)
            ok = True
            for kk in range(nbr_ptr[i], nbr_ptr[i + 1]):
                j = nbr_idx[kk]
                if not placed[j]:
                    continue
                aj = out[j, 0] * DEG
                bj = out[j, 1] * DEG
                ux = base[j, 0] + la * math.cos(aj) + lb * math.cos(aj + bj) - tx
                uy = base[j, 1] + la * math.sin(aj) + lb * math.sin(aj + bj) - ty
                if ux * ux + uy * uy <= sep * sep:
                    ok = False
                    break
            if ok:
                for kk in range(fid_ptr[i], fid_ptr[i + 1]):
                    f = fid_idx[kk]
                    if (fid_xy[f, 0] - tx) ** 2 + (fid_xy[f, 1] - ty) ** 2 <= fid_sep * fid_sep:
                        ok = False
                        break
            if ok:
                out[i, 0] = pool[i, c, 0]
                out[i, 1] = pool[i, c, 1]
                placed[i] = True
                ok_any = True
                break
        if not ok_any:
            return i
    return -1


def random_tip_configs(geom: ArrayGeometry, rng: np.random.Generator, min_sep_mm: float, *,
                       fixed=None, initial=None, pool: int = 256, attempts: int = 20) -> np.ndarray:
    """Seeded random right-armed configurations whose fiber tips are > min_sep_mm apart.

    Tips uniform (by area) in the patrol annulus; robots are placed in index order, each
    taking its first draw clear of the tips already placed and of the fiducial disks
    (``min_sep_mm / 2 + fiducial_buffer_mm``). Only the tips are considered: this is the
    tip model of Makarem 2014, whose targets are "at least d apart".

    Parameters
    ----------
    geom : ArrayGeometry
    rng : numpy Generator
    min_sep_mm : float > 0
    fixed : (n,) bool, rows of ``initial`` to keep (offline robots)
    initial : (n, 2) deg
    pool, attempts : draws per robot, whole-draw restarts

    Returns
    -------
    (n, 2) float64 deg

    Raises
    ------
    TargetError
        When no clear spot is found for some robot in ``attempts`` draws.
    """
    sep = _num(min_sep_mm, "min_sep_mm", 0.0, 1e3, "(0, 1000] mm", where="random_tip_configs")
    spec = geom.spec
    n = geom.n_robots
    la, lb = spec.alpha_length_mm, spec.beta_length_mm
    ptr, idx = geom.layout.neighbour_csr(2.0 * (la + lb) + sep)
    fsep = sep / 2.0 + spec.fiducial_buffer_mm
    fptr, fidx = geom.layout.robot_fiducial_csr(la + lb + fsep)
    fix = np.zeros(n, dtype=bool) if fixed is None else np.asarray(fixed, dtype=bool)
    bad = -1
    for _ in range(max(1, attempts)):
        out = np.zeros((n, 2)) if initial is None else np.array(initial, dtype=np.float64)
        draws = sample_patrol_zone(rng, n * pool, la, lb).reshape(n, pool, 2)
        bad = _assign_tips(geom.base_xy, draws, fix, out, np.asarray(ptr, dtype=np.int64),
                           np.asarray(idx, dtype=np.int64), np.asarray(fptr, dtype=np.int64),
                           np.asarray(fidx, dtype=np.int64),
                           np.ascontiguousarray(geom.fid_xy, dtype=np.float64).reshape(-1, 2),
                           la, lb, sep, fsep)
        if bad < 0:
            return out
    raise TargetError(f"robot {int(geom.robot_ids[bad])}: no random tip position > {sep} mm from "
                      f"its neighbours' in {attempts} x {pool} draws; allowed: a smaller "
                      "'min_sep_mm'")
