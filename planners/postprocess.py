"""From a stepwise plan to firmware-ready trajectories, re-verified (Sayres 2021 Sect. 6).

Pipeline (:func:`postprocess`):

0. **Pre-simplify** (:func:`planners.simplify.simplify_plan`): each robot's stepwise
   breakpoints are reduced by RDP within ``presimplify_deg`` on both axes (at equal
   plan step), so the smoothed path of the reduced plan is within ``presimplify_deg``
   of the smoothed plan (the running average is an average: it does not increase a
   sup-norm difference). Markov plans have a breakpoint nearly every step; their
   one-step wiggles cost knots and gridpoints, and time where the wiggles are wider
   than the window.
1. **Smooth** (:mod:`planners.smoothing`): the running-average velocity filter turns
   each robot's stepwise path into a C1 path ``q_i(s)`` of the plan step ``s``. The
   default window spans the time an axis needs to reach full speed (``v / a``;
   :func:`planners.smoothing.window_for_limits`, 200 steps for SDSS-V at 0.1 deg):
   starts and stops then cost no slow-down, and one-step wiggles vanish.
2. **Group** (:mod:`planners.timing`): neighbour pairs whose clearance falls below
   ``interaction_mm`` at some step of the plan are edges; each connected component
   shares one path parameter, the other robots are timed alone.
3. **Time** (:mod:`planners.timing`): time-optimal ``s(t)`` per group (TOPP-RA, by the
   ``toppra`` library or the numba kernel: ``backend``) under the spec's per-axis
   velocity and acceleration limits, from rest to rest. Groups are
   aligned on their end: every robot arrives when the slowest group does, as in the
   plan every robot arrives on its last step.
4. **Sample and simplify** (:mod:`planners.simplify`): each group is sampled every
   ``sample_s`` seconds and every axis reduced by Ramer-Douglas-Peucker to at most
   ``max_points`` points within ``tolerance_deg`` of the samples. The kept points are
   exact samples of the timed path, so their slopes and three-point accelerations (the
   definitions of :func:`planners.timing.pl_kinematics`) are within the limits; a group
   whose measured values exceed them anyway (rounding) is slowed down uniformly.
5. **Verify**: the ``verifier`` handed in by the caller (the pipeline passes the
   independent 2D checker of ``validation/``; planners never import it) at ``buffer_mm -
   budget_mm`` (Eq. 12's sigma_smooth, 0.03 mm by default). A collision between two
   groups merges them (they met at different ``s``); a collision inside a group, or
   with a fiducial, halves the smoothing window, the tolerance and the
   pre-simplification tolerance of the robots involved (they deviate too far from the
   plan). The touched groups are redone and
   checked again with their neighbours: the other pairs did not change (up to one
   common time shift when the longest group changes), so their earlier result stands.
   At most ``max_retries`` rounds; a trajectory that does not pass is never returned
   (:class:`models.errors.PlanningError`).

The trajectory starts exactly at the plan's first configuration and ends exactly at
its last (the plan is given in the executed direction, fold -> targets).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, fields
from typing import Any, Callable

import numpy as np

from models.array import ArrayGeometry
from models.errors import PlanningError, SpecError, field_error
from models.trajectory import Trajectory
from planners.plan import Plan
from planners.simplify import simplify_columns, simplify_plan
from planners.smoothing import (METHODS, SmoothPath, plan_deviation, smooth_plan,
                                window_for_limits)
from planners.timing import (BACKENDS, DEFAULT_BACKEND, TimeLaw, interaction_groups,
                             interaction_pairs, pl_kinematics, time_group)

#: ``verifier(trajectory, spec, layout, buffer_mm) -> report`` (see :func:`postprocess`).
Verifier = Callable[..., Any]

__all__ = ["PostprocessReport", "Verifier", "TimedPath", "postprocess", "DEFAULT_BUDGET_MM",
           "DEFAULT_TOLERANCE_DEG", "DEFAULT_PRESIMPLIFY_DEG", "DEFAULT_INTERACTION_MM",
           "DEFAULT_MAX_POINTS", "ALIGNMENTS"]

#: sigma_smooth of Sayres 2021 Eq. 12, mm.
DEFAULT_BUDGET_MM = 0.03
#: Firmware limit of (angle, time) points per axis (Sayres 2021 Sect. 6).
DEFAULT_MAX_POINTS = 1024
#: RDP tolerance, deg. Measured on the 500-robot SDSS-V layout (benchmarks/RESULTS.md):
#: 0.02 / 0.05 / 0.1 / 0.2 deg give a median of 37 / 22 / 18 / 12 points per axis at the
#: same fold time and verification rounds. 0.1 deg moves a point of the beta collision
#: segment by at most (7.4 + 2 * 14.7) mm * 0.1 deg = 0.064 mm, small next to the
#: smoothing itself; robots near contact get it halved by the verification loop.
DEFAULT_TOLERANCE_DEG = 0.1
#: RDP tolerance of the stepwise plan before smoothing, deg (0: off). Measured on the
#: 500-robot SDSS-V layout, step 0.1 deg, 2.0 mm (benchmarks/RESULTS.md): Markov plans
#: ~980k breakpoints -> ~200k, post-processing 2.7-3.2 s -> 1.4-1.8 s and folds 2.6-6.9 s
#: shorter (the wiggles are gone); greedy plans 14-20k -> 3-6k breakpoints, the same
#: time, folds 0.1-0.4 s shorter. 0.2 deg moves a point of the beta collision segment by at
#: most 0.13 mm before smoothing; robots that come too close get it halved.
DEFAULT_PRESIMPLIFY_DEG = 0.2
#: Pairs whose clearance falls below this at some step of the plan share one path
#: parameter, mm. 0.3 / 1 / 2 mm gave the same fold times on the 500-robot layout; 1 mm
#: (half a buffer) needed no group merge in verification there, 0.3 mm one.
DEFAULT_INTERACTION_MM = 1.0
ALIGNMENTS = ("end", "start")
#: Smallest window / tolerance that tightening goes down to.
_MIN_WINDOW_STEPS = 1.0
_MIN_TOLERANCE_DEG = 1e-3
#: Factor by which a colliding robot's window (then tolerance) shrinks per retry.
_TIGHTEN = 2.0


# =====================================================================================
# Report
# =====================================================================================
@dataclass(frozen=True)
class TimedPath:
    """The smooth, timed motion that the returned trajectory simplifies.

    Robot ``i`` of group ``g = labels[i]`` is at ``path.evaluate(s)`` with ``s =
    laws[g].s_at((t - offsets[g]) / scales[g])`` at time ``t``.

    Attributes
    ----------
    path : SmoothPath
    labels : (n,) group of each robot
    laws, offsets, scales : dicts keyed by group: TimeLaw, start time (s), slow-down >= 1
    window_steps : (n,) smoothing window each robot ended with, plan steps
    tolerance_deg : (n,) RDP tolerance each robot ended with (largest of its axes), deg
    """

    path: SmoothPath
    labels: np.ndarray
    laws: dict
    offsets: dict
    scales: dict
    window_steps: np.ndarray
    tolerance_deg: np.ndarray

    def sample(self, times) -> np.ndarray:
        """Angles at the given times: (len(times), n, 2) deg."""
        times = np.atleast_1d(np.asarray(times, dtype=np.float64))
        out = np.empty((times.size, self.labels.size, 2))
        for g, law in self.laws.items():
            robots = np.flatnonzero(self.labels == g)
            s = law.s_at((times - self.offsets[g]) / self.scales[g])
            out[:, robots, :] = self.path.evaluate(s, robots, 0)
        return out

    def group_durations(self) -> dict:
        """Duration of each group's motion, s."""
        return {g: law.duration * self.scales[g] for g, law in self.laws.items()}


