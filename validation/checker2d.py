"""Independent dense 2D collision check of a :class:`models.trajectory.Trajectory`.

The collision model is the capsule model of Sayres 2021 (Eq. 3). Robot ``i`` with base
``b_i``, alpha ``a`` and beta ``b`` (degrees) has its beta collision body on the segment

    P_i(r, t) = b_i + l_alpha (cos a, sin a) + r (cos(a + b), sin(a + b)),
    r in [segment_start_mm, spec.segment_end(buffer)]

Robots ``i, j`` collide when the segment distance ``D_ij(t) <= buffer_i + buffer_j``.
A fiducial is a disk of radius ``spec.fiducial_buffer_mm``; robot ``i`` collides with
it when the point-segment distance ``<= buffer_i + fiducial_buffer_mm``. Only pairs
whose bases are within ``2 (l_alpha + r_max + buffer)`` (robot pairs) or
``l_alpha + r_max + buffer + fiducial_buffer`` (robot-fiducial) can touch,
``r_max = max(segment_start, segment_end)``; the candidate pairs are found here with
a k-d tree, not with the planner's neighbour lists.

Independence
------------
This module imports only ``models.robot``, ``models.layout``, ``models.errors`` and the
data type ``models.trajectory``. Its segment distance is its own: the closest points
of the two segments are found from the parameters ``(s, t)`` of the supporting lines,
clamped to ``[0, 1]`` and re-projected (the formulation of Ericson, *Real-Time Collision
Detection*, Sect. 5.1.9), written afresh here with 2D cross products for the line
parameter so that nearly parallel segments stay exact. The planner's kernel
(:mod:`models.geometry2d`) instead tests for a proper crossing and then takes the
smallest of four endpoint-to-segment distances; the two share no code.

Why no collision can slip between samples
-----------------------------------------
*Speed bound.* Differentiating ``P_i(r, t)`` (angles in radians)::

    dP/dt = l_alpha a' n(a) + r (a' + b') n(a + b),   |n| = 1
    |dP/dt| <= l_alpha |a'| + r_max (|a'| + |b'|) =: V_i

The trajectory is piecewise linear, so on any time window ``|a'|`` and ``|b'|`` are at
most the largest slope ``A_i`` / ``B_i`` of the breakpoint segments that overlap the
window (zero outside a robot's time range, where it holds its first/last angle). So
every material point of the collision segment moves at most ``V_i = l_alpha A_i +
r_max (A_i + B_i)`` mm/s. The bound comes from the trajectory itself, not from the spec
speed. A jump (two breakpoints at the same time with different angles) has no finite
bound and is rejected with :class:`models.errors.TrajectoryError`.

*Lipschitz distance.* Let ``(r*, q*)`` be the closest material points at time ``t'``.
Then ``D(t) <= |P_i(r*, t) - P_j(q*, t)| <= D(t') + (V_i + V_j) |t - t'|``, and the same
with ``t, t'`` swapped: ``D`` is Lipschitz with ``L = V_i + V_j`` (``V_j = 0`` for a
fiducial).

*Interval bound.* On ``[t0, t1]``, ``h = t1 - t0``, with sampled ``D0 = D(t0)`` and
``D1 = D(t1)``: ``D(t) >= max(D0 - L (t - t0), D1 - L (t1 - t))``. The right side is
smallest where the two lines cross, so for every ``t`` in the interval::

    D(t) >= (D0 + D1 - L h) / 2 =: lb

If ``lb > threshold`` the whole interval is provably clear.

Algorithm (per candidate pair)
------------------------------
1. Coarse grid. The uniform grid on ``[T0, T1]`` (``T0 = min(0, first breakpoint)``,
   ``T1 = trajectory.duration``; both ends included) has ``n = ceil((T1 - T0) L_m /
   (2 buffer))`` intervals, i.e. spacing ``h0 <= 2 buffer / L_m``, where ``L_m =
   Vm_i + Vm_j`` is the pair's speed bound with each axis' *mean* |slope| over the
   span (travel / duration) in place of its largest. Where the robots move at their
   typical speed the largest slack of the bound, ``L h0 / 2``, is then at most one
   buffer, so an interval whose two ends are both at least one buffer clear of the
   threshold is cleared at once. Using the mean rather than the largest slope keeps
   one fast blip of one robot from forcing a fine grid over the whole span: the
   bisection below adapts to it locally. Static pairs get one interval; ``n`` is
   capped at ``(T1 - T0) / resolution_s``. The grid only sets where refinement
   starts; the guarantee below does not depend on it.
2. Bisection (in time order, depth first). An interval whose two ends are clear is
   bisected while its bound ``lb`` (computed first with the largest speeds of the
   whole trajectory, ``L_g = V_i + V_j``, and, when that does not clear it, with the
   *local* speeds of the window, which are never larger) is ``<= threshold``; once it is no longer than
   ``resolution_s`` and still not cleared it is reported as a collision anyway
   (``Collision.conservative = True``; its ``min_distance_mm`` is then the bound
   ``max(lb, 0)``). An interval with one colliding end is bisected down to
   ``resolution_s`` to locate the start/end of the collision. An interval whose two
   ends collide is bisected (down to ``resolution_s``) only while the mirror upper
   bound ``(D0 + D1 + L h) / 2`` exceeds the threshold, i.e. while a brief exit from
   collision inside it cannot be ruled out; otherwise it is in collision throughout.
3. Minimum refinement. A clear interval is also bisected while ``lb < best - tol``,
   ``tol = distance_tol_mm + distance_rel_tol * max(best - threshold, 0)`` (``best``:
   the pair's smallest sampled distance so far). ``best`` only decreases, so every
   interval that is left has ``lb >= best_final - tol``: the reported per-pair minimum
   (the smallest *sampled* distance, an upper bound of the true one) is within ``tol``
   of the true minimum (up to ``L resolution_s / 2`` where the resolution limit
   stopped the bisection). Pairs near the threshold are thus exact to about
   ``distance_tol_mm`` (``min_clearance_mm`` to ``distance_tol_mm +
   distance_rel_tol * min_clearance_mm``); far pairs, whose distance may stay flat
   for long stretches, are not refined needlessly.

Colliding samples and colliding intervals of a pair that are at most ``resolution_s``
apart are merged into one :class:`Collision` with ``t_start`` / ``t_end`` the first /
last colliding sample (or the ends of a conservative interval), accurate to
``resolution_s``. ``conservative`` is set only when no sample of the run collided.

All heavy work is numba ``@njit(cache=True)`` on plain arrays: the trajectory becomes
per-axis CSR arrays (``ptr``, times, angles in radians, |slope| per breakpoint segment
in rad/s) and is interpolated inside the kernel with a binary search per robot.

Robots of the layout that the trajectory does not list are not checked. Units: mm,
degrees, seconds at the public boundary.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
from numba import njit
from scipy.spatial import cKDTree

from models.errors import SpecError, TrajectoryError, field_error
from models.layout import Layout
from models.robot import RobotSpec
from models.trajectory import AXES, Trajectory

__all__ = [
    "Collision",
    "CheckReport",
    "check_trajectory",
    "segment_distance_np",
    "speed_bounds_mm_s",
    "coarse_grid",
]

#: Squared length (mm^2) below which a segment is treated as a point.
_POINT_EPS2 = 1e-24
#: |u x v| / (|u| |v|) (sine of the angle) below which two segments are parallel.
_PARALLEL_EPS = 1e-12
#: Upper bound on coarse intervals per pair (memory guard; refinement keeps it safe).
_MAX_COARSE = 10_000_000
#: Depth of the bisection stack (halving from at most the whole span to resolution_s).
_STACK = 256
#: Tolerance added to pair reaches so that ``distance == reach`` counts, mm.
_REACH_TOL_MM = 1e-9


# =====================================================================================
# Reports
# =====================================================================================
@dataclass
class Collision:
    """One contiguous time interval in which a pair is in collision.

    Attributes
    ----------
    kind : str
        ``"robot"`` (robot-robot) or ``"fiducial"`` (robot-fiducial).
    robot_a : int
        Robot id.
    other : int
        The other robot's id, or the fiducial id.
    t_start, t_end : float
        First and last colliding sample of the interval, s (for a conservative
        interval: its ends).
    t_min : float
        Time of the smallest distance found in the interval, s.
    min_distance_mm : float
        Smallest centre-line (segment) distance found in the interval, mm; for a
        conservative interval the lower bound ``max(lb, 0)``.
    threshold_mm : float
        ``buffer_i + buffer_j`` (or ``buffer_i + fiducial_buffer_mm``), mm.
    conservative : bool
        True when no sample collided but the bound could not clear an interval of
        length ``<= resolution_s`` (a grazing contact reported to be safe).
    """

    kind: str
    robot_a: int
    other: int
    t_start: float
    t_end: float
    t_min: float
    min_distance_mm: float
    threshold_mm: float
    conservative: bool = False

    def to_dict(self) -> dict:
        return {"kind": self.kind, "robot_a": int(self.robot_a), "other": int(self.other),
                "t_start": float(self.t_start), "t_end": float(self.t_end),
                "t_min": float(self.t_min), "min_distance_mm": float(self.min_distance_mm),
                "threshold_mm": float(self.threshold_mm), "conservative": bool(self.conservative)}


@dataclass
class CheckReport:
    """Result of :func:`check_trajectory`.

    Attributes
    ----------
    buffer_mm : float
    n_robots : int
        Robots in the trajectory.
    n_pairs, n_fiducial_pairs : int
        Candidate robot-robot and robot-fiducial pairs checked.
    duration_s : float
        Length of the checked time span ``[T0, T1]``, s.
    n_samples : int
        Pair distances evaluated in all (coarse grid + refinement).
    pair_ids : (p, 2) int64
        Robot ids of the checked robot pairs.
    pair_min_distance_mm : (p,) float64
        Smallest sampled segment distance per robot pair, mm.
    fiducial_pair_ids : (q, 2) int64
        ``(robot id, fiducial id)``.
    fiducial_min_distance_mm : (q,) float64
    min_clearance_mm : float
        Smallest ``distance - threshold`` over all pairs (and conservative collision
        bounds); ``> 0`` means clear, ``inf`` when there is no pair.
    collisions : list of Collision
        Sorted by ``t_start``.
    seconds : float
        Wall time of the check (includes numba compilation on a first call), s.
    """

    buffer_mm: float
    n_robots: int
    n_pairs: int
    n_fiducial_pairs: int
    duration_s: float
    n_samples: int
    pair_ids: np.ndarray
    pair_min_distance_mm: np.ndarray
    fiducial_pair_ids: np.ndarray
    fiducial_min_distance_mm: np.ndarray
    min_clearance_mm: float
    collisions: list[Collision] = field(default_factory=list)
    seconds: float = 0.0

    @property
    def ok(self) -> bool:
        """True when no collision was found."""
        return not self.collisions

    def to_dict(self) -> dict:
        """JSON-serialisable summary (``inf`` becomes ``None``)."""
        def num(x: float):
            x = float(x)
            return x if math.isfinite(x) else None

        return {
            "ok": self.ok,
            "buffer_mm": float(self.buffer_mm),
            "n_robots": int(self.n_robots),
            "n_pairs": int(self.n_pairs),
            "n_fiducial_pairs": int(self.n_fiducial_pairs),
            "duration_s": float(self.duration_s),
            "n_samples": int(self.n_samples),
            "min_clearance_mm": num(self.min_clearance_mm),
            "n_collisions": len(self.collisions),
            "collisions": [c.to_dict() for c in self.collisions],
            "pair_ids": np.asarray(self.pair_ids, dtype=np.int64).tolist(),
            "pair_min_distance_mm": [num(v) for v in self.pair_min_distance_mm],
            "fiducial_pair_ids": np.asarray(self.fiducial_pair_ids, dtype=np.int64).tolist(),
            "fiducial_min_distance_mm": [num(v) for v in self.fiducial_min_distance_mm],
            "seconds": float(self.seconds),
        }

    def table(self) -> str:
        """A short plain-text table for the terminal."""
        clear = "-" if not math.isfinite(self.min_clearance_mm) else f"{self.min_clearance_mm:.4f}"
        lines = [
            f"2D dense check: {'OK' if self.ok else 'COLLISION'}  buffer {self.buffer_mm} mm, "
            f"{self.n_robots} robots, {self.n_pairs} robot pairs, {self.n_fiducial_pairs} "
            f"fiducial pairs, {self.duration_s:.3f} s, {self.n_samples} samples, "
            f"min clearance {clear} mm, {self.seconds:.3f} s",
        ]
        if self.collisions:
            lines.append(f"{'kind':<9}{'robot':>7}{'other':>7}{'t_start':>11}{'t_end':>11}"
                         f"{'t_min':>11}{'min mm':>9}{'thr mm':>8}")
            for c in self.collisions:
                lines.append(f"{c.kind:<9}{c.robot_a:>7}{c.other:>7}{c.t_start:>11.5f}"
                             f"{c.t_end:>11.5f}{c.t_min:>11.5f}{c.min_distance_mm:>9.4f}"
                             f"{c.threshold_mm:>8.3f}" + ("  (bound)" if c.conservative else ""))
        return "\n".join(lines)


# =====================================================================================
# Segment distance (own formulation: clamped line parameters, Ericson Sect. 5.1.9)
# =====================================================================================
@njit(cache=True)
def _clamp01(x):
    if x < 0.0:
        return 0.0
    if x > 1.0:
        return 1.0
    return x


@njit(cache=True)
def _segment_distance(p0x, p0y, p1x, p1y, q0x, q0y, q1x, q1y):
    """Distance between segments P0P1 and Q0Q1, mm (scalars)."""
    ux = p1x - p0x
    uy = p1y - p0y
    vx = q1x - q0x
    vy = q1y - q0y
    wx = p0x - q0x
    wy = p0y - q0y
    a = ux * ux + uy * uy          # |u|^2
    e = vx * vx + vy * vy          # |v|^2
    f = vx * wx + vy * wy          # v.w
    if a <= _POINT_EPS2:
        s = 0.0
        t = _clamp01(f / e) if e > _POINT_EPS2 else 0.0
    else:
        c = ux * wx + uy * wy      # u.w
        if e <= _POINT_EPS2:
            t = 0.0
            s = _clamp01(-c / a)
        else:
            b = ux * vx + uy * vy  # u.v
            # in 2D, a e - b^2 = (u x v)^2 and the unclamped line parameter is
            # (v x w) / (u x v); the cross products keep nearly parallel segments exact
            cr = ux * vy - uy * vx
            if abs(cr) > _PARALLEL_EPS * math.sqrt(a * e):
                s = _clamp01((vx * wy - vy * wx) / cr)
            else:
                s = 0.0
            t = (b * s + f) / e
            if t < 0.0:
                t = 0.0
                s = _clamp01(-c / a)
            elif t > 1.0:
                t = 1.0
                s = _clamp01((b - c) / a)
    dx = wx + ux * s - vx * t
    dy = wy + uy * s - vy * t
    return math.sqrt(dx * dx + dy * dy)


def segment_distance_np(p0, p1, q0, q1) -> np.ndarray:
    """Distance between segments ``p0-p1`` and ``q0-q1``, vectorised.

    Parameters
    ----------
    p0, p1, q0, q1 : array-like (..., 2), mm
        Segment end points; leading shapes broadcast against each other.

    Returns
    -------
    (...) float64, mm
    """
    p0 = np.asarray(p0, dtype=np.float64)
    p1 = np.asarray(p1, dtype=np.float64)
    q0 = np.asarray(q0, dtype=np.float64)
    q1 = np.asarray(q1, dtype=np.float64)
    u = p1 - p0
    v = q1 - q0
    w = p0 - q0
    u, v, w = np.broadcast_arrays(u, v, w)
    a = np.einsum("...k,...k->...", u, u)
    e = np.einsum("...k,...k->...", v, v)
    b = np.einsum("...k,...k->...", u, v)
    c = np.einsum("...k,...k->...", u, w)
    f = np.einsum("...k,...k->...", v, w)
    p_pt = a <= _POINT_EPS2
    q_pt = e <= _POINT_EPS2
    a_safe = np.where(p_pt, 1.0, a)
    e_safe = np.where(q_pt, 1.0, e)
    cr = u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]
    vxw = v[..., 0] * w[..., 1] - v[..., 1] * w[..., 0]
    general = np.abs(cr) > _PARALLEL_EPS * np.sqrt(a * e)
    s = np.where(general, np.clip(vxw / np.where(general, cr, 1.0), 0.0, 1.0), 0.0)
    t = (b * s + f) / e_safe
    s = np.where(t < 0.0, np.clip(-c / a_safe, 0.0, 1.0),
                 np.where(t > 1.0, np.clip((b - c) / a_safe, 0.0, 1.0), s))
    t = np.clip(t, 0.0, 1.0)
    # degenerate segments
    s = np.where(q_pt, np.clip(-c / a_safe, 0.0, 1.0), s)
    t = np.where(q_pt, 0.0, t)
    s = np.where(p_pt, 0.0, s)
    t = np.where(p_pt, np.where(q_pt, 0.0, np.clip(f / e_safe, 0.0, 1.0)), t)
    d = w + u * s[..., None] - v * t[..., None]
    return np.sqrt(np.einsum("...k,...k->...", d, d))


# =====================================================================================
# Trajectory interpolation on CSR arrays
# =====================================================================================
@njit(cache=True)
def _interp(ptr, tt, aa, i, t):
    """Angle of robot ``i`` at time ``t`` (holds the first/last angle outside)."""
    lo = ptr[i]
    hi = ptr[i + 1]
    if t <= tt[lo]:
        return aa[lo]
    if t >= tt[hi - 1]:
        return aa[hi - 1]
    a = lo
    b = hi - 1                    # tt[a] < t < tt[b]
    while b - a > 1:
        m = (a + b) >> 1
        if tt[m] <= t:
            a = m
        else:
            b = m
    return aa[a] + (aa[b] - aa[a]) * ((t - tt[a]) / (tt[b] - tt[a]))


@njit(cache=True)
def _max_rate(ptr, tt, rate, i, t0, t1):
    """Largest |slope| (rad/s) of robot ``i``'s breakpoint segments overlapping (t0, t1)."""
    lo = ptr[i]
    hi = ptr[i + 1]
    if hi - lo < 2 or t1 <= tt[lo] or t0 >= tt[hi - 1]:
        return 0.0
    if t0 <= tt[lo]:
        s = lo
    else:
        a = lo
        b = hi - 1                # tt[a] < t0 < tt[b]
        while b - a > 1:
            m = (a + b) >> 1
            if tt[m] <= t0:
                a = m
            else:
                b = m
        s = a
    best = 0.0
    while s < hi - 1 and tt[s] < t1:
        if rate[s] > best:
            best = rate[s]
        s += 1
    return best


