"""Per-group work of the pipeline: time, sample and simplify one group; assemble the groups.

A group (robots sharing one path parameter, :func:`rfp_twin.planners.postprocess.timing.interaction_groups`)
is timed by :func:`rfp_twin.planners.postprocess.timing.time_group`, sampled every ``sample_s`` seconds and
each of its ``2k`` axes reduced by RDP (:func:`rfp_twin.planners.postprocess.simplify.simplify_columns`);
a group whose piecewise-linear output exceeds the limits anyway (rounding) is slowed
down uniformly (:func:`time_and_simplify`). :func:`assemble` places the groups in time
(aligned on their end or their start) and builds the firmware trajectory, with the
plan's exact first and last configurations.

Units: degrees, seconds; samples ``Y`` are (S, 2k) arrays (alpha, beta of each robot).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rfp_twin.models.trajectory import Trajectory
from rfp_twin.planners.plan import Plan
from rfp_twin.planners.postprocess.simplify import simplify_columns
from rfp_twin.planners.postprocess.smoothing import SmoothPath
from rfp_twin.planners.postprocess.timing import TimeLaw, pl_kinematics, time_group

__all__ = ["TimedGroup", "time_and_simplify", "group_offsets", "assemble"]


@dataclass
class TimedGroup:
    """One group, timed and simplified (its time law runs ``scale`` times slower)."""

    robots: np.ndarray
    law: TimeLaw
    scale: float
    t: np.ndarray          # (S,) sample times (unscaled), s
    Y: np.ndarray          # (S, 2k) dense samples
    keep: np.ndarray       # (S, 2k) kept by RDP
    tol_used: np.ndarray   # (2k,)

    @property
    def duration(self) -> float:
        return self.scale * float(self.t[-1])


def time_and_simplify(path: SmoothPath, robots: np.ndarray, vmax, amax, tol_robot: np.ndarray, *,
                      grid_steps: float, backend: str, sample_s: float, max_points: int,
                      moving_range: np.ndarray, limits: np.ndarray | None = None) -> TimedGroup:
    """Time the group ``robots`` (k,), sample it and simplify every axis.

    ``vmax``, ``amax`` (2,) axis limits, deg/s and deg/s^2; ``tol_robot`` (n,) RDP
    tolerance per robot, deg; ``limits`` (n, 2, 2) each robot's joint limits (robot,
    axis, lo/hi), deg; the other keywords as :func:`rfp_twin.planners.postprocess.postprocess`.
    """
    law = time_group(path, robots, vmax, amax, grid_steps=grid_steps, backend=backend,
                     moving_range=moving_range)
    T = law.duration
    if T > 0:
        n = int(math.floor(T / sample_s))
        t = np.arange(n + 1) * sample_s
        if T - t[-1] > 1e-9 * max(1.0, T):
            t = np.append(t, T)
        else:
            t[-1] = T
    else:
        t = np.zeros(1)
    s = law.s_at(t)
    k = robots.size
    Y = path.evaluate(s, robots, 0).reshape(t.size, 2 * k)
    if limits is not None:
        # the smoothed path is an average of in-limit angles; the local windows' sum of
        # components can round a hair outside (-2e-14 deg at a 0 deg limit)
        Y = np.minimum(np.maximum(Y, limits[robots, :, 0].ravel()), limits[robots, :, 1].ravel())
    tol = np.repeat(tol_robot[robots], 2)
    keep, used = simplify_columns(t, Y, tol, max_points)
    # limits on the piecewise-linear product; a uniform slow-down fixes any excess
    ratio = 1.0
    for c in range(2 * k):
        m = keep[:, c]
        vm, am = pl_kinematics(t[m], Y[m, c])
        ratio = max(ratio, vm / vmax[c % 2], math.sqrt(am / amax[c % 2]))
    scale = ratio * (1.0 + 1e-9) if ratio > 1.0 else 1.0
    return TimedGroup(robots, law, scale, t, Y, keep, used)



def group_members(labels: np.ndarray) -> dict[int, np.ndarray]:
    """Robot indices (increasing, int64) of every group label in ``labels`` (n,), by one
    stable sort (``np.flatnonzero(labels == g)`` for each g, without a pass per group)."""
    labels = np.asarray(labels)
    order = np.argsort(labels, kind="stable")
    keys, first = np.unique(labels[order], return_index=True)
    return {int(k): order[a:b].astype(np.int64) for k, a, b in
            zip(keys, first, np.r_[first[1:], len(order)])}


def group_offsets(groups: dict, align: str) -> dict:
    """Start time of each group, s: all end with the longest ("end") or start at 0 ("start")."""
    T = max((g.duration for g in groups.values()), default=0.0)
    return {k: (T - g.duration if align == "end" else 0.0) for k, g in groups.items()}


def assemble(plan: Plan, groups: dict, align: str, start_cfg, end_cfg,
             robots: np.ndarray | None = None) -> Trajectory:
    """The trajectory of all groups (by label), ends set to ``start_cfg``, ``end_cfg`` (n, 2);
    with ``robots`` (indices, increasing), only those robots (the groups still placed in
    time with all of them)."""
    n = plan.n_robots
    offsets = group_offsets(groups, align)
    times: tuple[list, list] = ([None] * n, [None] * n)   # type: ignore[list-item]
    angles: tuple[list, list] = ([None] * n, [None] * n)  # type: ignore[list-item]
    wanted = None
    if robots is not None:
        wanted = np.zeros(n, dtype=bool)
        wanted[robots] = True
    for key, g in groups.items():
        off = offsets[key]
        for r, i in enumerate(g.robots):
            if wanted is not None and not wanted[i]:
                continue
            for ax in range(2):
                c = 2 * r + ax
                m = g.keep[:, c]
                tt = off + g.scale * g.t[m]
                yy = g.Y[m, c].copy()
                yy[0] = start_cfg[i, ax]
                yy[-1] = end_cfg[i, ax]
                if yy.size == 2 and yy[0] == yy[1]:
                    tt, yy = tt[:1], yy[:1]
                times[ax][i] = tt
                angles[ax][i] = yy
    keep = range(n) if robots is None else [int(i) for i in robots]
    return Trajectory(np.asarray(plan.robot_ids, dtype=np.int64)[list(keep)],
                      tuple(tuple(times[ax][i] for i in keep) for ax in range(2)),
                      tuple(tuple(angles[ax][i] for i in keep) for ax in range(2)))