@dataclass
class PostprocessReport:
    """Every figure of one post-processing run (units in the names).

    ``max_speed_deg_s`` / ``max_accel_deg_s2`` are measured on the returned
    piecewise-linear trajectory (slope; three-point acceleration, see
    :func:`planners.timing.pl_kinematics`), per axis (alpha, beta).
    ``stage_seconds`` holds smooth, group, time, simplify, verify and total (retries
    included in each stage). ``max_slowdown`` is the largest uniform slow-down applied to
    a group to keep its piecewise-linear output within the limits (1 = none; a value
    much above 1 would mean the time law and the path disagree). ``retries`` counts
    verification rounds after the first, ``merges`` group merges, ``tightened`` robots
    whose window and tolerance were halved. ``max_smoothing_deviation_deg`` is the
    largest |smoothed - stepwise| angle at equal plan step (large where robots are free,
    by design), ``max_simplify_deviation_deg`` the largest RDP error (<= the tolerance).
    """

    buffer_mm: float
    budget_mm: float
    verify_buffer_mm: float
    smoothing: str
    window_steps: float
    min_window_steps: float
    tolerance_deg: float
    max_tolerance_used_deg: float
    max_points: int
    sample_s: float
    interaction_mm: float
    align: str
    backend: str
    n_robots: int
    n_groups: int
    largest_group: int
    n_grouped_robots: int
    duration_s: float
    plan_duration_s: float
    speed_limit_deg_s: list
    accel_limit_deg_s2: list
    max_speed_deg_s: list
    max_accel_deg_s2: list
    points_per_axis_median: float
    points_per_axis_max: int
    points_per_axis_mean: float
    max_smoothing_deviation_deg: float
    max_simplify_deviation_deg: float
    verified: bool
    min_clearance_mm: float
    check_rounds: int
    max_slowdown: float
    retries: int
    merges: int
    tightened: int
    collisions_repaired: int
    timing_solvers: dict = field(default_factory=dict)
    timing_fallbacks: int = 0
    presimplify_deg: float = 0.0
    plan_breakpoints: int = 0
    smoothed_breakpoints: int = 0
    stage_seconds: dict = field(default_factory=dict)
    #: The smooth timed motion behind the trajectory (not serialised).
    timed: TimedPath | None = field(default=None, repr=False, compare=False)
    #: The verifier's report on the whole returned trajectory, when its last round
    #: checked all of it (not serialised); else None.
    final_check: Any = field(default=None, repr=False, compare=False)

    def to_dict(self) -> dict:
        """JSON-ready figures (everything but ``timed``; non-finite numbers become None)."""
        d = {f.name: getattr(self, f.name) for f in fields(self) if f.name not in ("timed", "final_check")}
        d["stage_seconds"] = dict(d["stage_seconds"])
        d["timing_solvers"] = dict(d["timing_solvers"])
        for k, v in d.items():
            if isinstance(v, float) and not math.isfinite(v):
                d[k] = None
        return d

    def table(self) -> str:
        st = self.stage_seconds
        lines = [
            f"post-processing: {'verified' if self.verified else 'NOT VERIFIED'} at "
            f"{self.verify_buffer_mm:.3f} mm (buffer {self.buffer_mm:.3f} - budget "
            f"{self.budget_mm:.3f} mm), min clearance {self.min_clearance_mm:.4f} mm",
            f"  fold time {self.duration_s:.2f} s (stepwise plan {self.plan_duration_s:.2f} s); "
            f"groups {self.n_groups} (largest {self.largest_group}, "
            f"{self.n_grouped_robots} robots grouped)",
            f"  max |v| {self.max_speed_deg_s[0]:.2f} / {self.max_speed_deg_s[1]:.2f} deg/s "
            f"(limit {self.speed_limit_deg_s[0]:g}), max |a| {self.max_accel_deg_s2[0]:.1f} / "
            f"{self.max_accel_deg_s2[1]:.1f} deg/s^2 (limit {self.accel_limit_deg_s2[0]:g})",
            f"  points per axis median {self.points_per_axis_median:.0f}, max "
            f"{self.points_per_axis_max} (<= {self.max_points}); tolerance "
            f"{self.tolerance_deg:g} deg; retries {self.retries}",
            f"  breakpoints {self.plan_breakpoints} -> {self.smoothed_breakpoints} smoothed "
            f"(pre-simplified within {self.presimplify_deg:g} deg)",
            f"  timing: {self.backend} backend, groups by solver "
            + ", ".join(f"{k} {v}" for k, v in sorted(self.timing_solvers.items()))
            + f"; fallbacks {self.timing_fallbacks}",
            "  stages " + ", ".join(f"{k} {v:.3f} s" for k, v in st.items()),
        ]
        return "\n".join(lines)


