"""Smoothing a stepwise plan into a C1 path of the step parameter (Sayres 2021 Sect. 6).

A :class:`rfp_twin.planners.plan.Plan` moves every axis by -d, 0 or +d deg per step, so its
paths are piecewise linear in the step index with a corner at every change of
direction: infinite acceleration at any finite speed, and the "wiggles" of robots that
meet (the paper's words). Here each robot's path becomes a smooth function
``q_i(s)`` of one path parameter ``s`` (plan steps), on a domain shared by all robots.
Time does not appear: :mod:`rfp_twin.planners.postprocess.timing` chooses ``s(t)`` afterwards, jointly for
robots that interact, so their relative configuration at each ``s`` stays the smoothed
plan's.

Methods
-------
``"average"`` (default): the paper's running-average velocity filter. Averaging the
velocity over a window of ``w`` steps and integrating is the same as averaging the
position over a centred window (both axes of a robot alike)::

    q~(s) = (1 / w) * integral_{s - w/2}^{s + w/2} q(u) du,

with the plan held at its first / last configuration outside ``[0, n_steps]``. For a
piecewise-linear ``q`` this is exactly piecewise quadratic, C1, with knots at every
plan breakpoint +- ``w/2``; its second derivative is piecewise constant. Straight
stretches are kept exactly, a corner of slope change ``D`` (deg/step) moves by at most
``|D| w / 8``, and a wiggle shorter than the window is averaged away. It is computed
exactly (no sampling) from the plan's breakpoints.

``"spline"``: a least-squares clamped cubic B-spline with uniform knots every ``w``
steps, fitted to the plan at every integer step, with value and zero slope pinned at
both ends. C2, but it rings around corners (Gibbs), creeps during holds, and its second
derivative is not piecewise constant, so the time law's constraints are exact only on
a fine grid. Kept for comparison; the running average is the default: exact, cheap
(one pass over the breakpoints), and its folds are shorter with fewer points per axis
(``benchmarks/bench_postprocess.py``).

Both give a :class:`SmoothPath`: per robot a piecewise cubic (CSR arrays) on the shared
domain ``[0, s_end]``, ``s = plan step + pad_steps`` with ``pad_steps`` half the widest
window, so every robot starts exactly at the plan's start and ends exactly at its end.

Units: degrees, plan steps.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit, prange

from rfp_twin.models.errors import SpecError, field_error
from rfp_twin.models.kernel_cache import DELIVERY, warm_up
from rfp_twin.planners.plan import Plan

__all__ = ["METHODS", "DEFAULT_WINDOW_STEPS", "SmoothPath", "smooth_plan", "plan_deviation",
           "window_for_limits"]

METHODS = ("average", "spline")
#: Window of :func:`smooth_plan` when none is given, plan steps (kaiju's Savitzky-Golay
#: window is 21 points). The post-processing pipeline uses :func:`window_for_limits`.
DEFAULT_WINDOW_STEPS = 21.0
#: Knots closer than this (steps) are merged.
_KNOT_EPS = 1e-9


# =====================================================================================
# The path object
# =====================================================================================
@dataclass(frozen=True)
class SmoothPath:
    """Smoothed per-robot paths as piecewise cubics of the path parameter ``s``.

    Attributes
    ----------
    robot_ids : (n,) int64
    method : str, one of :data:`METHODS`
    window_steps : (n,) float64, smoothing window of each robot, plan steps
    pad_steps : float, ``s = plan step + pad_steps``
    s_end : float, the shared domain is ``[0, s_end]`` (``n_steps + 2 pad_steps``)
    ptr : (n + 1,) int64, CSR offsets into ``knots`` / ``coef``
    knots : (m,) float64, increasing per robot; robot ``i`` has knots
        ``knots[ptr[i]:ptr[i+1]]`` (at least 2), the first 0 and the last ``s_end``
    coef : (m, 2, 4) float64, on ``[knots[k], knots[k+1]]`` axis ``ax`` is
        ``sum_p coef[k, ax, p] * (s - knots[k])**p`` (the row of a robot's last knot is
        its end value)
    """

    robot_ids: np.ndarray
    method: str
    window_steps: np.ndarray
    pad_steps: float
    s_end: float
    ptr: np.ndarray
    knots: np.ndarray
    coef: np.ndarray

    @property
    def n_robots(self) -> int:
        return int(self.robot_ids.shape[0])

    def robot_knots(self, i: int) -> np.ndarray:
        """(k,) knots of robot index i, s."""
        return self.knots[self.ptr[i]:self.ptr[i + 1]]

    def evaluate(self, s, robots=None, deriv: int = 0) -> np.ndarray:
        """Angles (or derivatives wrt s) at parameters ``s``: (len(s), len(robots), 2).

        ``deriv`` 0, 1 or 2 (deg, deg/step, deg/step^2); outside ``[0, s_end]`` the
        path holds its end values (derivatives 0). At a knot the right-hand limit of the
        second derivative is returned.
        """
        s = np.ascontiguousarray(np.atleast_1d(np.asarray(s, dtype=np.float64)))
        robots = np.arange(self.n_robots) if robots is None else np.asarray(robots, dtype=np.int64)
        out = np.empty((s.size, robots.size, 2))
        _evaluate_many(self.ptr, self.knots, self.coef, np.ascontiguousarray(robots), s,
                       int(deriv), out)
        return out

    def start(self) -> np.ndarray:
        """(n, 2) configuration at s = 0, deg."""
        return self.coef[self.ptr[:-1], :, 0].copy()

    def end(self) -> np.ndarray:
        """(n, 2) configuration at s = s_end, deg."""
        return self.coef[self.ptr[1:] - 1, :, 0].copy()

    def moving_range(self) -> np.ndarray:
        """(n, 2) first and last s between which each robot moves (equal if it never does)."""
        out = np.zeros((self.n_robots, 2))
        _moving_range(self.ptr, self.knots, self.coef, out)
        return out


# =====================================================================================
# Public entry point
# =====================================================================================
def smooth_plan(plan: Plan, *, method: str = "average",
                window_steps: float | np.ndarray = DEFAULT_WINDOW_STEPS,
                pad_steps: float | None = None) -> SmoothPath:
    """Smooth every robot's stepwise path (see the module docstring).

    Parameters
    ----------
    plan : Plan, in the executed direction
    method : "average" (running-average velocity filter) or "spline"
    window_steps : float or (n,) array, window per robot in plan steps (>= 0; 0 keeps
        the piecewise-linear plan, corners included)
    pad_steps : s of the plan's step 0 [default: half the widest window]; at least that
        (give it to keep the domain fixed while windows change)

    Returns
    -------
    SmoothPath on ``[0, n_steps + 2 pad_steps]``.
    """
    if method not in METHODS:
        raise field_error(SpecError, "method", method, ", ".join(METHODS), "smooth_plan")
    n = plan.n_robots
    w = np.broadcast_to(np.asarray(window_steps, dtype=np.float64), (n,)).copy()
    if not np.all(np.isfinite(w)) or np.any(w < 0) or np.any(w > 1e6):
        raise field_error(SpecError, "window_steps", window_steps, "finite values in [0, 1e6] steps",
                          "smooth_plan")
    pad = float(w.max()) / 2.0 if n else 0.0
    if pad_steps is not None:
        if not (np.isfinite(pad_steps) and pad_steps >= pad):
            raise field_error(SpecError, "pad_steps", pad_steps, f">= half the widest window ({pad})",
                              "smooth_plan")
        pad = float(pad_steps)
    s_end = float(plan.n_steps) + 2.0 * pad
    steps = np.ascontiguousarray(plan.path_step, dtype=np.float64) + pad
    angles = np.ascontiguousarray(plan.path_angles, dtype=np.float64)
    ptr_in = np.ascontiguousarray(plan.path_ptr, dtype=np.int64)
    if method == "average":
        ptr, knots, coef = average_all(ptr_in, steps, angles, w, s_end)
    else:
        ptr, knots, coef = _spline_all(plan, w, pad, s_end)
    return SmoothPath(np.asarray(plan.robot_ids, dtype=np.int64).copy(), method, w, pad, s_end,
                      ptr, knots, coef)


def window_for_limits(max_speed, max_accel, step_deg: float) -> float:
    """Running-average window that spans the time an axis needs to reach full speed.

    ``w = v / a`` seconds, i.e. ``v^2 / (a d)`` plan steps (``v``, ``a`` the smallest
    axis limits, ``d`` the plan step, one step per ``d / v`` seconds). The filter turns
    a start or a stop at full speed into a ramp at exactly the acceleration limit, so the
    time law need not slow down there; a reversal needs twice that and still slows
    down. 200 steps (20 deg of travel) for SDSS-V (30 deg/s, 45 deg/s^2) at 0.1 deg.
    A corner moves by at most ``|slope change| * w / 8`` (2.5 deg at a stop), which is
    why :mod:`rfp_twin.planners.postprocess` re-verifies and narrows the window of robots that
    come too close.
    """
    v = float(np.min(max_speed))
    a = float(np.min(max_accel))
    if not (v > 0 and a > 0 and step_deg > 0):
        raise field_error(SpecError, "limits", (max_speed, max_accel, step_deg), "> 0",
                          "window_for_limits")
    return float(max(1.0, round(v * v / (a * step_deg))))


def plan_deviation(plan: Plan, path: SmoothPath, stride: int = 1) -> np.ndarray:
    """(n, 2) largest |smoothed - plan| per robot and axis over the plan's steps
    (every ``stride``-th step), deg. One pass per robot, no (steps, n)
    arrays: memory stays linear in robots whatever the plan's length."""
    steps = np.arange(0, plan.n_steps + 1, max(1, int(stride)), dtype=np.float64)
    out = np.zeros((plan.n_robots, 2))
    _max_deviation(np.asarray(plan.path_ptr, dtype=np.int64),
                   np.asarray(plan.path_step, dtype=np.float64),
                   np.ascontiguousarray(plan.path_angles, dtype=np.float64),
                   path.ptr, path.knots, path.coef, float(path.pad_steps), steps, out)
    return out