@njit(cache=True)
def _local_speed(i, t0, t1, la, rmax, pa, ta, ra, pb, tb, rb):
    """Bound on the point speed (mm/s) of robot ``i``'s collision segment on (t0, t1)."""
    A = _max_rate(pa, ta, ra, i, t0, t1)
    B = _max_rate(pb, tb, rb, i, t0, t1)
    return la * A + rmax * (A + B)


@njit(cache=True)
def _pair_distance(i, j, fx, fy, t, bx, by, la, s0, s1, pa, ta, aa, pb, tb, ab):
    """Segment distance of robot ``i`` to robot ``j`` (or to point (fx, fy) if j < 0)."""
    al = _interp(pa, ta, aa, i, t)
    ph = al + _interp(pb, tb, ab, i, t)
    ex = bx[i] + la * math.cos(al)
    ey = by[i] + la * math.sin(al)
    c = math.cos(ph)
    s = math.sin(ph)
    p0x = ex + s0 * c
    p0y = ey + s0 * s
    p1x = ex + s1 * c
    p1y = ey + s1 * s
    if j < 0:
        return _segment_distance(p0x, p0y, p1x, p1y, fx, fy, fx, fy)
    al = _interp(pa, ta, aa, j, t)
    ph = al + _interp(pb, tb, ab, j, t)
    ex = bx[j] + la * math.cos(al)
    ey = by[j] + la * math.sin(al)
    c = math.cos(ph)
    s = math.sin(ph)
    return _segment_distance(p0x, p0y, p1x, p1y, ex + s0 * c, ey + s0 * s,
                             ex + s1 * c, ey + s1 * s)