# =====================================================================================
# Per-group work
# =====================================================================================
@dataclass
class _Group:
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


def _do_group(path: SmoothPath, robots: np.ndarray, vmax, amax, tol_robot: np.ndarray, *,
              grid_steps: float, backend: str, sample_s: float, max_points: int,
              moving_range: np.ndarray) -> _Group:
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
    tol = np.repeat(tol_robot[robots], 2)
    keep, used = simplify_columns(t, Y, tol, max_points)
    # limits on the piecewise-linear product; a uniform slow-down fixes any excess
    ratio = 1.0
    for c in range(2 * k):
        m = keep[:, c]
        vm, am = pl_kinematics(t[m], Y[m, c])
        ratio = max(ratio, vm / vmax[c % 2], math.sqrt(am / amax[c % 2]))
    scale = ratio * (1.0 + 1e-9) if ratio > 1.0 else 1.0
    return _Group(robots, law, scale, t, Y, keep, used)


# =====================================================================================
# Pipeline
# =====================================================================================
def _resolve_geometry(geom_or, buffer_mm) -> tuple[ArrayGeometry, float]:
    if isinstance(geom_or, ArrayGeometry):
        b = float(geom_or.buffer_mm if buffer_mm is None else buffer_mm)
        if b != geom_or.buffer_mm:
            geom_or = ArrayGeometry(geom_or.spec, geom_or.layout, b)
        return geom_or, b
    try:
        spec, layout = geom_or
    except (TypeError, ValueError):
        raise field_error(SpecError, "geom", type(geom_or).__name__,
                          "an ArrayGeometry or a (RobotSpec, Layout) pair", "postprocess") from None
    b = float(spec.buffer_mm if buffer_mm is None else buffer_mm)
    return ArrayGeometry(spec, layout, b), b


