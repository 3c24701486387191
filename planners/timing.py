"""Time-optimal parametrisation of smoothed plans under per-axis limits (TOPP-RA).

Given smoothed paths ``q_i(s)`` (:mod:`planners.smoothing`, ``s`` in plan steps) this
module chooses the path parameter as a function of time, ``s(t)``, as fast as every
axis' velocity and acceleration limits allow:

    |q'_k(s) sd| <= v_k,      |q'_k(s) sdd + q''_k(s) sd^2| <= a_k      (every joint k)

with ``sd = ds/dt``, ``sdd = d2s/dt2``, starting and ending at rest.

Groups
------
Robots that come close to each other during the plan must share one ``s(t)``: then at
every instant they are at the same ``s``, so their relative configuration is the
smoothed plan's and the planner's clearance holds (up to the smoothing deviation).
Robots that never come close may be timed apart, which lets a free robot run at full
speed while a crowded group slows down for its reversals. :func:`interaction_pairs`
finds every Eq. 4 neighbour pair whose clearance ``D_ij - 2 sigma`` falls below the
interaction distance at some step of the plan (continuous in the step: it walks the
plan with strides that the pair cannot close in); those pairs are edges, and
:func:`interaction_groups` returns the connected components. A group of ``k`` robots is
one path with ``2k`` joints.

The interaction distance is a heuristic, not a proof: groups timed apart are at
different ``s`` at the same instant, which the plan never checked. The post-processing
pipeline therefore re-verifies the result and merges the groups of any pair that comes
too close (:mod:`planners.postprocess`).

Algorithm
---------
TOPP-RA (Pham & Pham 2018, the algorithm of the ``toppra`` library) on gridpoints
``s_0 < ... < s_N`` with ``x = sd^2`` and a constant ``u = sdd`` on each interval, so
``x`` is linear in ``s`` there. A backward pass computes the controllable sets
``[0, X_i]`` (largest ``x_i`` from which the end can still be reached at rest), a
forward pass takes the largest admissible ``u`` at every gridpoint.

The gridpoints include every knot of the group's smoothed paths. With the
running-average smoothing ``q''`` is then constant on each interval and ``q'`` linear,
and the joint acceleration ``q' u + q'' x`` is *linear* in ``s`` on the interval:
constraining it at both ends of the interval (the "interpolation" discretisation)
bounds it everywhere. The velocity ``|q' sd|`` is bounded on the interval by
``max|q'| * sqrt(max x)`` over its two ends, so ``x_i`` is limited with the largest
``|q'|`` of the adjacent gridpoints. The continuous ``s(t)`` therefore respects both
limits exactly (up to rounding; limits are applied with a factor ``limit_margin``).

The grid cuts intervals where a joint curves at ``grid_steps`` (4 plan steps) and the
straight cruises between them more coarsely (:func:`group_grid`): 2.8-2.9x fewer
gridpoints on SDSS-V plans at the same fold time.

Backends
--------
Both solve the same discretised problem on the same gridpoints:

- ``"toppra"`` (default): the ``toppra`` 0.6 library, its ``TOPPRA`` algorithm and
  seidel LP solver, given the constraints above as precomputed rows
  (:mod:`planners.timing_toppra`). A group the library finds no solution for is timed
  by the kernel instead (``TimeLaw.solver == "fallback"``, counted by the pipeline's
  report as ``timing_fallbacks``); none did in any plan measured;
- ``"numba"``: this module's kernel, :func:`topp_kernel`, about 0.3 ms per group, 10-15x
  faster than the library for the same laws.

With ``"toppra"``, groups of more than :data:`TOPPRA_MAX_ROBOTS` robots go to the kernel
(``TimeLaw.solver == "numba-large"``).

Why the library used to fail (measured; benchmarks/RESULTS.md, "Timing backends"):
with its own ``JointVelocityConstraint`` / ``JointAccelerationConstraint`` its seidel
solver solved 0 of 386 groups of a 500-robot SDSS-V fold ("The controllable set at step
[i / N] can't be computed"). The cause is scaling, not infeasibility: the 2D LP walks
each violated constraint line with the unnormalised direction ``(-q'', q')``, 1e-5 to
1e-3 long with ``s`` in plan steps, and bounds the line parameter by 1e10, so from its
start at the box corner (1e8, 1e8) the optimum is out of reach and the 1D sub-LP ends
on that artificial bound, which the solver reports as infeasible. It shows where an
axis creeps or starts (smallest ``q'``, ``q''``) and only after some warm starts (the
same stage solved cold succeeds). With unit-norm rows, ``s`` rescaled so that the
kernel's ``sd`` cap fits the solver's box, and each interval's own ``q''`` at both of
its ends (the library's ``Interpolation`` scheme takes the next interval's ``q''`` at a
knot), it solves every group of every plan measured (~390-460 groups per fold, greedy
and Markov, 0 fallbacks), and its laws equal the kernel's within 2e-5 of the duration
(fold times equal to 2e-6).

Cost: the library runs its backward and forward passes in Python, about 10-13 us per
gridpoint plus a solver set-up that copies the rows element by element. On the
500-robot SDSS-V benchmark (greedy, 2.0 mm, 5 seeds, pre-simplified plans, 2-core
machine under load 3.7) the whole post-processing takes 1.8-2.6 s with the library
(0.56-0.69 s with the kernel), within the 3 s budget; Markov plans take 7-8 s with the
library against 1.4-1.8 s with the kernel (``backend="numba"``).

Piecewise-linear kinematics
---------------------------
The firmware interpolates linearly between (angle, time) points, so the product is
piecewise linear. :func:`pl_kinematics` defines its velocity as the slope of each
segment and its acceleration at each breakpoint as the three-point value

    a_k = 2 (m_k - m_{k-1}) / (t_{k+1} - t_{k-1}),

(``m_k`` the slope after breakpoint ``k``): the slope change spread over the two
half-segments around the breakpoint, i.e. the acceleration of the parabola through
three consecutive breakpoints. The axis rests before its first and after its last
breakpoint, so ``a_0 = 2 m_0 / (t_1 - t_0)`` and ``a_K = -2 m_{K-1} / (t_K -
t_{K-1})``. Both are weighted averages of the true velocity / acceleration of any C1
curve through the breakpoints; so breakpoints sampled exactly from a trajectory within
the limits (any subset of them) have slopes and three-point accelerations within the
limits.

Units: degrees, seconds, plan steps.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numba import njit

from models.errors import PlanningError, SpecError, field_error
from models.geometry2d import DEG, beta_segment, segment_distance
from planners.smoothing import SmoothPath

__all__ = [
    "BACKENDS",
    "DEFAULT_BACKEND",
    "TOPPRA_MAX_ROBOTS",
    "SD_CAP",
    "STRAIGHT_STEPS",
    "TimeLaw",
    "interaction_pairs",
    "interaction_groups",
    "group_grid",
    "time_group",
    "topp",
    "law_excess",
    "pl_kinematics",
]

BACKENDS = ("toppra", "numba")
#: Backend of :func:`time_group` (and of the post-processing pipeline).
DEFAULT_BACKEND = "toppra"
#: With the toppra backend, groups of more robots than this are timed by the kernel
#: (solver "numba-large"): the library's Python loops grow with the joints, and a crowded
#: Markov plan at 3.5 mm on the 547 grid is one group of 547 robots (1094 joints), 35 s
#: with the library, 1.5 s with the kernel, the same law. SDSS-V groups at 2-2.5 mm have
#: at most ~7 robots.
TOPPRA_MAX_ROBOTS = 32
#: Cap on sd (plan steps / s) where no joint of a group moves; such stretches then take
#: a negligible time.
SD_CAP = 1.0e5
#: Longest grid interval where every joint of a group moves linearly (cruise, or no
#: joint moving), plan steps (:func:`group_grid`).
STRAIGHT_STEPS = 128.0
#: Parts per ramp zone of a straight interval (:func:`group_grid`).
_RAMP_PARTS = 16.0
#: Largest relative excess of the toppra library's law over the discretised constraints
#: that a uniform slow-down absorbs (more counts as no solution).
TOPPRA_TOLERANCE = 1e-3
#: Joint path speeds |q'| below this (deg/step) count as zero.
_QD_EPS = 1e-12


# =====================================================================================
# Interaction graph
# =====================================================================================
@njit(cache=True, inline="always")
def _plan_angles(ptr, steps, angles, i, s, out, col):
    """Robot i of a plan (CSR breakpoints) at step s, held outside: out[col], out[col+1]."""
    k0 = ptr[i]
    k1 = ptr[i + 1]
    if s <= steps[k0] or k1 - k0 < 2:
        out[col] = angles[k0, 0]
        out[col + 1] = angles[k0, 1]
        return
    if s >= steps[k1 - 1]:
        out[col] = angles[k1 - 1, 0]
        out[col + 1] = angles[k1 - 1, 1]
        return
    lo = k0
    hi = k1 - 1
    while hi - lo > 1:
        mid = (lo + hi) >> 1
        if steps[mid] <= s:
            lo = mid
        else:
            hi = mid
    h = steps[lo + 1] - steps[lo]
    f = (s - steps[lo]) / h if h > 0.0 else 0.0
    out[col] = angles[lo, 0] + f * (angles[lo + 1, 0] - angles[lo, 0])
    out[col + 1] = angles[lo, 1] + f * (angles[lo + 1, 1] - angles[lo, 1])


@njit(cache=True)
def _pair_clearance_below(ptr, steps, angles, n_steps, base_xy, pairs, l_alpha, seg_start,
                          seg_end, buffer, mu, margin):
    """Per pair: the smallest clearance found before it drops below ``margin`` (mm).

    Walks the plan's steps with adaptive strides: at clearance ``c`` the pair cannot get
    below ``margin`` within ``(c - margin) / (2 mu)`` steps, so those are skipped. The
    walk stops at the first sample below ``margin`` (its value is returned). A value
    ``>= margin`` is the smallest sample (an upper bound of the minimum) and proves the
    whole plan stays ``>= margin``; a value ``< margin`` only says "below".
    """
    p = pairs.shape[0]
    out = np.empty(p)
    q = np.empty(4)
    for k in range(p):
        i = pairs[k, 0]
        j = pairs[k, 1]
        thr = buffer[i] + buffer[j]
        best = np.inf
        s = 0.0
        while True:
            _plan_angles(ptr, steps, angles, i, s, q, 0)
            _plan_angles(ptr, steps, angles, j, s, q, 2)
            a0x, a0y, a1x, a1y = beta_segment(base_xy[i, 0], base_xy[i, 1], q[0], q[1],
                                              l_alpha, seg_start, seg_end[i])
            b0x, b0y, b1x, b1y = beta_segment(base_xy[j, 0], base_xy[j, 1], q[2], q[3],
                                              l_alpha, seg_start, seg_end[j])
            c = segment_distance(a0x, a0y, a1x, a1y, b0x, b0y, b1x, b1y) - thr
            if c < best:
                best = c
            if c < margin or s >= n_steps:
                break
            skip = math.floor((c - margin) / (2.0 * mu))
            if skip < 1.0:
                skip = 1.0
            s = min(s + skip, float(n_steps))
        out[k] = best
    return out


def interaction_pairs(plan, geom, margin_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """Neighbour pairs and their clearance over the plan, as far as needed, mm.

    Parameters
    ----------
    plan : Plan (executed direction), robots in ``geom`` order
    geom : ArrayGeometry (its Eq. 4 neighbour pairs, buffer and segment)
    margin_mm : the interaction distance

    Returns
    -------
    pairs : (p, 2) int64 robot indices (``geom.pairs``)
    clearance : (p,) float64, mm. A pair below ``margin_mm`` at some step has a value
        below ``margin_mm`` (the first such sample). Any other pair has a value
        ``>= margin_mm`` (its smallest sample) and its clearance ``D_ij(s) - 2 sigma``
        is ``>= margin_mm`` over the whole plan, continuous in ``s``: every point of a
        capsule moves at most ``mu = (l_alpha + 2 r) * step`` per step (``r`` the
        segment end), so a pair closes at most ``2 mu`` per step, and the walk only
        skips steps that cannot close the gap to ``margin_mm``.
    """
    spec = geom.spec
    pairs = np.ascontiguousarray(geom.pairs, dtype=np.int64)
    if pairs.shape[0] == 0:
        return pairs.reshape(0, 2), np.zeros(0)
    r = float(max(np.max(geom.seg_end), spec.segment_start_mm))
    mu = (spec.alpha_length_mm + 2.0 * r) * plan.step_deg * DEG
    cl = _pair_clearance_below(np.ascontiguousarray(plan.path_ptr, dtype=np.int64),
                               np.ascontiguousarray(plan.path_step, dtype=np.float64),
                               np.ascontiguousarray(plan.path_angles, dtype=np.float64),
                               float(plan.n_steps), geom.base_xy, pairs, spec.alpha_length_mm,
                               spec.segment_start_mm, np.ascontiguousarray(geom.seg_end),
                               np.ascontiguousarray(geom.buffer), float(mu), float(margin_mm))
    return pairs, cl


def interaction_groups(n: int, edges: np.ndarray) -> np.ndarray:
    """Connected components of the graph on ``n`` robots with ``edges`` (e, 2): labels (n,)."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import connected_components

    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    g = csr_matrix((np.ones(edges.shape[0]), (edges[:, 0], edges[:, 1])), shape=(n, n))
    _, labels = connected_components(g, directed=False)
    return labels.astype(np.int64)


