"""One stepwise kernel run on an array: arguments from the geometry, breakpoint buffers.

:func:`run_array` unpacks an :class:`rfp_twin.models.array.ArrayGeometry` into the arrays
:func:`rfp_twin.planners.stepwise.kernel.run_stepwise` takes, allocates its breakpoint buffers
and runs it. The buffers hold one breakpoint per robot and step, the most the kernel can
write, so a run is never repeated below :data:`MAX_EVENTS`; above it (arrays of
thousands of robots with long step limits), a run whose buffers overflow runs again,
from scratch, with buffers four times larger (the kernel is deterministic for a given
seed, so the result does not depend on the first size), and the repeated calls are
counted in its time and ``retries``. The breakpoints come back as a :class:`StepRun`, in the
kernel's order (each robot's in step order); :func:`rfp_twin.planners.plan.build_paths` turns
them into paths.

Units: angles in deg, lengths in mm, time in planner steps (wall time in s).
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.planners.stepwise.kernel import run_stepwise

#: Largest first breakpoint buffer, events (32 bytes each: 1 GiB of address space, of
#: which only the written breakpoints are ever touched).
MAX_EVENTS = 1 << 25


@dataclass
class StepRun:
    """Raw outcome of one kernel call.

    Attributes
    ----------
    final : (n, 2) deg, where every robot stands when the run stops
    n_steps : int, steps taken
    ev_robot, ev_step : (m,) int64, robot index and step of each breakpoint
    ev_angles : (m, 2) deg, (alpha, beta) at each breakpoint
    seconds : float, wall time of every kernel call of this run, s (the calls repeated
        after a buffer overflow included: what the run cost, not its last call)
    retries : int, kernel calls repeated because the breakpoint buffers overflowed
    """

    final: np.ndarray
    n_steps: int
    ev_robot: np.ndarray
    ev_step: np.ndarray
    ev_angles: np.ndarray
    seconds: float
    retries: int = 0


def run_array(geom: ArrayGeometry, start: np.ndarray, dest: np.ndarray, movable: np.ndarray, *,
              step_deg: float, max_steps: int, md: float, greed, phobia, seed: int,
              cap: int | None = None, greedy_first: np.ndarray | None = None) -> StepRun:
    """Run the stepwise kernel on ``geom`` from ``start`` towards ``dest``.

    Parameters
    ----------
    geom : ArrayGeometry (layout, spec, Eq. 4 neighbours; each robot's alpha arm, collision
        segment and buffer; the obstacles: fiducials as points, guide-camera edges as
        segments, each with its keep-out radius)
    start, dest : (n, 2) deg
    movable : (n,) bool; robots that are False never move
    step_deg : float, planner step, deg; max_steps : int, step limit
    md : float, step-rule margin MD, mm (for per-robot geometry, at least
        :func:`rfp_twin.planners.stepwise.moves.array_max_displacement`)
    greed, phobia : float or (n,) float64 in [0, 1], the Markov parameters of every robot
        or of each; a robot with greed 1 and phobia 0 follows the greedy planner's rules
    seed : int, seed of the kernel's generator (Markov moves)
    cap : int or None, breakpoints the first buffers hold [default: one per robot and
        step, ``n (max_steps + 1)``, which the kernel cannot exceed (it records a robot at
        most once a step), up to :data:`MAX_EVENTS`; the buffers are allocated untouched,
        so only the breakpoints written take memory]
    greedy_first : (n,) bool or None, Markov robots that take their obvious move whenever
        it passes and a Markov move only when blocked [default: none]
    """
    n = geom.n_robots
    limits = geom.limits
    if cap is None:
        cap = min(n * (int(max_steps) + 1), MAX_EVENTS)
    cap = max(1, int(cap))
    start = np.ascontiguousarray(start, dtype=np.float64)
    dest = np.ascontiguousarray(dest, dtype=np.float64)
    seconds, retries = 0.0, 0
    while True:
        ev_robot = np.empty(cap, dtype=np.int64)
        ev_step = np.empty(cap, dtype=np.int64)
        ev_angles = np.empty((cap, 2))
        final = np.empty((n, 2))
        t0 = time.perf_counter()
        n_ev, n_steps = run_stepwise(
            geom.base_xy, start, dest, movable, geom.nbr_ptr, geom.nbr_idx, geom.nbr_dist,
            geom.fid_ptr, geom.fid_idx, geom.fid_xy, geom.fid_buffer,
            geom.alpha_len, geom.seg_start, geom.seg_end, geom.buffer, limits,
            step_deg, max_steps, md, greed, phobia, seed,
            ev_robot, ev_step, ev_angles, final, fid_end_xy=geom.fid_end_xy,
            greedy_first=greedy_first)
        seconds += time.perf_counter() - t0
        if n_ev >= 0:
            return StepRun(final, int(n_steps), ev_robot[:n_ev], ev_step[:n_ev], ev_angles[:n_ev],
                           seconds, retries)
        cap *= 4
        retries += 1