def postprocess(plan: Plan, geom, buffer_mm: float | None = None, *,
                budget_mm: float = DEFAULT_BUDGET_MM,
                max_points: int = DEFAULT_MAX_POINTS,
                tolerance_deg: float = DEFAULT_TOLERANCE_DEG,
                presimplify_deg: float = DEFAULT_PRESIMPLIFY_DEG,
                smoothing: str = "average",
                window_steps: float | None = None,
                interaction_mm: float = DEFAULT_INTERACTION_MM,
                sample_s: float = 0.01,
                grid_steps: float = 4.0,
                align: str = "end",
                backend: str = DEFAULT_BACKEND,
                max_retries: int = 8,
                verifier: Verifier | None) -> tuple[Trajectory, PostprocessReport]:
    """Smooth, time, simplify and re-verify a plan (see the module docstring).

    Parameters
    ----------
    plan : Plan in the executed direction; robots in the order of ``geom``
    geom : ArrayGeometry, or a (RobotSpec, Layout) pair
    buffer_mm : planning buffer sigma_cb, mm [default: the geometry's / spec's]
    budget_mm : post-processing share of the buffer (Eq. 12 sigma_smooth); the result
        is verified at ``buffer_mm - budget_mm``
    max_points : most (angle, time) points per axis (firmware: 1024)
    tolerance_deg : RDP tolerance, deg (raised per axis only if ``max_points`` forces it)
    presimplify_deg : RDP tolerance of the stepwise plan before smoothing, deg (0: off)
    smoothing, window_steps : method and initial window (plan steps) of
        :func:`planners.smoothing.smooth_plan` [default window:
        :func:`planners.smoothing.window_for_limits` of the spec and the plan's step]
    interaction_mm : clearance below which two robots share one path parameter, mm
    sample_s : time step of the dense samples that RDP reduces, s
    grid_steps : longest TOPP-RA grid interval, plan steps
    align : "end" (all groups arrive together) or "start" (all start at t = 0)
    backend : "toppra" (default: the library; a group it finds no solution for is timed
        by the numba kernel and counted in the report's ``timing_fallbacks``) or "numba"
        (the kernel only: the same trajectories 3-5x faster, e.g. for Markov plans)
        (:func:`planners.timing.time_group`)
    max_retries : verification rounds after the first
    verifier : ``verifier(trajectory, spec, layout, buffer_mm) -> report`` with ``ok``,
        ``collisions``, ``pair_ids``, ``pair_min_distance_mm``, ... (the 2D checker of
        ``validation/``); required, so that nobody forgets it: ``None`` skips the
        verification (timing studies only; the report then says so). When the last
        round checked the whole trajectory, its report is ``report.final_check``.

    Returns
    -------
    (Trajectory, PostprocessReport)

    Raises
    ------
    SpecError : a parameter out of range
    PlanningError : no collision-free result within ``max_retries``
    """
    clock = time.perf_counter()
    geom, buffer_mm = _resolve_geometry(geom, buffer_mm)
    spec = geom.spec
    vmax = np.asarray(spec.max_speed_deg_s, dtype=np.float64)
    amax = np.asarray(spec.max_accel_deg_s2, dtype=np.float64)
    if window_steps is None:
        window_steps = window_for_limits(spec.max_speed_deg_s, spec.max_accel_deg_s2, plan.step_deg)
    _check_args(budget_mm, buffer_mm, max_points, tolerance_deg, smoothing, window_steps,
                interaction_mm, sample_s, grid_steps, align, backend, max_retries)
    if not (np.isfinite(presimplify_deg) and 0.0 <= presimplify_deg <= 10.0):
        raise field_error(SpecError, "presimplify_deg", presimplify_deg, "[0, 10] deg",
                          "postprocess")
    if plan.n_robots != geom.n_robots or not np.array_equal(plan.robot_ids, geom.robot_ids):
        raise field_error(SpecError, "plan.robot_ids", f"{plan.n_robots} robots",
                          f"the {geom.n_robots} robots of the layout, in layout order", "postprocess")
    n = plan.n_robots
    verify_buffer = buffer_mm - budget_mm
    stages = {"smooth": 0.0, "group": 0.0, "time": 0.0, "simplify": 0.0, "verify": 0.0}

    # 1. smoothing
    t0 = time.perf_counter()
    window = np.full(n, float(window_steps))
    pre = np.full(n, float(presimplify_deg))
    pad = float(window_steps) / 2.0
    path, n_smoothed = _smooth(plan, smoothing, window, pad, pre)
    stages["smooth"] += time.perf_counter() - t0

    # 2. grouping
    t0 = time.perf_counter()
    pairs, clear = interaction_pairs(plan, geom, interaction_mm)
    labels = interaction_groups(n, pairs[clear < interaction_mm])
    stages["group"] += time.perf_counter() - t0

    tol = np.full(n, float(tolerance_deg))
    groups: dict[int, _Group] = {}
    dirty = set(np.unique(labels).tolist())
    changed = np.ones(n, dtype=bool)           # robots whose trajectory changed since last check
    id_index = {int(r): i for i, r in enumerate(plan.robot_ids)}
    start_cfg, end_cfg = plan.start(), plan.end()
    near = _verify_neighbours(geom, verify_buffer) if verifier is not None else None
    ledger = _ClearanceLedger(2.0 * verify_buffer, verify_buffer + spec.fiducial_buffer_mm)

    rounds = retries = merges = tightened = repaired = 0
    traj = None
    while True:
        # 3-4. time, sample, simplify the groups that changed
        t0 = time.perf_counter()
        mrange = path.moving_range()
        for g in sorted(dirty):
            robots = np.flatnonzero(labels == g)
            if robots.size:
                groups[g] = _do_group(path, robots, vmax, amax, tol, grid_steps=grid_steps,
                                      backend=backend, sample_s=sample_s,
                                      max_points=max_points, moving_range=mrange)
        for g in list(groups):
            if not np.any(labels == g):
                del groups[g]
        stages["time"] += time.perf_counter() - t0
        dirty = set()
        t0 = time.perf_counter()
        traj = _assemble(plan, groups, align, start_cfg, end_cfg)
        stages["simplify"] += time.perf_counter() - t0
        if verifier is None:
            break
        # 5. verification: everything in the first round, then the robots whose
        #    trajectory changed and their neighbours (other pairs are unchanged up to a
        #    common time shift, so their earlier result stands)
        t0 = time.perf_counter()
        if rounds == 0:
            sub = traj
        else:
            sel = np.flatnonzero(changed | (near @ changed.astype(np.int64) > 0))
            sub = _subset(traj, sel)
        check = verifier(sub, spec, geom.layout, verify_buffer)
        ledger.update(check)
        stages["verify"] += time.perf_counter() - t0
        rounds += 1
        changed[:] = False
        if check.ok:
            break
        if retries >= max_retries:
            c = check.collisions[0]
            raise PlanningError(
                f"post-processing: {len(check.collisions)} collision(s) remain at "
                f"{verify_buffer:.3f} mm after {retries} retries (first: robot {c.robot_a} and "
                f"{c.kind} {c.other} at t = {c.t_min:.3f} s, {c.min_distance_mm:.4f} mm); "
                "allowed: a larger budget_mm, a smaller window_steps / tolerance_deg, or a "
                "larger interaction_mm")
        retries += 1
        repaired += len(check.collisions)
        touched = set()
        for c in check.collisions:
            a = id_index[c.robot_a]
            if c.kind == "robot":
                b = id_index[c.other]
                if labels[a] != labels[b]:
                    # timed apart, they met at different s: one path parameter from now on
                    labels[labels == labels[b]] = labels[a]
                    merges += 1
                    dirty.add(int(labels[a]))
                    continue
                touched.update((a, b))
            else:
                touched.add(a)
        for i in touched:
            # both deviations from the plan: smoothing and simplification
            if window[i] <= _MIN_WINDOW_STEPS and tol[i] <= _MIN_TOLERANCE_DEG and pre[i] == 0.0:
                continue
            window[i] = max(_MIN_WINDOW_STEPS, window[i] / _TIGHTEN)
            tol[i] = max(_MIN_TOLERANCE_DEG, tol[i] / _TIGHTEN)
            pre[i] = pre[i] / _TIGHTEN if pre[i] / _TIGHTEN >= _MIN_TOLERANCE_DEG else 0.0
            tightened += 1
            dirty.add(int(labels[i]))
        if not dirty:
            c = check.collisions[0]
            raise PlanningError(
                f"post-processing: robot {c.robot_a} and {c.kind} {c.other} collide at "
                f"{verify_buffer:.3f} mm with the smallest window and tolerance; allowed: a "
                "larger budget_mm")
        if touched:
            t0 = time.perf_counter()
            path, n_smoothed = _smooth(plan, smoothing, window, pad, pre)
            stages["smooth"] += time.perf_counter() - t0
        for g in dirty:
            changed[labels == g] = True

    report = _report(plan, traj, groups, labels, path, ledger if verifier is not None else None, spec,
                     buffer_mm, budget_mm, verify_buffer, smoothing, window_steps, window,
                     tolerance_deg, max_points, sample_s, interaction_mm, align, backend, rounds,
                     retries, merges, tightened, repaired, stages, clock)
    report.presimplify_deg = float(presimplify_deg)
    report.plan_breakpoints = int(plan.path_step.size)
    report.smoothed_breakpoints = n_smoothed
    report.final_check = check if verifier is not None and sub is traj else None
    return traj, report


