"""From a stepwise plan to firmware-ready trajectories, re-verified (Sayres 2021 Sect. 6).

Pipeline (:func:`postprocess`):

0. **Pre-simplify** (:func:`rfp_twin.planners.postprocess.simplify.simplify_plan`): each robot's stepwise
   breakpoints are reduced by RDP within ``presimplify_deg`` on both axes (at equal
   plan step; ``wiggle_presimplify_deg`` for the robots whose path turns back more than
   :data:`WIGGLE_REVERSALS` times), so the smoothed path of the reduced plan is within
   that tolerance of the smoothed plan (the running average is an average: it does not
   increase a sup-norm difference). Markov plans have a breakpoint nearly every step; their
   one-step wiggles cost knots and gridpoints, and time where the wiggles are wider
   than the window.
1. **Smooth** (:mod:`rfp_twin.planners.postprocess.smoothing`): the running-average velocity filter turns
   each robot's stepwise path into a C1 path ``q_i(s)`` of the plan step ``s``. The
   default window spans the time an axis needs to reach full speed (``v / a``;
   :func:`rfp_twin.planners.postprocess.smoothing.window_for_limits`, 200 steps for SDSS-V at 0.1 deg):
   starts and stops then cost no slow-down, and one-step wiggles vanish.
2. **Group** (:mod:`rfp_twin.planners.postprocess.timing`): neighbour pairs whose clearance falls below
   ``interaction_mm`` at some step of the plan are edges; each connected component
   shares one path parameter, the other robots are timed alone.
3. **Time** (:mod:`rfp_twin.planners.postprocess.timing`): time-optimal ``s(t)`` per group (TOPP-RA, by the
   ``toppra`` library or the numba kernel: ``backend``) under the spec's per-axis
   velocity and acceleration limits, from rest to rest. Groups are
   aligned on their end: every robot arrives when the slowest group does, as in the
   plan every robot arrives on its last step.
4. **Sample and simplify** (:mod:`rfp_twin.planners.postprocess.simplify`): each group is sampled every
   ``sample_s`` seconds and every axis reduced by Ramer-Douglas-Peucker to at most
   ``max_points`` points within ``tolerance_deg`` of the samples. The kept points are
   exact samples of the timed path, so their slopes and three-point accelerations (the
   definitions of :func:`rfp_twin.planners.postprocess.timing.pl_kinematics`) are within the limits; a group
   whose measured values exceed them anyway (rounding) is slowed down uniformly.
5. **Verify**: the ``verifier`` handed in by the caller (the pipeline passes the
   independent 2D checker of ``validation/``; planners never import it) at ``buffer_mm -
   budget_mm`` (Eq. 12's sigma_smooth, 0.03 mm by default). A collision between two
   groups merges them (they met at different ``s``). A collision inside a group, or
   with a fiducial, means the smoothing cut a corner of the plan too close to the
   other: the window of the robots involved is narrowed (by sqrt(2) a level) **only on
   the plan steps of the collision**, plus the margins the wider windows need
   (:mod:`rfp_twin.planners.postprocess.smoothing_local`, :func:`.verification.narrow_locally`;
   stretching it over every step in which the pair stays within 0.5 mm in the plan gave
   a p95 duration ratio of 1.214 instead of 1.126, greedy + search at 2.5 mm);
   the rest of their paths keeps the full window, so the time law slows down only
   there. (Halving it along the whole path, as before, stretched the 500-robot demo's
   searched group from 13.1 s to 19.6 s.) Only a robot whose local window reached one
   step has its RDP and pre-simplification tolerances halved. The touched groups are
   redone and checked again with their neighbours: the other pairs did not change (up
   to one common time shift when the longest group changes), so their earlier result
   stands (the verifier is asked for the pairs of the changed robots only: its
   ``focus_ids``; the report's ``merged_with`` joins each re-check into the whole
   trajectory's check, which is ``report.final_check``, so the whole trajectory is never
   checked twice: 3.5-4.8 s saved at 12,871 robots). At most ``max_retries`` rounds; a
   trajectory that does not pass is never returned (:class:`rfp_twin.models.errors.PlanningError`).

The trajectory starts exactly at the plan's first configuration and ends exactly at
its last (the plan is given in the executed direction, fold -> targets).

This module is the driver loop; steps 3-4 per group are in
:mod:`rfp_twin.planners.postprocess.groups`, the bookkeeping and repair of step 5 in
:mod:`rfp_twin.planners.postprocess.verification`, the report in :mod:`rfp_twin.planners.postprocess.report`.
Units: mm, degrees, seconds, plan steps.
"""
from __future__ import annotations