@njit(cache=True, parallel=True)
def _max_deviation(pptr, pstep, pang, ptr, knots, coef, pad, steps, out):
    """``out[i, ax]`` = max over ``steps`` of |path(i, step + pad) - plan(i, step)|; the
    plan is piecewise linear between its breakpoints and held outside them (robots in
    parallel, each on its own)."""
    for i in prange(pptr.size - 1):
        buf = np.empty(2)
        b0 = pptr[i]
        b1 = pptr[i + 1]
        cur = b0
        for j in range(steps.size):
            x = steps[j]
            eval_robot(ptr, knots, coef, i, x + pad, 0, buf)
            while cur + 1 < b1 and pstep[cur + 1] <= x:
                cur += 1
            for ax in range(2):
                if b1 - b0 < 2 or x <= pstep[b0]:
                    raw = pang[b0, ax]
                elif cur + 1 >= b1:
                    raw = pang[b1 - 1, ax]
                else:
                    h = pstep[cur + 1] - pstep[cur]
                    f = (x - pstep[cur]) / h if h > 0.0 else 1.0
                    raw = pang[cur, ax] + f * (pang[cur + 1, ax] - pang[cur, ax])
                d = abs(buf[ax] - raw)
                if d > out[i, ax]:
                    out[i, ax] = d