class _ClearanceLedger:
    """Latest checked minimum distance of every pair, over all verification rounds."""

    def __init__(self, thr_robot: float, thr_fid: float) -> None:
        self.thr_robot = thr_robot
        self.thr_fid = thr_fid
        self.robot: dict[tuple[int, int], float] = {}
        self.fid: dict[tuple[int, int], float] = {}
        self.ok = False

    def update(self, check) -> None:
        for (a, b), d in zip(check.pair_ids.tolist(), check.pair_min_distance_mm.tolist()):
            self.robot[(min(a, b), max(a, b))] = d
        for (a, f), d in zip(check.fiducial_pair_ids.tolist(),
                             check.fiducial_min_distance_mm.tolist()):
            self.fid[(a, f)] = d
        for c in check.collisions:
            table = self.robot if c.kind == "robot" else self.fid
            key = (min(c.robot_a, c.other), max(c.robot_a, c.other)) if c.kind == "robot" \
                else (c.robot_a, c.other)
            table[key] = min(table.get(key, math.inf), c.min_distance_mm)
        self.ok = check.ok

    def min_clearance(self) -> float:
        vals = [d - self.thr_robot for d in self.robot.values()]
        vals += [d - self.thr_fid for d in self.fid.values()]
        return float(min(vals)) if vals else math.inf