# =====================================================================================
# Time law
# =====================================================================================
@dataclass(frozen=True)
class TimeLaw:
    """``s(t)`` of one group: constant ``sdd`` between gridpoints.

    Attributes
    ----------
    s : (N+1,) gridpoints, plan steps (increasing)
    sd : (N+1,) ds/dt at the gridpoints, steps/s (0 at both ends)
    sdd : (N,) d2s/dt2 on each interval, steps/s^2
    t : (N+1,) time of each gridpoint, s (t[0] = 0)
    solver : what computed it: "numba" (the kernel), "toppra" (the library), "fallback"
        (the kernel, after the library found no solution), "numba-large" (the kernel, for
        a group too large for the library, :data:`TOPPRA_MAX_ROBOTS`) or "static"
        (nothing moves)
    """

    s: np.ndarray
    sd: np.ndarray
    sdd: np.ndarray
    t: np.ndarray
    solver: str = "numba"

    @property
    def duration(self) -> float:
        return float(self.t[-1]) if self.t.size else 0.0

    def s_at(self, times) -> np.ndarray:
        """Path parameter at the given times (held outside [0, duration])."""
        times = np.ascontiguousarray(np.atleast_1d(np.asarray(times, dtype=np.float64)))
        out = np.empty(times.size)
        _s_at(self.s, self.sd, self.sdd, self.t, times, out)
        return out

    def scaled(self, c: float) -> TimeLaw:
        """The same motion ``c`` times slower (c >= 1): velocities / c, accelerations / c^2."""
        return TimeLaw(self.s, self.sd / c, self.sdd / (c * c), self.t * c, self.solver)

    @classmethod
    def static(cls, s0: float) -> TimeLaw:
        return cls(np.array([s0]), np.zeros(1), np.zeros(0), np.zeros(1), "static")


