"""Parameters of the potential-field planners and the distances they resolve to.

:class:`ApfSettings` holds every parameter of the navigation-function planner (Makarem
et al. 2014) and, through ``lambda3``, of its cooperative variant (Macktoobian et al.
2019, :class:`rfp_twin.planners.fields.capf.CapfSettings`). Units: mm, deg, s.

Collision models
----------------
``"tip"`` (Makarem 2014): fiber tips are points; pairs repel on the tip distance,
defaults ``d = 2``, ``D = 4`` mm (DESI, Makarem 2014 Table 3). A fiducial is a disk of
radius ``spec.fiducial_buffer_mm`` that the tip (radius ``d / 2``) must not touch.

``"segment"`` (Sayres et al. 2021, Eq. 3): the beta collision segment of each robot
(``segment_start_mm .. segment_end`` along the beta arm). ``s`` is the segment distance.
Default ``d = 2 buffer + margin``, ``D = d + 2`` mm. The margin (default
:func:`default_margin_mm`) covers the motion between two Euler steps and the
simplification tolerance, so that a trajectory whose sampled distances are all ``> d``
passes the dense capsule check (validation/checker2d/) at ``buffer``: two points of
two arms move at most ``V dt`` closer between samples, ``V = l_alpha w_a + r_max (w_a +
w_b)`` (rad/s speeds). Fiducials: point-segment distance, ``d_fid = buffer +
fiducial_buffer + margin``. (If an axis needed more than ``max_points`` breakpoints, its
tolerance was raised: ``ApfResult.simplify_tol_used_deg``; above ``simplify_tol_deg``
the margin no longer covers it and the trajectory should be checked, as the CLI always
does.)

In both models ``D_fid = d_fid + (D - d)``.

Per-robot geometry (:class:`rfp_twin.models.array.ArrayGeometry`: each robot's alpha
length, beta segment and buffer, each obstacle's shape and keep-out radius): the
distances above are the nominal ones (run buffer, spec fiducial buffer). A pair uses
``d + ex_i + ex_j`` (and ``D`` likewise), robot i and obstacle f ``d_fid + ex_i + fex_f``,
with ``ex = buffer - buffer_mm`` (segment model; 0 in the tip model, whose tips are
points) and ``fex = fid_buffer - fiducial_buffer_mm`` (:func:`buffer_excess`). Bounds
that depend on an arm length (the margin's speed, neighbour reach) take the largest over
the robots.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rfp_twin.models.array import ArrayGeometry, obstacles_within
from rfp_twin.models.errors import SpecError, field_error

DEG = math.pi / 180.0
#: Collision models of :class:`ApfSettings`.
MODELS = ("tip", "segment")
#: Makarem 2014 Table 3 / Table 4 defaults.
TIP_D_MM = 2.0
TIP_ENVELOPE_MM = 4.0
#: Default envelope width ``D - d`` in segment mode (the paper's 4 - 2 mm), mm.
SEGMENT_ENVELOPE_MM = 2.0
#: Safety added to the computed segment-mode margin, mm.
MARGIN_SAFETY_MM = 0.005


def checked_number(value, name: str, lo: float, hi: float, allowed: str, lo_open=True,
                   hi_open=False, where="ApfSettings") -> float:
    """``value`` as a float when finite and within (lo, hi) (``lo_open`` / ``hi_open``:
    whether each end is excluded); else the SpecError of field ``name`` of ``where``."""
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
        Cooperative weight (Macktoobian 2019, Eq. 5); 0 = plain APF.
        :class:`rfp_twin.planners.fields.capf.CapfSettings` sets it; here it must be in [0, lambda1).
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
        Linearly implicit Euler step in the attractive term (see
        :mod:`rfp_twin.planners.fields.kernel`); False = plain explicit Euler as in the paper.
    guard : bool
        Halve/cancel steps that would bring a pair within ``d`` (see
        :mod:`rfp_twin.planners.fields.kernel`).
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
        l1 = checked_number(self.lambda1, "lambda1", 0.0, 1000.0, "(0, 1000]")
        checked_number(self.lambda2, "lambda2", 0.0, 1000.0, "(0, 1000]")
        checked_number(self.gain, "gain", 0.0, 1000.0, "(0, 1000] 1/s")
        checked_number(self.lambda3, "lambda3", 0.0, l1, f"[0, lambda1 = {l1}) (Macktoobian: lambda3 < "
             "lambda1)", lo_open=False, hi_open=True)
        if self.d_mm is not None:
            checked_number(self.d_mm, "d_mm", 0.0, 100.0, "(0, 100] mm")
        if self.D_mm is not None:
            lo = float(self.d_mm) if self.d_mm is not None else 0.0
            checked_number(self.D_mm, "D_mm", lo, 100.0, f"({lo}, 100] mm (D > d)")
        if self.margin_mm is not None:
            checked_number(self.margin_mm, "margin_mm", 0.0, 10.0, "[0, 10] mm", lo_open=False)
        checked_number(self.dt_s, "dt_s", 0.0, 0.1, "(0, 0.1] s")
        checked_number(self.tol_mm, "tol_mm", 0.0, 10.0, "(0, 10] mm")
        checked_number(self.max_time_s, "max_time_s", 0.0, 3600.0, "(0, 3600] s")
        if self.speed_deg_s is not None:
            sp = tuple(self.speed_deg_s)
            if len(sp) != 2:
                raise field_error(SpecError, "speed_deg_s", self.speed_deg_s,
                                  "(alpha, beta) deg/s, each in (0, 3600]", "ApfSettings")
            for v in sp:
                checked_number(v, "speed_deg_s", 0.0, 3600.0, "(alpha, beta) deg/s, each in (0, 3600]")
        checked_number(self.singular_band_deg, "singular_band_deg", 0.0, 45.0, "[0, 45] deg", lo_open=False)
        checked_number(self.axis_radius_mm, "axis_radius_mm", 0.0, 100.0, "[0, 100] mm", lo_open=False)
        checked_number(self.stall_window_s, "stall_window_s", 0.0, 600.0, "(0, 600] s")
        checked_number(self.stall_deg, "stall_deg", 0.0, 10.0, "[0, 10] deg", lo_open=False)
        checked_number(self.simplify_tol_deg, "simplify_tol_deg", 0.0, 1.0, "(0, 1] deg")
        if isinstance(self.max_points, bool) or not isinstance(self.max_points, (int, np.integer)) \
                or self.max_points < 2:
            raise field_error(SpecError, "max_points", self.max_points, "an integer >= 2",
                              "ApfSettings")
        if self.coop_radius_mm is not None:
            checked_number(self.coop_radius_mm, "coop_radius_mm", 0.0, 1e4, "(0, 1e4] mm")

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
    With per-robot geometry ``l_alpha`` and ``r_max`` are the largest over the robots.
    """
    spec = geom.spec
    wa, wb = (v * DEG for v in settings.speeds_deg_s(geom))
    n = geom.n_robots
    rmax = max(float(geom.seg_end.max()) if n else spec.beta_length_mm,
               float(geom.seg_start.max()) if n else spec.segment_start_mm)
    la = float(geom.alpha_len.max()) if n else spec.alpha_length_mm
    v = la * wa + rmax * (wa + wb)
    simp = 2.0 * (la + rmax) * settings.simplify_tol_deg * DEG
    return v * settings.dt_s + simp + MARGIN_SAFETY_MM