# =====================================================================================
# Evaluation kernels
# =====================================================================================
@njit(cache=True)
def eval_robot(ptr, knots, coef, i, s, deriv, out):
    """Robot i at parameter s: writes axis values (deriv 0/1/2) into out[0:2]."""
    k0 = ptr[i]
    k1 = ptr[i + 1]
    if s <= knots[k0] or k1 - k0 < 2:
        for ax in range(2):
            out[ax] = coef[k0, ax, 0] if deriv == 0 else 0.0
        return
    if s >= knots[k1 - 1]:
        for ax in range(2):
            out[ax] = coef[k1 - 1, ax, 0] if deriv == 0 else 0.0
        return
    # the piece [knots[k], knots[k + 1]) holding s (the last one for a NaN s)
    k = min(k0 + np.searchsorted(knots[k0:k1], s, side="right") - 1, k1 - 2)
    x = s - knots[k]
    for ax in range(2):
        c0 = coef[k, ax, 0]
        c1 = coef[k, ax, 1]
        c2 = coef[k, ax, 2]
        c3 = coef[k, ax, 3]
        if deriv == 0:
            out[ax] = c0 + x * (c1 + x * (c2 + x * c3))
        elif deriv == 1:
            out[ax] = c1 + x * (2.0 * c2 + 3.0 * x * c3)
        else:
            out[ax] = 2.0 * c2 + 6.0 * x * c3


@njit(cache=True)
def _moving_range(ptr, knots, coef, out):
    for i in range(ptr.size - 1):
        k0 = ptr[i]
        k1 = ptr[i + 1]
        first = -1
        last = -1
        for k in range(k0, k1 - 1):
            moving = False
            for ax in range(2):
                for p in range(1, 4):
                    if coef[k, ax, p] != 0.0:
                        moving = True
            if moving:
                if first < 0:
                    first = k
                last = k
        if first >= 0:
            out[i, 0] = knots[first]
            out[i, 1] = knots[last + 1]


@njit(cache=True)
def _evaluate_many(ptr, knots, coef, robots, s, deriv, out):
    buf = np.empty(2)
    for r in range(robots.size):
        i = robots[r]
        for j in range(s.size):
            eval_robot(ptr, knots, coef, i, s[j], deriv, buf)
            out[j, r, 0] = buf[0]
            out[j, r, 1] = buf[1]