def _verify_neighbours(geom: ArrayGeometry, verify_buffer: float):
    """Sparse (n, n) adjacency of robots that the checker pairs at either buffer."""
    from scipy.sparse import csr_matrix
    from scipy.spatial import cKDTree

    spec = geom.spec
    reach = 2.0 * max(spec.collision_reach_mm(verify_buffer), spec.collision_reach_mm(geom.buffer_mm))
    xy = np.asarray(geom.base_xy)
    pr = cKDTree(xy).query_pairs(reach + 1e-6, output_type="ndarray") if len(xy) > 1 \
        else np.zeros((0, 2), dtype=np.int64)
    n = xy.shape[0]
    rows = np.concatenate([pr[:, 0], pr[:, 1]])
    cols = np.concatenate([pr[:, 1], pr[:, 0]])
    return csr_matrix((np.ones(rows.size, dtype=np.int64), (rows, cols)), shape=(n, n))


def _subset(traj: Trajectory, sel: np.ndarray) -> Trajectory:
    return Trajectory(traj.robot_ids[sel],
                      tuple(tuple(traj.times[ax][i] for i in sel) for ax in range(2)),
                      tuple(tuple(traj.angles[ax][i] for i in sel) for ax in range(2)))


def _smooth(plan: Plan, method: str, window: np.ndarray, pad: float,
            pre: np.ndarray) -> tuple[SmoothPath, int]:
    """Pre-simplify (tolerance ``pre`` per robot) and smooth: (path, breakpoints smoothed)."""
    src = simplify_plan(plan, pre) if np.any(pre > 0.0) else plan
    return (smooth_plan(src, method=method, window_steps=window, pad_steps=pad),
            int(src.path_step.size))