@njit(cache=True)
def _n_intervals(span, speed, slack, resolution):
    """Coarse intervals on a span: spacing <= slack / speed, >= ~resolution."""
    if span <= 0.0:
        return 0
    n_max = math.ceil(span / resolution)
    if n_max > _MAX_COARSE:
        n_max = _MAX_COARSE
    if speed <= 0.0:
        return 1
    x = span * speed / slack
    if x >= n_max:
        return max(int(n_max), 1)
    return max(int(math.ceil(x)), 1)


# =====================================================================================
# The kernel
# =====================================================================================
@njit(cache=True)
def _add_item(coll, nc, run, p, start, end, d, td, is_sample, gap):
    """Add one colliding item (sample or interval) of pair ``p`` to the open run.

    ``run``: [open, t_start, t_end, d_min, t_min, has_sample]. Items that start at most
    ``gap`` after the open run ends extend it; otherwise the run is flushed first.
    """
    if run[0] != 0.0 and start > run[2] + gap:
        coll, nc = _flush(coll, nc, run, p)
    if run[0] == 0.0:
        run[0] = 1.0
        run[1] = start
        run[3] = np.inf
        run[5] = 0.0
    run[2] = end
    if d < run[3]:
        run[3] = d
        run[4] = td
    if is_sample:
        run[5] = 1.0
    return coll, nc


