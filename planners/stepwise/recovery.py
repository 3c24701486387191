"""Moves from wherever the robots stand: unwind to the fold, and explode apart.

These are the recovery moves SDSS-V's controller offers besides planned configurations:

- **unwind** (:func:`unwind_plan`): every movable robot goes from its current pose to the
  fold with the greedy stepwise planner (or Markov), forward in time; a run that
  deadlocks stops there and says which robots did not reach the fold.
- **explode** (:func:`explode_plan`): for ``degrees / step_deg`` steps, each movable robot
  in turn takes the one of its nine moves (each axis -1, 0, +1 step, clipped to its joint
  limits; standing still first, so a robot moves only when that strictly helps) that
  maximises its smallest clearance to its neighbours and obstacles, the robots before it
  having moved already in that step, among the moves that take none of its pairs closer
  than the step rule allows (:func:`explode_kernel`). Used to pull robots apart that
  stand too close, or one robot (``robots``) out of a tight spot.

Offline robots never move. Both return a :class:`rfp_twin.planners.plan.Plan` on the
step clock, in the executed direction (start -> end). Units: deg, mm, steps.
"""
from __future__ import annotations

import time

import numpy as np
from numba import njit

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.errors import PlanningError
from rfp_twin.models.geometry2d import beta_segment, segment_distance
from rfp_twin.planners.plan import DEADLOCKED, OFFLINE, REACHED, Plan, build_paths
from rfp_twin.planners.stepwise.moves import array_max_displacement
from rfp_twin.planners.stepwise.run import run_array

#: Explode's default travel, deg (jaeger's default for `explode`).
EXPLODE_DEG = 20.0
#: Candidate moves in units of a step, (9, 2): standing still first (ties keep a robot put).
MOVES = np.array([[0, 0], [1, 0], [-1, 0], [0, 1], [0, -1], [1, 1], [1, -1], [-1, 1], [-1, -1]],
                 dtype=np.float64)


@njit(cache=True)
def _clearances(i, a, b, cur, base_xy, alpha_len, seg_start, seg_end, buffer, nbr_ptr, nbr_idx,
                fid_ptr, fid_idx, fid_xy, fid_end_xy, fid_buffer, out):
    """Clearance (distance - keep-out), mm, of robot ``i`` at (a, b) deg to each of its
    neighbours, then each of its obstacles, written to ``out``; returns how many."""
    p0x, p0y, p1x, p1y = beta_segment(base_xy[i, 0], base_xy[i, 1], a, b, alpha_len[i],
                                      seg_start[i], seg_end[i])
    m = 0
    for k in range(nbr_ptr[i], nbr_ptr[i + 1]):
        j = nbr_idx[k]
        q0x, q0y, q1x, q1y = beta_segment(base_xy[j, 0], base_xy[j, 1], cur[j, 0], cur[j, 1],
                                          alpha_len[j], seg_start[j], seg_end[j])
        out[m] = segment_distance(p0x, p0y, p1x, p1y, q0x, q0y, q1x, q1y) - buffer[i] - buffer[j]
        m += 1
    for k in range(fid_ptr[i], fid_ptr[i + 1]):
        f = fid_idx[k]
        out[m] = segment_distance(p0x, p0y, p1x, p1y, fid_xy[f, 0], fid_xy[f, 1],
                                  fid_end_xy[f, 0], fid_end_xy[f, 1]) - buffer[i] - fid_buffer[f]
        m += 1
    return m