@njit(cache=True)
def _s_at(s, sd, sdd, t, times, out):
    n = s.size
    for j in range(times.size):
        tj = times[j]
        if n == 1 or tj <= t[0]:
            out[j] = s[0]
            continue
        if tj >= t[n - 1]:
            out[j] = s[n - 1]
            continue
        lo = 0
        hi = n - 1
        while hi - lo > 1:
            mid = (lo + hi) >> 1
            if t[mid] <= tj:
                lo = mid
            else:
                hi = mid
        tau = tj - t[lo]
        v = s[lo] + sd[lo] * tau + 0.5 * sdd[lo] * tau * tau
        out[j] = min(max(v, s[lo]), s[lo + 1])


@njit(cache=True)
def _times(s, x):
    n = s.size
    t = np.zeros(n)
    for i in range(n - 1):
        den = math.sqrt(max(x[i], 0.0)) + math.sqrt(max(x[i + 1], 0.0))
        ds = s[i + 1] - s[i]
        if ds <= 0.0:
            t[i + 1] = t[i]
        elif den > 0.0:
            t[i + 1] = t[i] + 2.0 * ds / den
        else:
            t[i + 1] = np.inf
    return t


# =====================================================================================
# TOPP-RA kernel (numba)
# =====================================================================================
@njit(cache=True)
def _x_direct(i, delta, qd, qdd, amax, V):
    """Upper bound on x_i from constraints whose u-coefficient vanishes: |q'' x| <= a."""
    xm = V
    J = qd.shape[1]
    d2 = 2.0 * delta[i]
    for k in range(J):
        b = abs(qdd[i, k])
        if b > 0.0 and (abs(qd[i, k]) <= _QD_EPS or abs(qd[i + 1, k] + d2 * qdd[i, k]) <= _QD_EPS):
            xm = min(xm, amax[k] / b)
    return xm


