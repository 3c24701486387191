"""Running-average smoothing with narrower windows on chosen stretches of a robot's path.

The post-processing (:mod:`rfp_twin.planners.postprocess`) narrows the smoothing window
where the smoothed path of a robot comes too close to a neighbour. Narrowing it for the
whole path would sharpen every corner of that robot, and the time-optimal law then
slows down all along it. Here the window is narrowed only on stretches of the
plan (:class:`WindowRegions`), and the result stays an exact piecewise quadratic, C1,
with the plan's exact ends:

Levels ``k = 0..K`` have windows ``w_k = w / f^k`` (``f`` the regions' ``factor``, 2 by
default); level ``k >= 1`` covers the
stretches ``R_k`` (nested, ``R_1 ⊇ R_2 ⊇ ...``). Let ``A_k`` be the plan with every
stretch of ``R_{k+1}`` replaced by its chord (``A_K`` is the plan). The plan is the
sum ``A_0 + sum_k (A_k - A_{k-1})`` of piecewise-linear components, the ``k``-th zero
outside ``R_k``; each is box-filtered with its own window
(:func:`rfp_twin.planners.postprocess.smoothing.smooth_plan`'s kernel) and the sum is the smoothed
path. At a step deeper than ``w_{k-1} / 2`` inside a stretch of ``R_k``, every
component but the ``k``-th is linear over its window, so it is kept exactly, and the
path deviates from the plan only as the ``w_k`` average does.

Units: plan steps, degrees.
"""
from __future__ import annotations

import numpy as np

from rfp_twin.planners.plan import Plan
from rfp_twin.planners.postprocess.smoothing import SmoothPath, average_all, smooth_plan

__all__ = ["WindowRegions", "smooth_plan_local"]

#: Knots of different components closer than this (steps) are merged.
_KNOT_EPS = 1e-9


class WindowRegions:
    """Stretches of plan steps where a robot's smoothing window is ``w / factor^level``.

    ``regions[i]`` is a list, per level 1, 2, ..., of disjoint sorted ``[lo, hi]``
    intervals (plan steps) of robot index ``i``; a stretch of level ``k`` lies inside
    the stretches of every lower level (:meth:`add` keeps it so).
    """

    def __init__(self, n_robots: int, factor: float = 2.0) -> None:
        self.factor = float(factor)
        self.regions: list[list[list[tuple[float, float]]]] = [[] for _ in range(n_robots)]

    def level(self, i: int, lo: float, hi: float) -> int:
        """Deepest level of robot ``i`` that covers some step of ``[lo, hi]`` (0: none)."""
        deepest = 0
        for k, ivs in enumerate(self.regions[i], start=1):
            if any(a <= hi and lo <= b for a, b in ivs):
                deepest = k
        return deepest

    def inside(self, i: int, lo: float, hi: float, level: int, depth: float) -> bool:
        """True when ``[lo, hi]`` lies in one stretch of ``level``, ``depth`` from its ends."""
        ivs = self.regions[i][level - 1] if level <= len(self.regions[i]) else []
        return any(a + depth <= lo and hi <= b - depth for a, b in ivs)

    def add(self, i: int, lo: float, hi: float, level: int) -> bool:
        """Narrow robot ``i``'s window on ``[lo, hi]`` to level ``level`` (and every level
        below); False when that changed nothing."""
        levels = self.regions[i]
        before = [list(v) for v in levels]
        while len(levels) < level:
            levels.append([])
        for k in range(level):
            levels[k] = _union(levels[k] + [(float(lo), float(hi))])
        return levels != before

    def robots(self) -> list[int]:
        """Indices of the robots with at least one narrowed stretch."""
        return [i for i, r in enumerate(self.regions) if r]

    def max_level(self) -> int:
        return max((len(r) for r in self.regions), default=0)


def _union(ivs: list[tuple[float, float]]) -> list[tuple[float, float]]:
    out: list[tuple[float, float]] = []
    for a, b in sorted(ivs):
        if out and a <= out[-1][1]:
            out[-1] = (out[-1][0], max(out[-1][1], b))
        else:
            out.append((a, b))
    return out


def _chorded(b: np.ndarray, y: np.ndarray, ivs) -> tuple[np.ndarray, np.ndarray]:
    """The piecewise-linear path (b, y) with each interval of ``ivs`` replaced by its chord."""
    if not ivs:
        return b, y
    ends = np.array([e for iv in ivs for e in iv])
    ends = np.clip(ends, b[0], b[-1])
    inside = np.zeros(b.size, dtype=bool)
    for lo, hi in ivs:
        inside |= (b > lo) & (b < hi)
    bb = np.concatenate([b[~inside], ends])
    order = np.argsort(bb, kind="stable")
    bb = bb[order]
    yy = np.stack([np.interp(bb, b, y[:, ax]) for ax in range(2)], axis=1)
    # the ends were evaluated on the plan; duplicates (an end on a breakpoint) are dropped
    keep = np.concatenate([[True], np.diff(bb) > _KNOT_EPS])
    return bb[keep], yy[keep]