@njit(cache=True)
def explode_kernel(start, movable, n_steps, step_deg, md, limits, moves, base_xy, alpha_len,
                   seg_start, seg_end, buffer, nbr_ptr, nbr_idx, fid_ptr, fid_idx, fid_xy,
                   fid_end_xy, fid_buffer):
    """Explode ``n_steps`` steps from ``start`` ((n, 2) deg).

    A move is admissible when it takes no neighbour or obstacle of the robot below
    ``min(its clearance now, md)`` (``md``: the step rule's margin, mm, so a pair clear by
    ``md`` stays so while both robots move, and a pair closer than that does not get
    closer); standing still always is. Among the admissible moves the robot takes the one
    with the largest smallest clearance.

    Returns ``(final (n, 2) deg, ev_robot (m,), ev_step (m,), ev_angles (m, 2))``: one
    breakpoint per robot and step in which it moved (each robot's in step order)."""
    n = start.shape[0]
    cur = start.copy()
    cap = n * n_steps
    ev_robot = np.empty(cap, dtype=np.int64)
    ev_step = np.empty(cap, dtype=np.int64)
    ev_angles = np.empty((cap, 2))
    width = 1
    for i in range(n):
        width = max(width, nbr_ptr[i + 1] - nbr_ptr[i] + fid_ptr[i + 1] - fid_ptr[i])
    now = np.empty(width)
    then = np.empty(width)
    m = 0
    for s in range(n_steps):
        for i in range(n):
            if not movable[i]:
                continue
            k = _clearances(i, cur[i, 0], cur[i, 1], cur, base_xy, alpha_len, seg_start,
                            seg_end, buffer, nbr_ptr, nbr_idx, fid_ptr, fid_idx, fid_xy,
                            fid_end_xy, fid_buffer, now)
            best = np.inf
            for q in range(k):
                best = min(best, now[q])
            ba, bb = cur[i, 0], cur[i, 1]
            for c in range(1, moves.shape[0]):
                a = min(max(cur[i, 0] + moves[c, 0] * step_deg, limits[i, 0]), limits[i, 1])
                b = min(max(cur[i, 1] + moves[c, 1] * step_deg, limits[i, 2]), limits[i, 3])
                _clearances(i, a, b, cur, base_xy, alpha_len, seg_start, seg_end, buffer,
                            nbr_ptr, nbr_idx, fid_ptr, fid_idx, fid_xy, fid_end_xy, fid_buffer,
                            then)
                worst = np.inf
                ok = True
                for q in range(k):
                    if then[q] < min(now[q], md):
                        ok = False
                        break
                    worst = min(worst, then[q])
                if ok and worst > best:
                    best, ba, bb = worst, a, b
            if ba != cur[i, 0] or bb != cur[i, 1]:
                ev_robot[m] = i
                ev_step[m] = s + 1
                ev_angles[m, 0] = ba
                ev_angles[m, 1] = bb
                m += 1
                cur[i, 0] = ba
                cur[i, 1] = bb
    return cur, ev_robot[:m], ev_step[:m], ev_angles[:m]


def _plan(geom: ArrayGeometry, step_deg: float, n_steps: int, start, final, events, status,
          metrics: dict) -> Plan:
    """A Plan from breakpoints ``events = (ev_robot, ev_step, ev_angles)`` (each robot's in
    step order; :func:`rfp_twin.planners.plan.build_paths` groups them by robot)."""
    ptr, steps, angles = build_paths(geom.n_robots, *events, start, final, n_steps)
    return Plan(robot_ids=geom.robot_ids.copy(), step_deg=float(step_deg),
                step_s=geom.spec.step_seconds(step_deg), n_steps=int(n_steps), path_ptr=ptr,
                path_step=steps, path_angles=angles, status=status, targets=final.copy(),
                original_targets=final.copy(), metrics=metrics)


def _checked_start(geom: ArrayGeometry, start: np.ndarray, movable: np.ndarray):
    start = np.ascontiguousarray(start, dtype=np.float64)
    movable = np.ascontiguousarray(movable, dtype=np.bool_)
    if start.shape != (geom.n_robots, 2) or movable.shape != (geom.n_robots,):
        raise PlanningError(f"start poses of shape {start.shape} and movable mask of shape "
                            f"{movable.shape}; allowed: ({geom.n_robots}, 2) and "
                            f"({geom.n_robots},)")
    bad = np.flatnonzero(~np.isfinite(start).all(axis=1))
    if bad.size:
        raise PlanningError(f"robot {int(geom.robot_ids[bad[0]])}: start pose "
                            f"{tuple(start[bad[0]])} is not finite; allowed: angles in deg")
    return start, movable


