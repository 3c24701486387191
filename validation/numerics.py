"""Numerics shared by the 2D checker and the 3D validation (and nothing else).

One definition each of what :mod:`rfp_twin.validation.checker2d`, :mod:`rfp_twin.validation.mesh3d` and
:mod:`rfp_twin.validation.buffer` all need: the segment distance, the trajectory as per-axis CSR
arrays and its interpolation, the largest breakpoint slope on a time window, the
bisection stack, candidate pairs within a reach, and input checks. Units: mm, s;
angles in radians inside the kernels, degrees at the public boundary.

Segment distance
----------------
The closest points of segments ``P0P1`` and ``Q0Q1`` are found from the parameters
``(s, t)`` of the supporting lines, clamped to ``[0, 1]`` and re-projected (the
formulation of Ericson, *Real-Time Collision Detection*, 2005, Sect. 5.1.9). In 2D,
``|u|^2 |v|^2 - (u . v)^2 = (u x v)^2`` and the unclamped line parameter of ``P`` is
``(v x w) / (u x v)``; computing it with the cross products keeps nearly parallel
segments exact. This code is the validation side's own: the planner's distance code
(:mod:`rfp_twin.models.geometry2d`) tests for a proper crossing and then takes the smallest of
four endpoint-to-segment distances; the two share no code.

Trajectory arrays
-----------------
Per axis, :func:`axis_csr` gives ``ptr (n + 1,)``, ``times (K,)``, ``angles (K,)`` rad
and ``rate (K,)``: the |slope| (rad/s) of the breakpoint segment that starts at each
breakpoint (0 for the last one and for zero-length segments); robot ``i`` owns
``ptr[i]:ptr[i + 1]``. Outside its breakpoints a robot holds its first / last angle.

Numba's on-disk cache (``cache=True``) is invalidated only by changes to the file that
defines a cached function: after editing a kernel or a constant here, delete the
``validation/**/__pycache__/*.nbi`` / ``*.nbc`` files so that the kernels which inline
it are compiled again.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
from numba import njit
from scipy.spatial import cKDTree

from rfp_twin.models.errors import SpecError, TrajectoryError, field_error
from rfp_twin.models.layout import Layout
from rfp_twin.models.trajectory import AXES, Trajectory

#: Squared length (mm^2) below which a segment is treated as a point.
POINT_EPS2 = 1e-24
#: |u x v| / (|u| |v|) (sine of the angle) below which two segments are parallel.
PARALLEL_EPS = 1e-12
#: Depth of a bisection stack (halving from at most the whole span to the resolution).
STACK = 256
#: Tolerance added to reaches and z gaps so that ``distance == reach`` counts, mm.
REACH_TOL_MM = 1e-9


# =====================================================================================
# Segment distance
# =====================================================================================
@njit(cache=True)
def clamp01(x):
    """``x`` clamped to ``[0, 1]``."""
    if x < 0.0:
        return 0.0
    if x > 1.0:
        return 1.0
    return x


@njit(cache=True, inline="always")
def closest_parameters(a, b, c, e, f, s_lines, eps):
    """Parameters ``(s, t)`` in [0, 1] of the closest points of the segments P0 + s u and
    Q0 + t v (2D or 3D), from ``a = u.u``, ``b = u.v``, ``c = u.w``, ``e = v.v``,
    ``f = v.w`` (``w = P0 - Q0``) and ``s_lines``, the parameter on P of the closest points
    of the two lines, clamped (used when both segments have a length). A segment with
    squared length <= ``eps`` (mm^2) is a point."""
    if a <= eps:
        return 0.0, (clamp01(f / e) if e > eps else 0.0)
    if e <= eps:
        return clamp01(-c / a), 0.0
    t = (b * s_lines + f) / e
    if t < 0.0:
        return clamp01(-c / a), 0.0
    if t > 1.0:
        return clamp01((b - c) / a), 1.0
    return s_lines, t


@njit(cache=True)
def segment_distance(p0x, p0y, p1x, p1y, q0x, q0y, q1x, q1y):
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
    c = ux * wx + uy * wy          # u.w
    b = ux * vx + uy * vy          # u.v
    cr = ux * vy - uy * vx
    s = clamp01((vx * wy - vy * wx) / cr) if abs(cr) > PARALLEL_EPS * math.sqrt(a * e) else 0.0
    s, t = closest_parameters(a, b, c, e, f, s, POINT_EPS2)
    dx = wx + ux * s - vx * t
    dy = wy + uy * s - vy * t
    return math.sqrt(dx * dx + dy * dy)


@njit(cache=True)
def beta_segment(bx, by, a, b, la, s0, s1):
    """Ends ``(p0x, p0y, p1x, p1y)`` (mm) of the 2D collision segment of a robot with
    base ``(bx, by)`` at alpha ``a``, beta ``b`` (rad): ``elbow + r (cos(a + b),
    sin(a + b))`` for ``r = s0, s1``, ``elbow = base + l_alpha (cos a, sin a)``
    (Sayres et al. 2021, Eq. 3)."""
    ex = bx + la * math.cos(a)
    ey = by + la * math.sin(a)
    ph = a + b
    c = math.cos(ph)
    s = math.sin(ph)
    return ex + s0 * c, ey + s0 * s, ex + s1 * c, ey + s1 * s


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
    p_pt = a <= POINT_EPS2
    q_pt = e <= POINT_EPS2
    a_safe = np.where(p_pt, 1.0, a)
    e_safe = np.where(q_pt, 1.0, e)
    cr = u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]
    vxw = v[..., 0] * w[..., 1] - v[..., 1] * w[..., 0]
    general = np.abs(cr) > PARALLEL_EPS * np.sqrt(a * e)
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
# Trajectory on CSR arrays
# =====================================================================================
def axis_csr(traj: Trajectory, ax: int):
    """(ptr (n+1,), times (K,), angles rad (K,), |slope| rad/s per breakpoint (K,)).

    Raises :class:`rfp_twin.models.errors.TrajectoryError` on a jump (two breakpoints at one
    time with different angles): it has no finite speed bound.
    """
    n = traj.n_robots
    counts = np.array([traj.times[ax][i].size for i in range(n)], dtype=np.int64)
    ptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(counts, out=ptr[1:])
    tt = np.concatenate([np.asarray(traj.times[ax][i], dtype=np.float64) for i in range(n)]) \
        if n else np.zeros(0)
    aa = np.deg2rad(np.concatenate([np.asarray(traj.angles[ax][i], dtype=np.float64)
                                    for i in range(n)])) if n else np.zeros(0)
    rate = np.zeros(tt.size)
    if tt.size > 1:
        dt = np.diff(tt)
        da = np.abs(np.diff(aa))
        inside = np.ones(dt.size, dtype=bool)    # not from one robot's last point to the next
        inside[ptr[1:n] - 1] = False
        jump = inside & (dt <= 0) & (da > 0)
        if jump.any():
            k = int(np.flatnonzero(jump)[0])
            i = int(np.searchsorted(ptr, k, side="right")) - 1
            raise TrajectoryError(
                f"robot {int(traj.robot_ids[i])}: axis {AXES[ax]} jumps by "
                f"{math.degrees(float(da[k])):.6g} deg at t = {float(tt[k]):.6g} s with "
                f"no time between breakpoints; allowed: continuous motion (strictly "
                f"increasing times where the angle changes)")
        moving = inside & (dt > 0)
        rate[:-1][moving] = da[moving] / dt[moving]
    return ptr, tt, aa, rate


def peak_and_travel(ptr: np.ndarray, tt: np.ndarray, rate: np.ndarray):
    """Per robot of one axis: largest |slope| (rad/s) and total travel (rad), (n,) each."""
    n = len(ptr) - 1
    peak = np.zeros(n)
    travel = np.zeros(n)
    rows = np.flatnonzero(np.diff(ptr) > 0)
    if rows.size:
        # a robot's last breakpoint has rate 0, so the products across robots vanish
        step = np.zeros(tt.size)
        step[:-1] = rate[:-1] * np.diff(tt)
        peak[rows] = np.maximum(np.maximum.reduceat(rate, ptr[rows]), 0.0)
        travel[rows] = np.add.reduceat(step, ptr[rows])
    return peak, travel


def time_span(traj: Trajectory) -> tuple[float, float]:
    """Checked time span ``[min(0, first breakpoint), last breakpoint]``, s."""
    if traj.n_robots == 0:
        return 0.0, 0.0
    t_first = min(float(t[0]) for axis in traj.times for t in axis)
    t_last = max(float(t[-1]) for axis in traj.times for t in axis)
    t_lo = min(0.0, t_first)
    return t_lo, max(t_last, t_lo)


@njit(cache=True)
def interp_angle(ptr, tt, aa, i, t):
    """Angle (rad) of robot ``i``'s axis at time ``t`` (holds the first/last angle outside)."""
    lo = ptr[i]
    hi = ptr[i + 1]
    if t <= tt[lo]:
        return aa[lo]
    if t >= tt[hi - 1]:
        return aa[hi - 1]
    a = lo + np.searchsorted(tt[lo:hi], t, side="right") - 1     # tt[a] <= t < tt[a + 1]
    b = a + 1
    return aa[a] + (aa[b] - aa[a]) * ((t - tt[a]) / (tt[b] - tt[a]))