@njit(cache=True)
def _flush(coll, nc, run, p):
    if run[0] == 0.0:
        return coll, nc
    if nc == coll.shape[0]:
        grown = np.empty((2 * nc + 8, 6))
        grown[:nc] = coll[:nc]
        coll = grown
    coll[nc, 0] = p
    coll[nc, 1] = run[1]
    coll[nc, 2] = run[2]
    coll[nc, 3] = run[4]
    coll[nc, 4] = run[3]
    coll[nc, 5] = 1.0 if run[5] == 0.0 else 0.0   # conservative: no colliding sample
    run[0] = 0.0
    return coll, nc + 1


@njit(cache=True)
def _check_pairs(pi, pj, pfx, pfy, thr, bx, by, la, s0, s1, rmax,
                 pa, ta, aa, ra, pb, tb, ab, rb, vglob, vmean,
                 t_lo, t_hi, slack, resolution, tol, rel_tol):
    """Dense check of every pair. Returns (pair_min, pair_tmin, n_samples, coll (k, 6)).

    ``coll`` rows: pair index, t_start, t_end, t_min, d_min, conservative (0/1).
    """
    n_p = pi.shape[0]
    pmin = np.full(n_p, np.inf)
    ptmin = np.zeros(n_p)
    coll = np.empty((8, 6))
    nc = 0
    n_samples = 0
    run = np.zeros(6)
    st_a = np.empty(_STACK)
    st_b = np.empty(_STACK)
    st_da = np.empty(_STACK)
    st_db = np.empty(_STACK)
    span = t_hi - t_lo
    for p in range(n_p):
        i = pi[p]
        j = pj[p]
        fx = pfx[p]
        fy = pfy[p]
        th = thr[p]
        lg = vglob[i] + (vglob[j] if j >= 0 else 0.0)
        lm = vmean[i] + (vmean[j] if j >= 0 else 0.0)
        run[0] = 0.0
        n_int = _n_intervals(span, lm, slack, resolution)
        if n_int == 0:
            d = _pair_distance(i, j, fx, fy, t_lo, bx, by, la, s0, s1, pa, ta, aa, pb, tb, ab)
            n_samples += 1
            pmin[p] = d
            ptmin[p] = t_lo
            if d <= th:
                coll, nc = _add_item(coll, nc, run, p, t_lo, t_lo, d, t_lo, True, resolution)
            coll, nc = _flush(coll, nc, run, p)
            continue
        tc = np.empty(n_int + 1)
        dc = np.empty(n_int + 1)
        best = np.inf
        tbest = t_lo
        for k in range(n_int + 1):
            t = t_lo + span * (k / n_int) if k < n_int else t_hi
            tc[k] = t
            d = _pair_distance(i, j, fx, fy, t, bx, by, la, s0, s1, pa, ta, aa, pb, tb, ab)
            dc[k] = d
            if d < best:
                best = d
                tbest = t
        n_samples += n_int + 1
        for k in range(n_int):
            top = 0
            st_a[0] = tc[k]
            st_b[0] = tc[k + 1]
            st_da[0] = dc[k]
            st_db[0] = dc[k + 1]
            top = 1
            while top > 0:
                top -= 1
                a = st_a[top]
                b = st_b[top]
                da = st_da[top]
                db = st_db[top]
                h = b - a
                ca = da <= th
                cb = db <= th
                split = False
                unresolved = False
                lb = 0.0
                loc = lg
                if ca and cb:
                    # upper bound: D(t) <= (D0 + D1 + L h) / 2; split while an exit
                    # from collision inside the interval cannot be ruled out
                    if h > resolution and 0.5 * (da + db + lg * h) > th:
                        loc = _local_speed(i, a, b, la, rmax, pa, ta, ra, pb, tb, rb)
                        if j >= 0:
                            loc += _local_speed(j, a, b, la, rmax, pa, ta, ra, pb, tb, rb)
                        split = 0.5 * (da + db + loc * h) > th
                elif ca or cb:
                    split = h > resolution
                else:
                    lb = 0.5 * (da + db - lg * h)
                    want = best - tol - rel_tol * max(best - th, 0.0)
                    if lb <= th or lb < want:
                        loc = _local_speed(i, a, b, la, rmax, pa, ta, ra, pb, tb, rb)
                        if j >= 0:
                            loc += _local_speed(j, a, b, la, rmax, pa, ta, ra, pb, tb, rb)
                        lb = 0.5 * (da + db - loc * h)
                        if lb <= th:
                            if h > resolution:
                                split = True
                            else:
                                unresolved = True
                        elif lb < want and h > resolution:
                            split = True
                if split and top + 2 <= _STACK:
                    m = a + 0.5 * h
                    dm = _pair_distance(i, j, fx, fy, m, bx, by, la, s0, s1,
                                        pa, ta, aa, pb, tb, ab)
                    n_samples += 1
                    if dm < best:
                        best = dm
                        tbest = m
                    # right half first, so the left half is popped first (time order)
                    st_a[top] = m
                    st_b[top] = b
                    st_da[top] = dm
                    st_db[top] = db
                    st_a[top + 1] = a
                    st_b[top + 1] = m
                    st_da[top + 1] = da
                    st_db[top + 1] = dm
                    top += 2
                    continue
                if split:               # stack exhausted (cannot happen in practice)
                    unresolved = (not (ca or cb)) and lb <= th
                # terminal interval [a, b]: its left sample, then the interval itself
                if ca:
                    coll, nc = _add_item(coll, nc, run, p, a, a, da, a, True, resolution)
                if ca and cb:
                    coll, nc = _add_item(coll, nc, run, p, a, b, np.inf, a, False, resolution)
                elif unresolved:
                    # time where the bound is lowest, clipped to the interval
                    tl = a + 0.5 * h
                    if loc > 0.0:
                        tl = min(max(tl + (da - db) / (2.0 * loc), a), b)
                    coll, nc = _add_item(coll, nc, run, p, a, b, max(lb, 0.0), tl, False,
                                         resolution)
        if dc[n_int] <= th:
            coll, nc = _add_item(coll, nc, run, p, t_hi, t_hi, dc[n_int], t_hi, True, resolution)
        coll, nc = _flush(coll, nc, run, p)
        pmin[p] = best
        ptmin[p] = tbest
    return pmin, ptmin, n_samples, coll[:nc]