@njit(cache=True)
def _active(i, x, x_next, delta, qd, qdd, amax):
    """Largest lower and smallest upper bound on u at x, with their slopes d/dx.

    Every bound is linear in x; returns (lo, dlo, hi, dhi). Constraints with a vanishing
    u-coefficient are bounds on x alone (see :func:`_x_direct`) and are skipped here.
    """
    d2 = 2.0 * delta[i]
    lo = -x / d2
    dlo = -1.0 / d2
    hi = (x_next - x) / d2
    dhi = -1.0 / d2
    J = qd.shape[1]
    for k in range(J):
        beta = qdd[i, k]
        a = amax[k]
        for side in range(2):
            alpha = qd[i, k] if side == 0 else qd[i + 1, k] + d2 * beta
            if abs(alpha) <= _QD_EPS:
                continue
            r = -beta / alpha
            p1 = -a / alpha
            p2 = a / alpha
            if alpha < 0.0:
                p1, p2 = p2, p1
            v1 = p1 + r * x
            v2 = p2 + r * x
            if v1 > lo:
                lo = v1
                dlo = r
            if v2 < hi:
                hi = v2
                dhi = r
    return lo, dlo, hi, dhi


@njit(cache=True)
def _max_x(i, xm, x_next, delta, qd, qdd, amax):
    """Largest x in [0, xm] with an admissible u (the upper end of the controllable set).

    The gap ``hi(x) - lo(x)`` is concave and piecewise linear (min of linear minus max
    of linear) and >= 0 at x = 0, so Newton's method from ``xm`` moves monotonically
    down to its largest root, in a few steps; bisection is the fallback.
    """
    x = xm
    for _ in range(50):
        lo, dlo, hi, dhi = _active(i, x, x_next, delta, qd, qdd, amax)
        gap = hi - lo
        if gap >= 0.0:
            return x
        slope = dhi - dlo
        if slope >= 0.0:
            break
        xn = x - gap / slope
        if not (xn < x):
            break
        x = max(xn, 0.0)
        if x == 0.0:
            return 0.0
    # fallback (rounding at a kink): bisection between 0 (admissible) and x
    a = 0.0
    b = x
    for _ in range(80):
        mid = 0.5 * (a + b)
        lo, _, hi, _ = _active(i, mid, x_next, delta, qd, qdd, amax)
        if hi >= lo:
            a = mid
        else:
            b = mid
        if b - a <= 1e-13 * xm:
            break
    return a