@njit(cache=True)
def max_rate(ptr, tt, rate, i, t0, t1):
    """Largest |slope| (rad/s) of robot ``i``'s breakpoint segments overlapping (t0, t1)."""
    lo = ptr[i]
    hi = ptr[i + 1]
    if hi - lo < 2:
        return 0.0
    k0 = max(lo + np.searchsorted(tt[lo:hi], t0, side="right") - 1, lo)
    k1 = min(lo + np.searchsorted(tt[lo:hi], t1, side="left"), hi - 1)
    best = 0.0
    for k in range(k0, k1):
        if rate[k] > best:
            best = rate[k]
    return best


# =====================================================================================
# Bisection stack: rows (a, b, F(a), F(b)), popped depth first
# =====================================================================================
@njit(cache=True)
def push(st, top, a, b, fa, fb):
    """Push interval ``[a, b]`` with its end values; returns the new top."""
    st[top] = (a, b, fa, fb)
    return top + 1


@njit(cache=True)
def push_halves(st, top, a, m, b, fa, fm, fb):
    """Push ``[m, b]`` then ``[a, m]`` (the left half is popped first: time order)."""
    top = push(st, top, m, b, fm, fb)
    return push(st, top, a, m, fa, fm)


# =====================================================================================
# Python side: pairs, bases, checks, JSON
# =====================================================================================
def pairs_within(xy: np.ndarray, reach: float) -> np.ndarray:
    """Index pairs ``(i < j)`` of points at most ``reach`` (+ tolerance) apart, (p, 2)
    int64, sorted."""
    if len(xy) < 2:
        return np.empty((0, 2), dtype=np.int64)
    pairs = cKDTree(xy).query_pairs(r=reach + REACH_TOL_MM, output_type="ndarray")
    pairs = np.sort(pairs.astype(np.int64).reshape(-1, 2), axis=1)
    return pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]