# =====================================================================================
# Python side
# =====================================================================================
def _axis_csr(traj: Trajectory, ax: int):
    """(ptr (n+1,), times (K,), angles rad (K,), |slope| rad/s per segment (K,))."""
    n = traj.n_robots
    counts = np.array([traj.times[ax][i].size for i in range(n)], dtype=np.int64)
    ptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(counts, out=ptr[1:])
    tt = np.concatenate([np.asarray(traj.times[ax][i], dtype=np.float64) for i in range(n)])
    aa = np.deg2rad(np.concatenate([np.asarray(traj.angles[ax][i], dtype=np.float64)
                                    for i in range(n)]))
    rate = np.zeros(tt.size)
    for i in range(n):
        lo, hi = int(ptr[i]), int(ptr[i + 1])
        dt = np.diff(tt[lo:hi])
        da = np.abs(np.diff(aa[lo:hi]))
        jump = (dt <= 0) & (da > 0)
        if jump.any():
            k = int(np.flatnonzero(jump)[0])
            raise TrajectoryError(
                f"robot {int(traj.robot_ids[i])}: axis {AXES[ax]} jumps by "
                f"{math.degrees(float(da[k])):.6g} deg at t = {float(tt[lo + k]):.6g} s with no "
                f"time between breakpoints; allowed: continuous motion (strictly increasing "
                f"times where the angle changes)")
        with np.errstate(divide="ignore", invalid="ignore"):
            rate[lo:hi - 1] = np.where(dt > 0, da / np.where(dt > 0, dt, 1.0), 0.0)
    return ptr, tt, aa, rate