def _offsets(groups: dict, align: str) -> dict:
    T = max((g.duration for g in groups.values()), default=0.0)
    return {k: (T - g.duration if align == "end" else 0.0) for k, g in groups.items()}


def _assemble(plan: Plan, groups: dict, align: str, start_cfg, end_cfg) -> Trajectory:
    n = plan.n_robots
    offsets = _offsets(groups, align)
    times: tuple[list, list] = ([None] * n, [None] * n)   # type: ignore[list-item]
    angles: tuple[list, list] = ([None] * n, [None] * n)  # type: ignore[list-item]
    for key, g in groups.items():
        off = offsets[key]
        for r, i in enumerate(g.robots):
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
    return Trajectory(np.asarray(plan.robot_ids, dtype=np.int64),
                      (tuple(times[0]), tuple(times[1])), (tuple(angles[0]), tuple(angles[1])))


def _report(plan, traj, groups, labels, path, ledger, spec, buffer_mm, budget_mm, verify_buffer,
            smoothing, window_steps, window, tolerance_deg, max_points, sample_s,
            interaction_mm, align, backend, rounds, retries, merges, tightened, repaired,
            stages, clock) -> PostprocessReport:
    vm = np.zeros(2)
    am = np.zeros(2)
    for ax in range(2):
        for i in range(traj.n_robots):
            v, a = pl_kinematics(traj.times[ax][i], traj.angles[ax][i])
            vm[ax] = max(vm[ax], v)
            am[ax] = max(am[ax], a)
    counts = traj.point_counts()
    sizes = np.bincount(np.unique(labels, return_inverse=True)[1])
    simp_dev = 0.0
    tol_used = 0.0
    for g in groups.values():
        tol_used = max(tol_used, float(g.tol_used.max()) if g.tol_used.size else 0.0)
        for c in range(g.Y.shape[1]):
            m = g.keep[:, c]
            if m.sum() < g.t.size:
                simp_dev = max(simp_dev, float(np.max(np.abs(
                    np.interp(g.t, g.t[m], g.Y[m, c]) - g.Y[:, c]))))
    smooth_dev = float(plan_deviation(plan, path).max()) if plan.n_robots else 0.0
    tol_robot = np.zeros(plan.n_robots)
    for g in groups.values():
        tol_robot[g.robots] = g.tol_used.reshape(-1, 2).max(axis=1)
    timed = TimedPath(path, labels.copy(), {k: g.law for k, g in groups.items()},
                      _offsets(groups, align), {k: g.scale for k, g in groups.items()},
                      window.copy(), tol_robot)
    solvers: dict = {}
    for g in groups.values():
        solvers[g.law.solver] = solvers.get(g.law.solver, 0) + 1
    stages = dict(stages)
    stages["total"] = time.perf_counter() - clock
    return PostprocessReport(
        buffer_mm=float(buffer_mm), budget_mm=float(budget_mm), verify_buffer_mm=float(verify_buffer),
        smoothing=smoothing, window_steps=float(window_steps), min_window_steps=float(window.min()),
        tolerance_deg=float(tolerance_deg), max_tolerance_used_deg=tol_used,
        max_points=int(max_points), sample_s=float(sample_s), interaction_mm=float(interaction_mm),
        align=align, backend=backend, n_robots=int(plan.n_robots), n_groups=int(sizes.size),
        largest_group=int(sizes.max()) if sizes.size else 0,
        n_grouped_robots=int(sizes[sizes > 1].sum()),
        duration_s=float(traj.duration), plan_duration_s=float(plan.n_steps * plan.step_s),
        speed_limit_deg_s=[float(v) for v in spec.max_speed_deg_s],
        accel_limit_deg_s2=[float(v) for v in spec.max_accel_deg_s2],
        max_speed_deg_s=vm.tolist(), max_accel_deg_s2=am.tolist(),
        points_per_axis_median=float(np.median(counts)) if counts.size else 0.0,
        points_per_axis_max=int(counts.max()) if counts.size else 0,
        points_per_axis_mean=float(counts.mean()) if counts.size else 0.0,
        max_smoothing_deviation_deg=smooth_dev, max_simplify_deviation_deg=simp_dev,
        verified=bool(ledger is not None and ledger.ok),
        min_clearance_mm=ledger.min_clearance() if ledger is not None else math.nan,
        check_rounds=rounds,
        max_slowdown=max((g.scale for g in groups.values()), default=1.0),
        retries=retries, merges=merges, tightened=tightened, collisions_repaired=repaired,
        timing_solvers=solvers, timing_fallbacks=int(solvers.get("fallback", 0)),
        stage_seconds=stages, timed=timed)


