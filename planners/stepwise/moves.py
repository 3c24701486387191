"""One step of one robot: the step-rule margin MD and the scalar helpers of the kernel.

:func:`max_displacement` is the margin MD of the step rule (Sayres 2021 Eq. 7), raised
where needed so that it bounds how far any point of a beta segment moves in one step
(see :mod:`rfp_twin.planners.stepwise.kernel`); :func:`array_max_displacement` is that
margin for an array whose robots have their own alpha arms and segments (the largest
over its robots). The ``@njit(inline="always")`` helpers take and return scalars only
(no arrays, hence no reference counting when the kernel inlines them): a candidate move
clipped to the joint limits and to the destination, the sign of an angle difference,
(cos, sin) of an angle rotated by whole steps, the reach of a beta segment and the
distance of a beta segment to an obstacle (a point or a segment).

Units: angles in deg (radians only inside the trigonometry), lengths in mm.
"""
from __future__ import annotations

import math

from numba import njit

from rfp_twin.models.geometry2d import point_segment_distance, segment_distance

DEG = math.pi / 180.0
#: Angles closer than this are the same angle (deg).
ANGLE_EPS = 1e-9


def max_displacement(l_alpha: float, l_beta: float, seg_end: float, step_deg: float) -> float:
    """MD of Eq. 7, raised if needed to bound a step's motion of the whole segment, mm."""
    eq7 = (l_alpha + l_beta) * math.sin(2.0 * step_deg * DEG)
    bound = (l_alpha + 2.0 * seg_end) * step_deg * DEG
    return max(eq7, bound)


def array_max_displacement(geom, step_deg: float) -> float:
    """MD of :func:`max_displacement` for every robot of ``geom`` at once, mm.

    ``geom`` is an :class:`rfp_twin.models.array.ArrayGeometry`; one margin serves the
    whole array, so it takes the largest alpha arm (``geom.alpha_len``, (n,) mm) and the
    farthest segment point (``geom.seg_end`` / ``geom.seg_start``, (n,) mm) of any robot.
    On a layout without per-robot columns this is ``max_displacement(spec.alpha_length_mm,
    spec.beta_length_mm, seg_end.max(), step_deg)``, bit for bit.
    """
    spec = geom.spec
    if geom.n_robots == 0:
        return max_displacement(spec.alpha_length_mm, spec.beta_length_mm,
                                float(spec.segment_end(float(geom.buffer_mm))), step_deg)
    l_alpha = float(geom.alpha_len.max())
    s1 = max(float(geom.seg_end.max()), float(geom.seg_start.max()))
    return max_displacement(l_alpha, spec.beta_length_mm, s1, step_deg)


@njit(cache=True, inline="always")
def rotate_steps(c, s, k, cd, sd, c2d, s2d):
    """(cos, sin) of an angle rotated by k steps, k in -2..2."""
    if k == 0:
        return c, s
    if k == 1:
        return c * cd - s * sd, s * cd + c * sd
    if k == -1:
        return c * cd + s * sd, s * cd - c * sd
    if k == 2:
        return c * c2d - s * s2d, s * c2d + c * s2d
    return c * c2d + s * s2d, s * c2d - c * s2d


@njit(cache=True, inline="always")
def step_toward(cur, dest, k, step, lo, hi):
    """Angle after a k-step move (k in -1, 0, 1) clipped to limits and to not overshoot."""
    nxt = cur + k * step
    if nxt < lo:
        nxt = lo
    elif nxt > hi:
        nxt = hi
    if cur > dest and nxt <= dest:
        nxt = dest
    elif cur < dest and nxt >= dest:
        nxt = dest
    return nxt


@njit(cache=True, inline="always")
def direction_sign(x):
    """-1, 0 or 1: the direction of an angle difference x (deg), 0 within ANGLE_EPS."""
    if x > ANGLE_EPS:
        return 1
    if x < -ANGLE_EPS:
        return -1
    return 0


@njit(cache=True, inline="always")
def segment_reach(l_alpha, s0, s1, cos_b):
    """Largest base distance of any point of the beta segment, from cos(beta), mm."""
    r1 = l_alpha * l_alpha + s1 * s1 + 2.0 * l_alpha * s1 * cos_b
    r0 = l_alpha * l_alpha + s0 * s0 + 2.0 * l_alpha * s0 * cos_b
    return math.sqrt(max(r0, r1, 0.0))


@njit(cache=True, inline="always")
def obstacle_distance(x0, y0, x1, y1, ax, ay, bx, by):
    """Distance from the beta segment (x0, y0)-(x1, y1) to the obstacle A-B, mm.

    A point obstacle (A == B, a fiducial) uses the point-to-segment distance, a segment
    obstacle (a guide-camera edge) the segment-to-segment distance.
    """
    if ax == bx and ay == by:
        return point_segment_distance(ax, ay, x0, y0, x1, y1)
    return segment_distance(x0, y0, x1, y1, ax, ay, bx, by)