def _geometry(spec: RobotSpec, buffer_mm: float) -> tuple[float, float, float, float]:
    """(l_alpha, segment start, segment end, r_max) in mm."""
    s0 = float(spec.segment_start_mm)
    s1 = float(spec.segment_end(buffer_mm))
    return float(spec.alpha_length_mm), s0, s1, max(abs(s0), abs(s1))


def _check_buffer(buffer_mm) -> float:
    try:
        b = float(buffer_mm)
    except (TypeError, ValueError):
        b = math.nan
    if isinstance(buffer_mm, bool) or not (math.isfinite(b) and b > 0):
        raise field_error(SpecError, "buffer_mm", buffer_mm, "a finite number > 0 mm",
                          "check_trajectory")
    return b


def _speeds(la: float, rmax: float, alpha_csr, beta_csr, span: float):
    """Per-robot (max, mean) point-speed bounds of the collision segment, mm/s.

    Max: ``l_alpha A + r_max (A + B)`` with the largest |slope| per axis (rad/s).
    Mean: the same with the mean |slope| over the checked span (travel / span).
    """
    out = []
    for ptr, tt, rate in (alpha_csr, beta_csr):
        n = len(ptr) - 1
        peak = np.array([rate[ptr[i]:ptr[i + 1]].max(initial=0.0) for i in range(n)])
        travel = np.array([float(np.sum(rate[ptr[i]:ptr[i + 1] - 1]
                                        * np.diff(tt[ptr[i]:ptr[i + 1]]))) for i in range(n)])
        out.append((peak, travel / span if span > 0 else np.zeros(n)))
    (a_max, a_mean), (b_max, b_mean) = out
    return la * a_max + rmax * (a_max + b_max), la * a_mean + rmax * (a_mean + b_mean)