def robot_bases(traj: Trajectory, layout: Layout) -> tuple[np.ndarray, np.ndarray]:
    """Robot ids (n,) int64 of the trajectory and their bases (n, 2) mm in the layout.

    Raises :class:`rfp_twin.models.errors.TrajectoryError` on a repeated id and
    :class:`rfp_twin.models.errors.UnknownRobotError` on an id the layout does not have.
    """
    ids = np.asarray(traj.robot_ids, dtype=np.int64)
    uniq, counts = np.unique(ids, return_counts=True)
    if (counts > 1).any():
        raise TrajectoryError(f"robot {int(uniq[counts > 1][0])}: appears more than once in the "
                              f"trajectory; allowed: unique robot ids")
    base = layout.robot_xy[layout.robot_indices(ids)] if len(ids) else np.empty((0, 2))
    return ids, base


def checked_float(value, name: str, allowed: str, where: str, minimum: float = 0.0, *,
                  strict: bool = True, allow_bool: bool = False) -> float:
    """``float(value)`` if finite and ``> minimum`` (``>=`` unless ``strict``), else a
    :class:`rfp_twin.models.errors.SpecError` naming the field (``allowed`` says what is)."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        x = math.nan
    ok = math.isfinite(x) and (x > minimum if strict else x >= minimum)
    if not ok or (isinstance(value, bool) and not allow_bool):
        raise field_error(SpecError, name, value, allowed, where)
    return x


def json_float(x: float):
    """``float(x)``, or ``None`` when it is not finite (JSON has no inf / NaN)."""
    x = float(x)
    return x if math.isfinite(x) else None


def plain_fields(obj) -> dict:
    """A dataclass of ``str`` / ``int`` / ``float`` / ``bool`` fields as a dict of plain
    Python values (numpy scalars converted), in field order."""
    return {f.name: _PLAIN[f.type](getattr(obj, f.name)) for f in dataclasses.fields(obj)}


_PLAIN = {"str": str, "int": int, "float": float, "bool": bool}


class PlainRecord:
    """Mixin for a dataclass of plain fields: ``to_dict`` is :func:`plain_fields`."""

    def to_dict(self) -> dict:
        return plain_fields(self)


def collision_table(summary: list[str], collisions, columns) -> str:
    """Terminal text: the ``summary`` lines, then (if there are collisions) a header
    line and one line per collision.

    ``columns``: ``(title, attribute, spec)`` with ``spec`` a format spec such as
    ``"<9"`` or ``">11.5f"`` (the title takes its alignment and width); a
    ``conservative`` collision's line ends with ``(bound)``.
    """
    def width(spec: str) -> str:
        return spec.split(".")[0]

    lines = list(summary)
    if collisions:
        lines.append("".join(f"{title:{width(spec)}}" for title, _, spec in columns))
    for c in collisions:
        lines.append("".join(f"{getattr(c, attr):{spec}}" for _, attr, spec in columns)
                     + ("  (bound)" if c.conservative else ""))
    return "\n".join(lines)