@njit(cache=True)
def topp_kernel(delta, qd, qdd, vmax, amax, sd_cap):
    """TOPP-RA on N intervals with per-joint box limits; start and end at rest.

    Parameters
    ----------
    delta : (N,) interval lengths, steps (> 0)
    qd : (N+1, J) q' at the gridpoints, deg/step
    qdd : (N, J) q'' on each interval (constant), deg/step^2
    vmax, amax : (J,) limits, deg/s and deg/s^2
    sd_cap : upper bound on sd where no joint moves, steps/s

    Returns
    -------
    x : (N+1,) sd^2 ; u : (N,) sdd ; X : (N+1,) controllable upper bounds
    """
    N = delta.size
    J = qd.shape[1]
    V = np.empty(N + 1)
    for i in range(N + 1):
        best = sd_cap * sd_cap
        for k in range(J):
            m = qd[i, k] * qd[i, k]
            if i > 0:
                m = max(m, qd[i - 1, k] * qd[i - 1, k])
            if i < N:
                m = max(m, qd[i + 1, k] * qd[i + 1, k])
            if m > _QD_EPS * _QD_EPS:
                best = min(best, vmax[k] * vmax[k] / m)
        V[i] = best
    X = np.zeros(N + 1)
    X[N] = 0.0
    for i in range(N - 1, -1, -1):
        xm = _x_direct(i, delta, qd, qdd, amax, V[i])
        X[i] = _max_x(i, xm, X[i + 1], delta, qd, qdd, amax)
    x = np.zeros(N + 1)
    u = np.zeros(N)
    for i in range(N):
        lo, _, hi, _ = _active(i, x[i], X[i + 1], delta, qd, qdd, amax)
        ui = hi if hi >= lo else lo
        xn = x[i] + 2.0 * delta[i] * ui
        if xn > X[i + 1]:
            xn = X[i + 1]
        if xn < 0.0:
            xn = 0.0
        u[i] = (xn - x[i]) / (2.0 * delta[i])
        x[i + 1] = xn
    return x, u, X


def topp(grid, qd, qdd, vmax, amax, *, sd_cap: float = SD_CAP) -> TimeLaw:
    """Time-optimal law on ``grid`` for path derivatives ``qd`` (N+1, J), ``qdd`` (N, J)."""
    grid = np.ascontiguousarray(grid, dtype=np.float64)
    if grid.size < 2:
        return TimeLaw.static(float(grid[0]) if grid.size else 0.0)
    delta = np.diff(grid)
    x, u, _ = topp_kernel(delta, np.ascontiguousarray(qd, dtype=np.float64),
                          np.ascontiguousarray(qdd, dtype=np.float64),
                          np.ascontiguousarray(vmax, dtype=np.float64),
                          np.ascontiguousarray(amax, dtype=np.float64), float(sd_cap))
    t = _times(grid, x)
    return TimeLaw(grid, np.sqrt(np.maximum(x, 0.0)), u, t)