def _components(b: np.ndarray, y: np.ndarray, levels, far: float
                ) -> list[tuple[np.ndarray, np.ndarray]]:
    """Piecewise-linear components ``A_0, A_1 - A_0, ...`` of one robot's path (b, y).

    Outside ``[b[0], b[-1]]`` the path holds its end values, a corner at each end. Where
    stretches of level ``K`` cover an end, the wider components go on straight past it
    (to ``far`` steps beyond) and component ``K`` takes the difference, so the end corner
    is smoothed with the window of level ``K``, not the widest.
    """
    chorded = [_chorded(b, y, levels[k]) for k in range(len(levels))] + [(b, y)]
    comps = [chorded[0]]
    for k in range(1, len(chorded)):
        (b1, y1), (b0, y0) = chorded[k], chorded[k - 1]
        bb = np.union1d(b1, b0)
        diff = np.stack([np.interp(bb, b1, y1[:, ax]) - np.interp(bb, b0, y0[:, ax])
                         for ax in range(2)], axis=1)
        comps.append((bb, diff))
    for end, sign in ((b[0], -1.0), (b[-1], 1.0)):
        deepest = max((k for k, ivs in enumerate(levels, start=1)
                       if any(lo <= end <= hi for lo, hi in ivs)), default=0)
        if deepest == 0:
            continue
        x = end + sign * far
        moved = np.zeros(2)
        for k in range(deepest):
            cb, cy = comps[k]
            j0, j1 = (0, 1) if sign < 0 else (-2, -1)
            h = cb[j1] - cb[j0]
            slope = (cy[j1] - cy[j0]) / h if h > 0 else np.zeros(2)
            value = cy[j1 if sign > 0 else j0] + slope * (x - end)
            moved += value - cy[j1 if sign > 0 else j0]
            comps[k] = _with_point(cb, cy, x, value, sign)
        cb, cy = comps[deepest]
        at_end = cy[-1] if sign > 0 else cy[0]
        comps[deepest] = _with_point(cb, cy, x, at_end - moved, sign)
    return comps


def _with_point(b: np.ndarray, y: np.ndarray, x: float, value: np.ndarray, sign: float):
    """(b, y) with the breakpoint (x, value) added before the first (sign < 0) or after the last."""
    if sign > 0:
        return np.append(b, x), np.vstack([y, value])
    return np.insert(b, 0, x), np.vstack([value, y])


def _sum_pieces(parts: list[tuple[np.ndarray, np.ndarray]], end_value: np.ndarray,
                start_value: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Sum of piecewise polynomials (knots (m,), coef (m, 2, 4)) on one domain."""
    knots = np.unique(np.concatenate([k for k, _ in parts]))
    keep = np.concatenate([[True], np.diff(knots) > _KNOT_EPS])
    knots = knots[keep]
    coef = np.zeros((knots.size, 2, 4))
    mids = 0.5 * (knots[:-1] + knots[1:])
    for kn, cf in parts:
        piece = np.clip(np.searchsorted(kn, mids, side="right") - 1, 0, kn.size - 2)
        x = (knots[:-1] - kn[piece])[:, None]
        p0, p1, p2, p3 = (cf[piece, :, j] for j in range(4))
        coef[:-1, :, 0] += p0 + x * (p1 + x * (p2 + x * p3))
        coef[:-1, :, 1] += p1 + x * (2.0 * p2 + 3.0 * x * p3)
        coef[:-1, :, 2] += p2 + 3.0 * x * p3
        coef[:-1, :, 3] += p3
    coef[0, :, 0] = start_value
    coef[-1, :, :] = 0.0
    coef[-1, :, 0] = end_value
    return knots, coef


def smooth_plan_local(plan: Plan, window_steps: np.ndarray, regions: WindowRegions,
                      pad_steps: float, base: SmoothPath | None = None) -> SmoothPath:
    """Running-average smoothing, window ``window_steps[i]`` (n,) for robot ``i`` except on
    its :class:`WindowRegions` stretches (see the module docstring); domain padding
    ``pad_steps`` (at least half the widest window). ``base``: the plain smoothing of
    the same plan, windows and padding, if already computed."""
    local = regions.robots()
    if base is None:
        base = smooth_plan(plan, method="average", window_steps=window_steps,
                           pad_steps=pad_steps)
    if not local:
        return base
    pad = float(pad_steps)
    s_end = base.s_end
    # every component of every narrowed robot, as one CSR batch for the box-filter kernel
    comp_b, comp_y, comp_w, owner = [], [], [], []
    for i in local:
        b, y = plan.path(i)
        far = pad + float(window_steps[i])
        for k, (cb, cy) in enumerate(_components(b.astype(np.float64), y, regions.regions[i],
                                                 far)):
            comp_b.append(cb + pad)
            comp_y.append(cy)
            comp_w.append(float(window_steps[i]) / regions.factor ** k)
            owner.append(i)
    ptr_in = np.concatenate([[0], np.cumsum([c.size for c in comp_b])]).astype(np.int64)
    ptr, knots, coef = average_all(ptr_in, np.ascontiguousarray(np.concatenate(comp_b)),
                                    np.ascontiguousarray(np.concatenate(comp_y)),
                                    np.asarray(comp_w), s_end)
    summed: dict[int, list] = {}
    for c, i in enumerate(owner):
        summed.setdefault(i, []).append((knots[ptr[c]:ptr[c + 1]], coef[ptr[c]:ptr[c + 1]]))
    # splice: the narrowed robots' new pieces replace their base pieces
    out_knots, out_coef, out_ptr = [], [], [0]
    start, end = base.start(), base.end()
    for i in range(plan.n_robots):
        if i in summed:
            kn, cf = _sum_pieces(summed[i], end[i], start[i])
        else:
            kn, cf = base.knots[base.ptr[i]:base.ptr[i + 1]], base.coef[base.ptr[i]:base.ptr[i + 1]]
        out_knots.append(kn)
        out_coef.append(cf)
        out_ptr.append(out_ptr[-1] + kn.size)
    return SmoothPath(base.robot_ids, "average", base.window_steps, pad, s_end,
                      np.asarray(out_ptr, dtype=np.int64), np.concatenate(out_knots),
                      np.concatenate(out_coef))