def explode_plan(geom: ArrayGeometry, start: np.ndarray, movable: np.ndarray, *,
                 degrees: float = EXPLODE_DEG, step_deg: float = 0.1,
                 robots: np.ndarray | None = None) -> Plan:
    """Explode from ``start`` ((n, 2) deg): every movable robot, or only the robot
    indices ``robots``, steps ``degrees / step_deg`` times to increase its smallest
    clearance (module docstring). Every robot's status is REACHED (OFFLINE for the
    robots that do not move); ``metrics`` gives the smallest clearance before and after
    (``min_clearance_start_mm``, ``min_clearance_end_mm``) and the wall time."""
    start, movable = _checked_start(geom, start, movable)
    if not (np.isfinite(degrees) and degrees > 0):
        raise PlanningError(f"explode degrees {degrees!r}; allowed: a finite number > 0 deg")
    moving = movable.copy()
    if robots is not None:
        chosen = np.zeros(geom.n_robots, dtype=bool)
        chosen[np.asarray(robots, dtype=np.int64)] = True
        moving &= chosen
    n_steps = int(np.ceil(degrees / step_deg - 1e-9))
    clock = time.perf_counter()
    final, *events = explode_kernel(
        start, moving, n_steps, float(step_deg), array_max_displacement(geom, step_deg),
        np.ascontiguousarray(geom.limits), MOVES,
        geom.base_xy, geom.alpha_len, geom.seg_start, geom.seg_end, geom.buffer, geom.nbr_ptr,
        geom.nbr_idx, geom.fid_ptr, geom.fid_idx, geom.fid_xy, geom.fid_end_xy, geom.fid_buffer)
    seconds = time.perf_counter() - clock
    status = np.where(movable, REACHED, OFFLINE).astype(object)
    metrics = {"algorithm": "explode", "explode_deg": float(degrees), "tau_pg": seconds,
               "n_moved": int(np.any(final != start, axis=1).sum()),
               "min_clearance_start_mm": min_clearance(geom, start),
               "min_clearance_end_mm": min_clearance(geom, final)}
    return _plan(geom, step_deg, n_steps, start, final, events, status,
                 metrics)


def unwind_plan(geom: ArrayGeometry, start: np.ndarray, movable: np.ndarray, *,
                step_deg: float = 0.1, greed: float = 1.0, phobia: float = 0.0,
                max_steps: int | None = None, seed: int = 0) -> Plan:
    """Every movable robot from ``start`` ((n, 2) deg) to the spec's fold, forward, with
    the stepwise planner (greedy by default). Robots that do not reach the fold are
    DEADLOCKED and the plan ends where the run stopped; ``metrics["n_deadlocked"]``
    counts them."""
    start, movable = _checked_start(geom, start, movable)
    fold = np.tile(np.asarray(geom.spec.fold_deg, dtype=np.float64), (geom.n_robots, 1))
    dest = np.where(movable[:, None], fold, start)
    if max_steps is None:
        max_steps = int(np.ceil(1000.0 / step_deg))
    run = run_array(geom, start, dest, movable, step_deg=step_deg, max_steps=max_steps,
                    md=array_max_displacement(geom, step_deg), greed=greed, phobia=phobia,
                    seed=seed)
    home = np.all(np.abs(run.final - dest) < 1e-9, axis=1)
    status = np.where(~movable, OFFLINE, np.where(home, REACHED, DEADLOCKED)).astype(object)
    metrics = {"algorithm": "greedy" if greed >= 1.0 else "markov", "tau_pg": run.seconds,
               "n_deadlocked": int((status == DEADLOCKED).sum()),
               "min_clearance_start_mm": min_clearance(geom, start)}
    return _plan(geom, step_deg, run.n_steps, start, run.final,
                 (run.ev_robot, run.ev_step, run.ev_angles), status, metrics)


def min_clearance(geom: ArrayGeometry, angles: np.ndarray) -> float:
    """Smallest robot-robot or robot-obstacle clearance of a configuration, mm."""
    values = [c.min() for c in (geom.pair_clearance(angles), geom.fiducial_clearance(angles))
              if c.size]
    return float(min(values)) if values else float("inf")