# =====================================================================================
# One group
# =====================================================================================
def group_grid(path: SmoothPath, robots: np.ndarray, grid_steps: float,
               moving_range: np.ndarray | None = None, span=(None, None),
               straight_steps: float | None = None, limits=None) -> np.ndarray:
    """Gridpoints of a group: its knots over the span where it moves, subdivided.

    Every knot of every robot of the group inside the moving span is a gridpoint (so
    ``q''`` is constant between gridpoints). An interval where some joint of the group
    curves (``q'' != 0``) is cut into equal parts no longer than ``grid_steps``.

    An interval where every joint moves linearly is cut more coarsely if ``limits`` are
    given: there the joints' constraints are constant, ``|u| <= U = min a_k / |q'_k|``
    and ``x <= X = min(sd_cap^2, v_k^2 / q'_k^2)``, so the time-optimal law accelerates
    at a constant ``u`` (``x`` linear in ``s``, exact on any grid), cruises at ``X`` and
    brakes, and its corners lie within ``D = X / (2 U)`` of the interval's ends (the
    distance in which it reaches its cruise from rest). Those two zones are cut into
    parts no longer than ``clip(D / 16, grid_steps, straight_steps)``, the cruise
    between them into parts no longer than ``straight_steps`` [default
    :data:`STRAIGHT_STEPS`]; an interval where no joint moves into parts no longer than
    ``straight_steps``. Measured on the 500-robot SDSS-V layout (preset ``sdss-v``,
    step 0.1 deg, window 200 steps, seeds 0 and 1): 2.8-2.9x fewer gridpoints than
    ``grid_steps`` everywhere (137k and 146k instead of 403k), the same longest group
    duration, at most +0.03 % on any group; on the test suite's corner plan
    (``CORNER``, windows 10 / 60 / 200 steps) at most +0.03 %. A flat 128-step cut
    of straight intervals (no ramp zones) cost up to 1.5 % of the fold time.

    Parameters
    ----------
    path : SmoothPath
    robots : (k,) robot indices
    grid_steps, straight_steps : plan steps (``straight_steps`` at least ``grid_steps``)
    moving_range : ``path.moving_range()``, if already computed
    span : (lo, hi): extend the grid down to ``lo`` / up to ``hi`` (None: the moving
        span's end)
    limits : None (every interval cut at ``grid_steps``), or (vmax (2k,), amax (2k,),
        sd_cap): the joint limits (deg/s, deg/s^2) and the cap on sd (steps/s)

    Returns
    -------
    (N+1,) increasing s, plan steps; one point if nothing moves.
    """
    rng = (path.moving_range() if moving_range is None else moving_range)[robots]
    moving = rng[:, 1] > rng[:, 0]
    if not moving.any():
        return np.array([0.0])
    s_a = float(rng[moving, 0].min())
    s_b = float(rng[moving, 1].max())
    if span[0] is not None:
        s_a = min(s_a, float(span[0]))
    if span[1] is not None:
        s_b = max(s_b, float(span[1]))
    ks = [path.robot_knots(int(i)) for i in robots]
    k = np.concatenate(ks + [np.array([s_a, s_b])])
    k = np.unique(k[(k >= s_a) & (k <= s_b)])
    keep = np.concatenate([[True], np.diff(k) > 1e-9])
    k = k[keep]
    k[-1] = s_b
    if k.size < 2:
        return np.array([s_a, s_b])
    straight = STRAIGHT_STEPS if straight_steps is None else max(float(straight_steps), grid_steps)
    if limits is None or straight <= grid_steps:
        zone = np.zeros(k.size - 1)
        curved = np.ones(k.size - 1, dtype=np.bool_)
    else:
        vmax, amax, sd_cap = limits
        mid = 0.5 * (k[1:] + k[:-1])
        curved = np.any(path.evaluate(mid, robots, 2).reshape(mid.size, -1) != 0.0, axis=1)
        qd = np.abs(path.evaluate(mid, robots, 1).reshape(mid.size, -1))
        zone = _ramp_zone(np.ascontiguousarray(qd), np.asarray(vmax, dtype=np.float64),
                          np.asarray(amax, dtype=np.float64), float(sd_cap))
    return _subdivide(k, curved, zone, float(grid_steps), straight)


@njit(cache=True)
def _ramp_zone(qd, vmax, amax, sd_cap):
    """Per interval (rows of |q'| (M, J), joints moving linearly): D = X / (2 U), steps."""
    M, J = qd.shape
    out = np.zeros(M)
    for i in range(M):
        X = sd_cap * sd_cap
        U = np.inf
        for k in range(J):
            q = qd[i, k]
            if q > _QD_EPS:
                X = min(X, vmax[k] * vmax[k] / (q * q))
                U = min(U, amax[k] / q)
        out[i] = X / (2.0 * U) if U < np.inf else 0.0
    return out