def _span(traj: Trajectory) -> tuple[float, float]:
    """Checked time span ``[min(0, first breakpoint), last breakpoint]``, s."""
    if traj.n_robots == 0:
        return 0.0, 0.0
    t_first = min(float(t[0]) for axis in traj.times for t in axis)
    t_last = max(float(t[-1]) for axis in traj.times for t in axis)
    t_lo = min(0.0, t_first)
    return t_lo, max(t_last, t_lo)


def speed_bounds_mm_s(traj: Trajectory, spec: RobotSpec, buffer_mm: float,
                      *, mean: bool = False) -> np.ndarray:
    """Per-robot bound on the point speed of the collision segment, mm/s.

    ``V_i = l_alpha A_i + r_max (A_i + B_i)`` with ``A_i`` / ``B_i`` the largest
    |slope| of robot ``i``'s alpha / beta breakpoints in rad/s. With ``mean=True``
    the mean |slope| over the checked span instead (what sets the coarse grid).

    Returns
    -------
    (n_robots,) float64, mm/s, in trajectory order.
    """
    buffer_mm = _check_buffer(buffer_mm)
    la, _, _, rmax = _geometry(spec, buffer_mm)
    if traj.n_robots == 0:
        return np.zeros(0)
    pa, ta, _, ra = _axis_csr(traj, 0)
    pb, tb, _, rb = _axis_csr(traj, 1)
    t_lo, t_hi = _span(traj)
    vmax, vmean = _speeds(la, rmax, (pa, ta, ra), (pb, tb, rb), t_hi - t_lo)
    return vmean if mean else vmax


def coarse_grid(traj: Trajectory, spec: RobotSpec, buffer_mm: float, robot_a: int,
                robot_b: int | None = None, *, resolution_s: float = 1e-5) -> np.ndarray:
    """The coarse sample times :func:`check_trajectory` starts from for one pair.

    Parameters
    ----------
    traj, spec, buffer_mm
        As for :func:`check_trajectory`.
    robot_a, robot_b : int
        Robot ids; ``robot_b=None`` for a robot-fiducial pair.

    Returns
    -------
    (n + 1,) float64, s: uniform on the checked span, both ends included, spacing
    ``<= 2 buffer / (Vmean_a + Vmean_b)``.
    """
    vmean = speed_bounds_mm_s(traj, spec, buffer_mm, mean=True)
    ids = [int(r) for r in traj.robot_ids]
    speed = vmean[ids.index(int(robot_a))]
    if robot_b is not None:
        speed += vmean[ids.index(int(robot_b))]
    t_lo, t_hi = _span(traj)
    n = int(_n_intervals(t_hi - t_lo, float(speed), 2.0 * float(buffer_mm), float(resolution_s)))
    if n == 0:
        return np.array([t_lo])
    grid = t_lo + (t_hi - t_lo) * (np.arange(n + 1) / n)
    grid[-1] = t_hi
    return grid


def _pairs_within(xy: np.ndarray, reach: float) -> np.ndarray:
    if len(xy) < 2:
        return np.empty((0, 2), dtype=np.int64)
    pairs = cKDTree(xy).query_pairs(r=reach + _REACH_TOL_MM, output_type="ndarray")
    pairs = np.sort(pairs.astype(np.int64).reshape(-1, 2), axis=1)
    return pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]


def _fiducials_within(robot_xy: np.ndarray, fid_xy: np.ndarray, reach: float) -> np.ndarray:
    if len(robot_xy) == 0 or len(fid_xy) == 0:
        return np.empty((0, 2), dtype=np.int64)
    lists = cKDTree(fid_xy).query_ball_point(robot_xy, r=reach + _REACH_TOL_MM)
    rows = [(i, k) for i, ks in enumerate(lists) for k in sorted(ks)]
    return np.array(rows, dtype=np.int64).reshape(-1, 2)