# =====================================================================================
# Running average (box filter) of a piecewise-linear path: exact piecewise quadratic
# =====================================================================================
@njit(cache=True)
def _pl_at(b, y, cum, lo, hi, x, cur, out):
    """Held piecewise-linear path at x, both axes: out = (q_a, q_b, q'_a, q'_b, Q_a, Q_b).

    ``q'`` is the slope of the segment holding x (right-hand), ``Q`` the integral from
    ``b[lo]``. ``cur`` is a cursor into the breakpoints for increasing x; returns it.
    """
    if hi - lo < 2 or x < b[lo]:
        for ax in range(2):
            out[ax] = y[lo, ax]
            out[2 + ax] = 0.0
            out[4 + ax] = y[lo, ax] * (x - b[lo])
        return cur
    if x >= b[hi - 1]:
        for ax in range(2):
            out[ax] = y[hi - 1, ax]
            out[2 + ax] = 0.0
            out[4 + ax] = cum[hi - 1 - lo, ax] + y[hi - 1, ax] * (x - b[hi - 1])
        return cur
    if cur < lo:
        cur = lo
    while cur + 1 < hi - 1 and b[cur + 1] <= x:
        cur += 1
    h = b[cur + 1] - b[cur]
    dx = x - b[cur]
    for ax in range(2):
        slope = (y[cur + 1, ax] - y[cur, ax]) / h if h > 0.0 else 0.0
        out[ax] = y[cur, ax] + slope * dx
        out[2 + ax] = slope
        out[4 + ax] = cum[cur - lo, ax] + dx * (y[cur, ax] + 0.5 * slope * dx)
    return cur


@njit(cache=True)
def _average_robot(b, y, lo, hi, w, s_end, knots_out, coef_out):
    """Box-filtered path of one robot; returns the number of knots written."""
    m = hi - lo
    # Q at the breakpoints, per axis
    cum = np.zeros((m, 2))
    for ax in range(2):
        acc = 0.0
        for k in range(1, m):
            h = b[lo + k] - b[lo + k - 1]
            acc += 0.5 * h * (y[lo + k, ax] + y[lo + k - 1, ax])
            cum[k, ax] = acc
    # candidate knots: 0, s_end, every breakpoint +- w/2
    cand = np.empty(2 * m + 2)
    cand[0] = 0.0
    cand[1] = s_end
    half = 0.5 * w
    for k in range(m):
        cand[2 + 2 * k] = min(max(b[lo + k] - half, 0.0), s_end)
        cand[3 + 2 * k] = min(max(b[lo + k] + half, 0.0), s_end)
    cand.sort()
    nk = 0
    for c in cand:
        if nk == 0 or c - knots_out[nk - 1] > _KNOT_EPS:
            knots_out[nk] = c
            nk += 1
    knots_out[nk - 1] = s_end
    # four monotone evaluation sequences (s +- w/2 at knots, mid +- w/2 inside pieces),
    # each with its own cursor into the breakpoints: linear time
    v1 = np.empty(6)
    v0 = np.empty(6)
    e1 = np.empty(6)
    e0 = np.empty(6)
    c_v1 = c_v0 = c_e1 = c_e0 = lo
    for k in range(nk):
        s = knots_out[k]
        # slopes (and curvature) are taken inside the piece: at a knot the one-sided
        # value could land on the wrong side of a breakpoint by rounding
        mid = 0.5 * (s + knots_out[k + 1]) if k + 1 < nk else s
        c_v1 = _pl_at(b, y, cum, lo, hi, s + half, c_v1, v1)
        c_v0 = _pl_at(b, y, cum, lo, hi, s - half, c_v0, v0)
        c_e1 = _pl_at(b, y, cum, lo, hi, mid + half, c_e1, e1)
        c_e0 = _pl_at(b, y, cum, lo, hi, mid - half, c_e0, e0)
        for ax in range(2):
            if w > 0.0:
                coef_out[k, ax, 0] = (v1[4 + ax] - v0[4 + ax]) / w
                coef_out[k, ax, 1] = (v1[ax] - v0[ax]) / w
                coef_out[k, ax, 2] = 0.5 * (e1[2 + ax] - e0[2 + ax]) / w
            else:
                coef_out[k, ax, 0] = v1[ax]
                coef_out[k, ax, 1] = e1[2 + ax]
                coef_out[k, ax, 2] = 0.0
            coef_out[k, ax, 3] = 0.0
    # exact ends (the plan's first and last configuration)
    for ax in range(2):
        coef_out[0, ax, 0] = y[lo, ax]
        coef_out[nk - 1, ax, 0] = y[hi - 1, ax]
        coef_out[nk - 1, ax, 1] = 0.0
        coef_out[nk - 1, ax, 2] = 0.0
    return nk