@njit(cache=True)
def _subdivide(k, curved, zone, grid_steps, straight_steps):
    """Cut knot intervals: curved ones at ``grid_steps``, straight ones by ramp zones."""
    n = k.size - 1
    out = np.empty(1 + 8 * n + int(np.sum(np.ceil(np.diff(k) / grid_steps))))
    out[0] = k[0]
    m = 1
    for i in range(n):
        a = k[i]
        b = k[i + 1]
        L = b - a
        if curved[i]:
            cuts = (a, b, b, b)
            steps = (grid_steps, 1.0, 1.0, 1.0)
        else:
            D = zone[i]
            h = min(max(D / _RAMP_PARTS, grid_steps), straight_steps)
            if D <= 0.0:
                cuts = (a, b, b, b)
                steps = (straight_steps, 1.0, 1.0, 1.0)
            elif 2.0 * D >= L:
                cuts = (a, b, b, b)
                steps = (h, 1.0, 1.0, 1.0)
            else:
                cuts = (a, a + D, b - D, b)
                steps = (h, straight_steps, h, 1.0)
        for z in range(3):
            lo = cuts[z]
            hi = cuts[z + 1]
            if hi <= lo:
                continue
            parts = max(1, int(math.ceil((hi - lo) / steps[z])))
            for p in range(1, parts + 1):
                out[m] = lo + (hi - lo) * p / parts
                m += 1
        out[m - 1] = b
    return out[:m]


def time_group(path: SmoothPath, robots, max_speed, max_accel, *, grid_steps: float = 4.0,
               backend: str = DEFAULT_BACKEND, limit_margin: float = 0.999,
               moving_range: np.ndarray | None = None, span=(None, None),
               sd_cap: float = SD_CAP, straight_steps: float | None = None,
               fallback: bool = True, toppra_max_robots: int | None = TOPPRA_MAX_ROBOTS) -> TimeLaw:
    """Time-optimal shared ``s(t)`` of a group of robots (one path, 2 joints per robot).

    Parameters
    ----------
    path : SmoothPath
    robots : (k,) robot indices of the group
    max_speed, max_accel : (2,) per-axis limits (alpha, beta), deg/s and deg/s^2
    grid_steps : longest interval between gridpoints where a joint curves, plan steps
    backend : "toppra" (the library, :mod:`planners.timing_toppra`) or "numba" (this
        module's kernel); both solve the same discretised problem on the same grid
    limit_margin : the limits are applied times this factor (rounding head-room)
    moving_range : ``path.moving_range()``, if already computed (saves time per group)
    span : see :func:`group_grid`
    sd_cap : upper bound on ds/dt where no joint moves, steps/s
    straight_steps : longest interval of a cruise where every joint moves linearly
        [default :data:`STRAIGHT_STEPS`] (see :func:`group_grid`)
    fallback : with ``backend="toppra"``, time the group with the kernel when the
        library finds no solution (the law's ``solver`` is then "fallback"); False
        raises :class:`models.errors.PlanningError` instead
    toppra_max_robots : with ``backend="toppra"``, larger groups are timed by the kernel
        (solver "numba-large"); None = no limit

    Returns
    -------
    TimeLaw, starting and ending at rest (a static law if the group never moves); its
    ``solver`` says which solver computed it.
    """
    if backend not in BACKENDS:
        raise field_error(SpecError, "backend", backend, ", ".join(BACKENDS), "time_group")
    if not (np.isfinite(grid_steps) and grid_steps > 0):
        raise field_error(SpecError, "grid_steps", grid_steps, "> 0 steps", "time_group")
    if straight_steps is not None and not (np.isfinite(straight_steps) and straight_steps > 0):
        raise field_error(SpecError, "straight_steps", straight_steps, "> 0 steps", "time_group")
    if not (np.isfinite(sd_cap) and sd_cap > 0):
        raise field_error(SpecError, "sd_cap", sd_cap, "> 0 steps/s", "time_group")
    robots = np.atleast_1d(np.asarray(robots, dtype=np.int64))
    k = robots.size
    vmax = np.tile(np.asarray(max_speed, dtype=np.float64) * limit_margin, k)
    amax = np.tile(np.asarray(max_accel, dtype=np.float64) * limit_margin, k)
    grid = group_grid(path, robots, grid_steps, moving_range, span, straight_steps,
                      limits=(vmax, amax, sd_cap))
    if grid.size < 2:
        return TimeLaw.static(float(grid[0]))
    qd = np.ascontiguousarray(path.evaluate(grid, robots, 1).reshape(grid.size, 2 * k))
    mid = 0.5 * (grid[1:] + grid[:-1])
    qdd = np.ascontiguousarray(path.evaluate(mid, robots, 2).reshape(mid.size, 2 * k))
    if backend == "toppra" and toppra_max_robots is not None and k > toppra_max_robots:
        return replace(topp(grid, qd, qdd, vmax, amax, sd_cap=sd_cap), solver="numba-large")
    if backend == "toppra":
        law = _topp_toppra(grid, qd, qdd, vmax, amax, sd_cap)
        if law is not None:
            return law
        if not fallback:
            raise PlanningError(f"toppra: no parametrisation of the group of robots "
                                f"{robots.tolist()}; allowed: fallback=True or backend='numba'")
        return replace(topp(grid, qd, qdd, vmax, amax, sd_cap=sd_cap), solver="fallback")
    return topp(grid, qd, qdd, vmax, amax, sd_cap=sd_cap)