import time
from typing import Any, Callable

import numpy as np

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.errors import PlanningError, SpecError, field_error
from rfp_twin.models.second_thread import second_thread
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.planners.plan import Plan
from rfp_twin.planners.postprocess.groups import (TimedGroup, assemble, group_members,
                                                  group_offsets, time_and_simplify)
from rfp_twin.planners.postprocess.limits import within_limits
from rfp_twin.planners.postprocess.singles import time_singles
from rfp_twin.planners.postprocess.report import PostprocessReport, build_report, slowest_groups
from rfp_twin.planners.postprocess.verification import (LOCAL_NARROWING, near_stretch, repair,
                                                        verify_neighbours)
from rfp_twin.planners.postprocess.simplify import direction_reversals, simplify_plan
from rfp_twin.planners.postprocess.smoothing import METHODS, SmoothPath, smooth_plan, window_for_limits
from rfp_twin.planners.postprocess.smoothing_local import WindowRegions, smooth_plan_local
from rfp_twin.planners.postprocess.timing import BACKENDS, DEFAULT_BACKEND, interaction_groups, interaction_pairs

#: ``verifier(trajectory, spec, layout, buffer_mm, *, focus_ids=None) -> report`` (see
#: :func:`postprocess`; ``focus_ids``: check only the pairs with one of these robots).
Verifier = Callable[..., Any]

__all__ = ["Verifier", "postprocess", "DEFAULT_BUDGET_MM", "DEFAULT_TOLERANCE_DEG",
           "DEFAULT_PRESIMPLIFY_DEG", "DEFAULT_WIGGLE_PRESIMPLIFY_DEG", "DEFAULT_INTERACTION_MM",
           "DEFAULT_MAX_POINTS", "WIGGLE_REVERSALS", "ALIGNMENTS"]