def _check_args(budget_mm, buffer_mm, max_points, tolerance_deg, smoothing, window_steps,
                interaction_mm, sample_s, grid_steps, align, backend, max_retries) -> None:
    def bad(name, value, allowed):
        raise field_error(SpecError, name, value, allowed, "postprocess")

    if not (np.isfinite(budget_mm) and 0.0 <= budget_mm < buffer_mm):
        bad("budget_mm", budget_mm, f"[0, buffer_mm = {buffer_mm}) mm")
    if int(max_points) != max_points or max_points < 2:
        bad("max_points", max_points, "an integer >= 2")
    if not (np.isfinite(tolerance_deg) and tolerance_deg > 0):
        bad("tolerance_deg", tolerance_deg, "> 0 deg")
    if smoothing not in METHODS:
        bad("smoothing", smoothing, ", ".join(METHODS))
    if not (np.isfinite(window_steps) and 0.0 <= window_steps <= 1e4):
        bad("window_steps", window_steps, "[0, 1e4] steps")
    if not (np.isfinite(interaction_mm) and interaction_mm >= 0):
        bad("interaction_mm", interaction_mm, ">= 0 mm")
    if not (np.isfinite(sample_s) and 1e-4 <= sample_s <= 1.0):
        bad("sample_s", sample_s, "[1e-4, 1] s")
    if not (np.isfinite(grid_steps) and grid_steps > 0):
        bad("grid_steps", grid_steps, "> 0 steps")
    if align not in ALIGNMENTS:
        bad("align", align, ", ".join(ALIGNMENTS))
    if backend not in BACKENDS:
        bad("backend", backend, ", ".join(BACKENDS))
    if int(max_retries) != max_retries or max_retries < 0:
        bad("max_retries", max_retries, "an integer >= 0")