def _topp_toppra(grid, qd, qdd, vmax, amax, sd_cap: float) -> TimeLaw | None:
    """The law computed by the toppra library, checked; None where it finds none.

    The library's forward pass lowers each ``x`` by up to 0.01 % against rounding, so
    its law can exceed the discretised constraints by a hair where the next ``x`` is
    bound by the acceleration limit; :func:`law_excess` measures that, and a law off by
    at most :data:`TOPPRA_TOLERANCE` is slowed down uniformly by the excess (a worse
    one counts as no solution).
    """
    from planners import timing_toppra   # imports toppra (and matplotlib): ~0.3 s, once

    x = timing_toppra.solve(grid, qd, qdd, vmax, amax, sd_cap)
    if x is None:
        return None
    delta = np.diff(grid)
    rv, ra = law_excess(delta, qd, qdd, vmax, amax, x, float(sd_cap))
    c = max(1.0, rv, math.sqrt(ra))
    if not c <= 1.0 + TOPPRA_TOLERANCE:
        return None
    law = TimeLaw(grid, np.sqrt(x), np.diff(x) / (2.0 * delta), _times(grid, x), "toppra")
    return law.scaled(c) if c > 1.0 else law


@njit(cache=True)
def law_excess(delta, qd, qdd, vmax, amax, x, sd_cap):
    """How far ``x`` (N+1,) exceeds the discretised constraints: (r_v, r_a) >= 0.

    ``r_v``: largest ``sqrt(x_i) max|q'_k| / v_k`` (the kernel's velocity bound, ``q'``
    over gridpoints ``i - 1 .. i + 1``) and ``sqrt(x_i) / sd_cap``; ``r_a``: largest
    ``|q'_k u_i + q''_k x| / a_k`` at both ends of every interval, ``u_i = (x_{i+1} -
    x_i) / (2 delta_i)``. Values <= 1 satisfy the constraints. Arrays as
    :func:`topp_kernel`.
    """
    N = delta.size
    J = qd.shape[1]
    rv = 0.0
    ra = 0.0
    for i in range(N + 1):
        xi = max(x[i], 0.0)
        rv = max(rv, math.sqrt(xi) / sd_cap)
        for k in range(J):
            m = abs(qd[i, k])
            if i > 0:
                m = max(m, abs(qd[i - 1, k]))
            if i < N:
                m = max(m, abs(qd[i + 1, k]))
            if m > _QD_EPS:
                rv = max(rv, math.sqrt(xi) * m / vmax[k])
    for i in range(N):
        u = (x[i + 1] - x[i]) / (2.0 * delta[i])
        for k in range(J):
            a0 = abs(qd[i, k] * u + qdd[i, k] * x[i]) / amax[k]
            a1 = abs(qd[i + 1, k] * u + qdd[i, k] * x[i + 1]) / amax[k]
            ra = max(ra, a0, a1)
    return rv, ra


# =====================================================================================
# Piecewise-linear output
# =====================================================================================
@njit(cache=True)
def pl_kinematics(t, y):
    """Largest |slope| and |three-point acceleration| of one piecewise-linear axis.

    See the module docstring: slope ``m_k = dy / dt`` per segment; acceleration at
    breakpoint ``k`` ``2 (m_k - m_{k-1}) / (t_{k+1} - t_{k-1})`` with the axis at rest
    before the first and after the last breakpoint. Returns (vmax, amax); a zero-length
    segment with a change of angle gives inf.
    """
    n = t.size
    if n < 2:
        return 0.0, 0.0
    vm = 0.0
    am = 0.0
    prev_m = 0.0
    prev_h = 0.0
    for k in range(n - 1):
        h = t[k + 1] - t[k]
        dy = y[k + 1] - y[k]
        if h > 0.0:
            m = dy / h
        elif dy == 0.0:
            continue
        else:
            return np.inf, np.inf
        if abs(m) > vm:
            vm = abs(m)
        span = prev_h + h
        a = 2.0 * abs(m - prev_m) / span
        if a > am:
            am = a
        prev_m = m
        prev_h = h
    if prev_h > 0.0:
        a = 2.0 * abs(prev_m) / prev_h
        if a > am:
            am = a
    return vm, am