def buffer_excess(geom: ArrayGeometry, model: str) -> tuple[np.ndarray, np.ndarray]:
    """Each body's buffer beyond the nominal one that its thresholds add, mm.

    Returns ``(ex, fex)``: (n,) ``geom.buffer - geom.buffer_mm`` in the segment model
    (zeros in the tip model: tips are points) and (m,) ``geom.fid_buffer -
    spec.fiducial_buffer_mm``. Both are exactly 0 on a nominal layout.
    """
    if model == "segment":
        ex = np.ascontiguousarray(geom.buffer - float(geom.buffer_mm), dtype=np.float64)
    else:
        ex = np.zeros(geom.n_robots)
    fex = np.ascontiguousarray(geom.fid_buffer - geom.spec.fiducial_buffer_mm, dtype=np.float64)
    return ex, fex


def obstacle_csr(geom: ArrayGeometry, reach_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """Obstacles near each robot base, CSR ``(ptr (n + 1,), idx)`` int64, ascending.

    Obstacle f is listed for robot i when the distance from i's base to the obstacle
    (its segment ``fid_xy[f]``-``fid_end_xy[f]``, a point for a fiducial) is within
    ``reach_mm + fid_buffer[f] - spec.fiducial_buffer_mm`` mm. Point obstacles at the
    spec's buffer use the layout's own query (:meth:`Layout.robot_fiducial_csr`).
    """
    a, b = geom.fid_xy, geom.fid_end_xy
    fex = geom.fid_buffer - geom.spec.fiducial_buffer_mm
    if np.all(a == b) and np.all(fex == 0.0):
        ptr, idx = geom.layout.robot_fiducial_csr(float(reach_mm))
        return np.asarray(ptr, dtype=np.int64), np.asarray(idx, dtype=np.int64)
    ptr, idx = obstacles_within(geom.base_xy, a, b, float(reach_mm) + fex)
    return np.asarray(ptr, dtype=np.int64), np.asarray(idx, dtype=np.int64)