@njit(cache=True)
def _average_kernel(ptr_in, steps, angles, w, s_end, ptr, knots, coef):
    n = ptr_in.size - 1
    pos = 0
    for i in range(n):
        lo = ptr_in[i]
        hi = ptr_in[i + 1]
        ptr[i] = pos
        nk = _average_robot(steps, angles, lo, hi, w[i], s_end, knots[pos:], coef[pos:])
        pos += nk
    ptr[n] = pos
    return pos


def average_all(ptr_in, steps, angles, w, s_end):
    """Running-average smoothing of CSR piecewise-linear paths (``ptr_in`` (n + 1,),
    ``steps`` (m,) plan steps, ``angles`` (m, 2) deg), robot i with window ``w[i]`` steps,
    on the domain ``[0, s_end]``: the CSR piecewise quadratics ``(ptr, knots, coef)`` of a
    :class:`SmoothPath`."""
    n = ptr_in.size - 1
    cap = 2 * steps.size + 2 * n + 2
    ptr = np.zeros(n + 1, dtype=np.int64)
    knots = np.empty(cap)
    coef = np.zeros((cap, 2, 4))
    used = _average_kernel(ptr_in, steps, angles, np.ascontiguousarray(w), float(s_end),
                           ptr, knots, coef)
    return ptr, knots[:used].copy(), coef[:used].copy()


# =====================================================================================
# Clamped least-squares cubic B-spline (comparison method)
# =====================================================================================
def _spline_all(plan: Plan, w: np.ndarray, pad: float, s_end: float):
    """Per window value: one shared design matrix, all robots with that window at once."""
    from scipy.interpolate import BSpline, PPoly
    from scipy.sparse.linalg import splu

    n = plan.n_robots
    s_grid = np.arange(0.0, math.floor(s_end) + 1.0)
    if s_grid[-1] < s_end:
        s_grid = np.append(s_grid, s_end)
    raw = plan.angles_at(s_grid - pad)                     # (S, n, 2), held outside
    pieces_knots: list[np.ndarray] = [None] * n            # type: ignore[list-item]
    pieces_coef: list[np.ndarray] = [None] * n             # type: ignore[list-item]
    for wv in np.unique(w):
        idx = np.flatnonzero(w == wv)
        n_int = max(1, int(round(s_end / max(wv, 1.0))))
        brk = np.linspace(0.0, s_end, n_int + 1)
        t = np.concatenate([[0.0] * 3, brk, [s_end] * 3])
        n_coef = t.size - 4
        B = BSpline.design_matrix(s_grid, t, 3).tocsc()
        Y = raw[:, idx, :].reshape(s_grid.size, -1)        # (S, k*2)
        y0 = Y[0]
        y1 = Y[-1]
        pinned = np.zeros((n_coef, Y.shape[1]))
        pinned[:2] = y0
        pinned[-2:] = y1
        free = np.arange(2, n_coef - 2)
        if free.size:
            rhs = Y - B @ pinned
            Bf = B[:, free]
            A = (Bf.T @ Bf).tocsc()
            sol = splu(A).solve(np.asarray(Bf.T @ rhs))
            pinned[free] = sol
        for r, i in enumerate(idx):
            kn = brk
            cf = np.empty((kn.size, 2, 4))
            for ax in range(2):
                pp = PPoly.from_spline(BSpline(t, pinned[:, 2 * r + ax], 3))
                # keep the pieces on [0, s_end]; PPoly coefficients are highest power first
                sel = (pp.x[:-1] >= 0.0) & (pp.x[1:] <= s_end) & (pp.x[1:] > pp.x[:-1])
                c = pp.c[:, sel][::-1].T                   # (pieces, 4) lowest power first
                cf[:-1, ax, :] = c
                cf[-1, ax, :] = 0.0
                cf[-1, ax, 0] = y1[2 * r + ax]
                cf[0, ax, 0] = y0[2 * r + ax]
            pieces_knots[i] = kn
            pieces_coef[i] = cf
    ptr = np.zeros(n + 1, dtype=np.int64)
    ptr[1:] = np.cumsum([k.size for k in pieces_knots])
    return ptr, np.concatenate(pieces_knots), np.concatenate(pieces_coef)


# called from Python once the planner has run (loaded ahead from numba's cache)
warm_up(DELIVERY, _average_kernel, _moving_range, _evaluate_many, _max_deviation)