def check_trajectory(traj: Trajectory, spec: RobotSpec, layout: Layout, buffer_mm: float, *,
                     resolution_s: float = 1e-5, distance_tol_mm: float = 0.005,
                     distance_rel_tol: float = 0.01) -> CheckReport:
    """Check a trajectory densely against the 2D capsule model.

    Parameters
    ----------
    traj : Trajectory
        Robots are matched to the layout by id.
    spec : RobotSpec
        Arm geometry (``alpha_length_mm``, ``segment_start_mm``, ``segment_end``,
        ``fiducial_buffer_mm``).
    layout : Layout
        Robot bases and fiducials. Layout robots absent from ``traj`` are not checked.
    buffer_mm : float
        Collision buffer of every robot, mm (threshold ``2 buffer`` for robot pairs).
    resolution_s : float
        Shortest interval the bisection splits; an interval this short that the bound
        cannot clear is reported as a (conservative) collision. Also the precision of
        collision start/end times.
    distance_tol_mm, distance_rel_tol : float
        Per-pair minima are refined until within ``distance_tol_mm + distance_rel_tol
        * clearance`` of the true minimum (``clearance``: sampled minimum minus the
        threshold, if positive): close pairs to 0.005 mm, far pairs more loosely.

    Returns
    -------
    CheckReport

    Raises
    ------
    UnknownRobotError
        A trajectory robot id that is not a robot of the layout.
    TrajectoryError
        Duplicate robot ids, or an axis that jumps (no finite speed bound).
    SpecError
        ``buffer_mm``, ``resolution_s``, ``distance_tol_mm`` or ``distance_rel_tol``
        out of range.
    """
    clock = time.perf_counter()
    buffer_mm = _check_buffer(buffer_mm)
    try:
        res = float(resolution_s)
    except (TypeError, ValueError):
        res = math.nan
    if not (math.isfinite(res) and res >= 1e-12):
        raise field_error(SpecError, "resolution_s", resolution_s, "a finite number >= 1e-12 s",
                          "check_trajectory")
    try:
        tol = float(distance_tol_mm)
    except (TypeError, ValueError):
        tol = math.nan
    if not (math.isfinite(tol) and tol >= 0):
        raise field_error(SpecError, "distance_tol_mm", distance_tol_mm,
                          "a finite number >= 0 mm", "check_trajectory")
    try:
        rel = float(distance_rel_tol)
    except (TypeError, ValueError):
        rel = math.nan
    if not (math.isfinite(rel) and rel >= 0):
        raise field_error(SpecError, "distance_rel_tol", distance_rel_tol,
                          "a finite number >= 0", "check_trajectory")

    ids = np.asarray(traj.robot_ids, dtype=np.int64)
    uniq, counts = np.unique(ids, return_counts=True)
    if (counts > 1).any():
        raise TrajectoryError(f"robot {int(uniq[counts > 1][0])}: appears more than once in the "
                              f"trajectory; allowed: unique robot ids")
    la, s0, s1, rmax = _geometry(spec, buffer_mm)
    fbuf = float(spec.fiducial_buffer_mm)
    n = len(ids)
    base = layout.robot_xy[layout.robot_indices(ids)] if n else np.empty((0, 2))

    rpairs = _pairs_within(base, 2.0 * (la + rmax + buffer_mm))
    fpairs = _fiducials_within(base, np.asarray(layout.fiducial_xy, dtype=np.float64),
                               la + rmax + buffer_mm + fbuf)
    n_r, n_f = len(rpairs), len(fpairs)
    fid_xy = np.asarray(layout.fiducial_xy, dtype=np.float64)
    fid_ids = np.asarray(layout.fiducial_ids, dtype=np.int64)

    t_lo, t_hi = _span(traj)

    pmin = np.empty(0)
    ptmin = np.empty(0)
    n_samples = 0
    coll = np.empty((0, 6))
    if n_r + n_f:
        pa, ta, aa, ra = _axis_csr(traj, 0)
        pb, tb, ab, rb = _axis_csr(traj, 1)
        vglob, vmean = _speeds(la, rmax, (pa, ta, ra), (pb, tb, rb), t_hi - t_lo)
        pi = np.concatenate([rpairs[:, 0], fpairs[:, 0]]).astype(np.int64)
        pj = np.concatenate([rpairs[:, 1], np.full(n_f, -1, dtype=np.int64)]).astype(np.int64)
        pfx = np.concatenate([np.zeros(n_r), fid_xy[fpairs[:, 1], 0] if n_f else np.empty(0)])
        pfy = np.concatenate([np.zeros(n_r), fid_xy[fpairs[:, 1], 1] if n_f else np.empty(0)])
        thr = np.concatenate([np.full(n_r, 2.0 * buffer_mm), np.full(n_f, buffer_mm + fbuf)])
        pmin, ptmin, n_samples, coll = _check_pairs(
            pi, pj, pfx, pfy, thr,
            np.ascontiguousarray(base[:, 0]), np.ascontiguousarray(base[:, 1]),
            la, s0, s1, rmax, pa, ta, aa, ra, pb, tb, ab, rb, vglob, vmean,
            t_lo, t_hi, 2.0 * buffer_mm, res, tol, rel)
        thr_all = thr
    else:
        thr_all = np.empty(0)

    collisions: list[Collision] = []
    for row in coll:
        p = int(row[0])
        if p < n_r:
            kind, a_id, other = "robot", int(ids[rpairs[p, 0]]), int(ids[rpairs[p, 1]])
        else:
            q = p - n_r
            kind, a_id, other = "fiducial", int(ids[fpairs[q, 0]]), int(fid_ids[fpairs[q, 1]])
        collisions.append(Collision(kind, a_id, other, float(row[1]), float(row[2]),
                                    float(row[3]), float(row[4]), float(thr_all[p]),
                                    bool(row[5] != 0.0)))
    collisions.sort(key=lambda c: (c.t_start, c.kind, c.robot_a, c.other))

    clearance = np.inf
    if n_r + n_f:
        clearance = float(np.min(pmin - thr_all))
    for c in collisions:
        clearance = min(clearance, c.min_distance_mm - c.threshold_mm)

    pair_ids = ids[rpairs] if n_r else np.empty((0, 2), dtype=np.int64)
    fpair_ids = (np.stack([ids[fpairs[:, 0]], fid_ids[fpairs[:, 1]]], axis=1) if n_f
                 else np.empty((0, 2), dtype=np.int64))
    return CheckReport(
        buffer_mm=buffer_mm, n_robots=n, n_pairs=n_r, n_fiducial_pairs=n_f,
        duration_s=t_hi - t_lo, n_samples=int(n_samples),
        pair_ids=pair_ids.astype(np.int64), pair_min_distance_mm=np.asarray(pmin[:n_r]),
        fiducial_pair_ids=fpair_ids.astype(np.int64),
        fiducial_min_distance_mm=np.asarray(pmin[n_r:]),
        min_clearance_mm=clearance, collisions=collisions,
        seconds=time.perf_counter() - clock)