#: sigma_smooth of Sayres 2021 Eq. 12, mm.
DEFAULT_BUDGET_MM = 0.03
#: Firmware limit of (angle, time) points per axis (Sayres 2021 Sect. 6).
DEFAULT_MAX_POINTS = 1024
#: RDP tolerance, deg: fewer points per axis at a larger tolerance, the same fold time
#: and verification rounds (``benchmarks/bench_postprocess.py``). 0.1 deg moves a point of the beta collision
#: segment by at most (7.4 + 2 * 14.7) mm * 0.1 deg = 0.064 mm, small next to the
#: smoothing itself; robots near contact get it halved by the verification loop.
DEFAULT_TOLERANCE_DEG = 0.1
#: RDP tolerance of the stepwise plan before smoothing, deg (0: off): a Markov plan's
#: wiggles are cut before they are smoothed and timed (a few times fewer breakpoints,
#: faster post-processing and shorter folds). 0.2 deg moves a point of the beta collision segment by at
#: most 0.13 mm before smoothing; robots whose local window is at its floor and still come
#: too close get it halved.
DEFAULT_PRESIMPLIFY_DEG = 0.2
#: Robots whose stepwise path turns back more often than this on its axes
#: (:func:`rfp_twin.planners.postprocess.simplify.direction_reversals`) are *wiggly*: Markov random
#: walks, the robots of a deadlock re-run.
WIGGLE_REVERSALS = 20
#: Pre-simplification tolerance of the wiggly robots, deg: their back-and-forth
#: excursions are cut before smoothing instead of being smoothed and timed, which
#: shortens their folds; a much larger tolerance leaves collisions the verification
#: rounds cannot repair. The verification at buffer - budget still decides, as for
#: every path.
DEFAULT_WIGGLE_PRESIMPLIFY_DEG = 0.5
#: Pairs whose clearance falls below this at some step of the plan share one path
#: parameter, mm. Robots that share one slow down for each other's corners, so smaller
#: groups are faster; pairs timed apart that meet anyway are merged by the verification.
DEFAULT_INTERACTION_MM = 0.3
ALIGNMENTS = ("end", "start")
#: ``progress`` is called every this many groups timed (and after the last).
PROGRESS_EVERY = 64
#: Time the one-robot groups in one compiled call (:mod:`rfp_twin.planners.postprocess.singles`;
#: the same values as one group at a time, which False restores: for tests).
BATCH_SINGLES = True


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
                wiggle_presimplify_deg: float = DEFAULT_WIGGLE_PRESIMPLIFY_DEG,
                smoothing: str = "average",
                window_steps: float | None = None,
                interaction_mm: float = DEFAULT_INTERACTION_MM,
                sample_s: float = 0.01,
                grid_steps: float = 4.0,
                align: str = "end",
                backend: str = DEFAULT_BACKEND,
                max_retries: int = 8,
                verifier: Verifier | None,
                progress: Callable[[int, int], None] | None = None
                ) -> tuple[Trajectory, PostprocessReport]:
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
    wiggle_presimplify_deg : the same for the robots whose path turns back more than
        :data:`WIGGLE_REVERSALS` times, deg (at least ``presimplify_deg`` is used)
    smoothing, window_steps : method and initial window (plan steps) of
        :func:`rfp_twin.planners.postprocess.smoothing.smooth_plan` [default window:
        :func:`rfp_twin.planners.postprocess.smoothing.window_for_limits` of the spec and the plan's step]
    progress : called as ``progress(groups_timed, groups_to_time)`` while each round times
        its groups (the first round: every group; later rounds: the repaired ones)
    interaction_mm : clearance below which two robots share one path parameter, mm
    sample_s : time step of the dense samples that RDP reduces, s
    grid_steps : longest TOPP-RA grid interval, plan steps
    align : "end" (all groups arrive together) or "start" (all start at t = 0)
    backend : "numba" (default: our TOPP-RA kernel) or "toppra" (the library, the same
        laws ~10x slower, as a cross-check; a group it finds no solution for is timed by
        the kernel and counted in the report's ``timing_fallbacks``)
        (:func:`rfp_twin.planners.postprocess.timing.time_group`)
    max_retries : verification rounds after the first
    verifier : ``verifier(trajectory, spec, layout, buffer_mm, *, focus_ids=None) -> report``
        with ``ok``, ``collisions``, ``min_clearance_mm`` and ``merged_with(newer_report)``
        (the 2D checker of ``validation/``); required, so that nobody forgets it: ``None``
        skips the verification (timing studies only; the report then says so). The first
        round's report with every later re-check merged in is ``report.final_check``:
        the check of the whole returned trajectory.

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
    for name, value in (("presimplify_deg", presimplify_deg),
                        ("wiggle_presimplify_deg", wiggle_presimplify_deg)):
        if not (np.isfinite(value) and 0.0 <= value <= 10.0):
            raise field_error(SpecError, name, value, "[0, 10] deg", "postprocess")
    if plan.n_robots != geom.n_robots or not np.array_equal(plan.robot_ids, geom.robot_ids):
        raise field_error(SpecError, "plan.robot_ids", f"{plan.n_robots} robots",
                          f"the {geom.n_robots} robots of the layout, in layout order", "postprocess")
    n = plan.n_robots
    joint_limits = geom.limits.reshape(n, 2, 2)     # each robot's (axis, lo/hi), model deg
    plan = within_limits(plan, joint_limits)
    verify_buffer = buffer_mm - budget_mm
    stages = {"smooth": 0.0, "group": 0.0, "time": 0.0, "simplify": 0.0, "verify": 0.0}

    # 2. (beside 1) the interaction pairs need only the plan: the second thread finds them
    grouping = second_thread().submit(interaction_pairs, plan, geom, interaction_mm)

    # 1. smoothing
    t0 = time.perf_counter()
    window = np.full(n, float(window_steps))
    pre = np.full(n, float(presimplify_deg))
    wiggly = direction_reversals(plan.path_ptr, plan.path_angles) > WIGGLE_REVERSALS
    pre[wiggly] = max(float(presimplify_deg), float(wiggle_presimplify_deg))
    pad = float(window_steps) / 2.0
    regions = WindowRegions(n, LOCAL_NARROWING) if smoothing == "average" else None
    cache: dict = {}
    path, n_smoothed = _smooth(plan, smoothing, window, pad, pre, regions, cache)
    stages["smooth"] += time.perf_counter() - t0

    # 2. grouping ("group": what is left of it once the plan is smoothed)
    t0 = time.perf_counter()
    pairs, clear = grouping.result()
    labels = interaction_groups(n, pairs[clear < interaction_mm])
    stages["group"] += time.perf_counter() - t0

    tol = np.full(n, float(tolerance_deg))
    groups: dict[int, TimedGroup] = {}
    dirty = set(np.unique(labels).tolist())
    changed = np.ones(n, dtype=bool)           # robots whose trajectory changed since last check
    hits = np.zeros(n, dtype=np.int64)         # rounds in which each robot was in a collision
    id_index = {int(r): i for i, r in enumerate(plan.robot_ids)}
    start_cfg, end_cfg = plan.start(), plan.end()
    near = verify_neighbours(geom, verify_buffer) if verifier is not None else None
    merged = None               # the whole trajectory's check: the full one, re-checks merged in

    rounds = retries = merges = tightened = repaired = 0
    traj = None
    while True:
        # 3-4. time, sample, simplify the groups that changed
        t0 = time.perf_counter()
        mrange = path.moving_range()
        members = group_members(labels)
        todo = sorted(dirty)
        # one-robot groups: one compiled call on two threads, the same values
        singles = {}
        if backend == "numba" and BATCH_SINGLES:
            ones = [int(members[g][0]) for g in todo if g in members and members[g].size == 1]
            singles = time_singles(path, np.array(ones, dtype=np.int64), vmax, amax, tol,
                                   grid_steps=grid_steps, sample_s=sample_s,
                                   max_points=max_points, moving_range=mrange,
                                   limits=joint_limits) if ones else {}
        for done, g in enumerate(todo, 1):
            if progress is not None and (done % PROGRESS_EVERY == 0 or done == len(todo)):
                progress(done, len(todo))
            robots = members.get(g)
            if robots is None:
                continue
            timed = singles.get(int(robots[0])) if robots.size == 1 else None
            groups[g] = timed if timed is not None else time_and_simplify(
                path, robots, vmax, amax, tol, grid_steps=grid_steps, backend=backend,
                sample_s=sample_s, max_points=max_points, moving_range=mrange,
                limits=joint_limits)
        for g in list(groups):
            if g not in members:
                del groups[g]
        stages["time"] += time.perf_counter() - t0
        # 5. verification: everything in the first round, then the robots whose
        #    trajectory changed and their neighbours (other pairs are unchanged up to a
        #    common time shift, so their earlier result stands)
        t0 = time.perf_counter()
        focus = {}
        if rounds == 0 or verifier is None:
            sub = traj = assemble(plan, groups, align, start_cfg, end_cfg)
        else:
            sel = np.flatnonzero(changed | (near @ changed.astype(np.int64) > 0))
            sub = assemble(plan, groups, align, start_cfg, end_cfg, robots=sel)
            traj = None
            # only the pairs of a changed robot: the others are as last checked
            focus = {"focus_ids": np.asarray(plan.robot_ids)[changed]}
        stages["simplify"] += time.perf_counter() - t0
        if verifier is None:
            break
        t0 = time.perf_counter()
        check = verifier(sub, spec, geom.layout, verify_buffer, **focus)
        merged = check if merged is None else merged.merged_with(check)
        stages["verify"] += time.perf_counter() - t0
        rounds += 1
        changed[:] = False
        if merged.ok:
            break
        if retries >= max_retries:
            c = merged.collisions[0]
            raise PlanningError(
                f"post-processing: {len(merged.collisions)} collision(s) remain at "
                f"{verify_buffer:.3f} mm after {retries} retries (first: robot {c.robot_a} and "
                f"{c.kind} {c.other} at t = {c.t_min:.3f} s, {c.min_distance_mm:.4f} mm); "
                "allowed: a larger budget_mm, a smaller window_steps / tolerance_deg, or a "
                "larger interaction_mm")
        retries += 1
        repaired += len(merged.collisions)
        offsets = group_offsets(groups, align)

        def step_span(c, margin_mm: float) -> tuple[float, float]:
            i = id_index[c.robot_a]
            g = groups[labels[i]]
            tt = (np.array([c.t_start, c.t_end]) - offsets[labels[i]]) / g.scale
            u = g.law.s_at(np.clip(tt, 0.0, g.law.duration)) - pad
            if c.kind == "robot" and margin_mm > 0.0:
                return near_stretch(plan, geom, i, id_index[c.other], float(u.min()),
                                    float(u.max()), margin_mm)
            return float(u.min()), float(u.max())

        dirty, touched, n_merged, n_tightened = repair(merged.collisions, labels, id_index,
                                                       window, tol, pre, regions, step_span,
                                                       pre_base=float(presimplify_deg),
                                                       hits=hits)
        merges += n_merged
        tightened += n_tightened
        if not dirty:
            c = merged.collisions[0]
            raise PlanningError(
                f"post-processing: robot {c.robot_a} and {c.kind} {c.other} collide at "
                f"{verify_buffer:.3f} mm with the smallest window and tolerance; allowed: a "
                "larger budget_mm")
        if touched:
            t0 = time.perf_counter()
            path, n_smoothed = _smooth(plan, smoothing, window, pad, pre, regions, cache)
            stages["smooth"] += time.perf_counter() - t0
        for g in dirty:
            changed[labels == g] = True

    if traj is None:
        t0 = time.perf_counter()
        traj = assemble(plan, groups, align, start_cfg, end_cfg)
        stages["simplify"] += time.perf_counter() - t0
    report = build_report(plan, traj, groups, labels, path,
                          merged, spec, buffer_mm, budget_mm,
                          verify_buffer, smoothing, window_steps, window, tolerance_deg,
                          max_points, sample_s, interaction_mm, align, backend, rounds, retries,
                          merges, tightened, repaired, stages, clock)
    narrowed = set(regions.robots()) if regions is not None else set(
        np.flatnonzero(window < float(window_steps)).tolist())
    report.slowest_groups = slowest_groups(plan, groups, narrowed)
    report.presimplify_deg = float(presimplify_deg)
    report.n_wiggly_robots = int(wiggly.sum())
    report.plan_breakpoints = int(plan.path_step.size)
    report.smoothed_breakpoints = n_smoothed
    report.final_check = merged
    return traj, report


def _smooth(plan: Plan, method: str, window: np.ndarray, pad: float, pre: np.ndarray,
            regions: WindowRegions | None, cache: dict) -> tuple[SmoothPath, int]:
    """Pre-simplify (tolerance ``pre`` per robot) and smooth (narrower on ``regions``):
    (path, breakpoints smoothed). ``cache`` keeps the pre-simplified plan and its plain
    smoothing between rounds (they change only when ``pre`` or ``window`` does)."""
    key = (pre.tobytes(), window.tobytes())
    if key not in cache:
        cache.clear()
        src = simplify_plan(plan, pre) if np.any(pre > 0.0) else plan
        cache[key] = (src, None)
    src, base = cache[key]
    if regions is not None:
        if base is None:
            base = smooth_plan(src, method="average", window_steps=window, pad_steps=pad)
            cache[key] = (src, base)
        return smooth_plan_local(src, window, regions, pad, base), int(src.path_step.size)
    return (smooth_plan(src, method=method, window_steps=window, pad_steps=pad),
            int(src.path_step.size))


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
