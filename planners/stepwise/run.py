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

A run may cover only some of the robots (``robots``): the neighbour and obstacle lists are
cut to them, and robots outside are absent. Some of those may *replay* a recorded path
(``script``) instead of planning: a region of the array re-planned inside a ring of
robots that keep what they did (:mod:`rfp_twin.planners.deadlocks.rerun`).

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
    replay_blocked : bool, the run stopped at ``n_steps`` because a replayed robot's
        recorded move failed the step rule (the robots around it left no room)
    """

    final: np.ndarray
    n_steps: int
    ev_robot: np.ndarray
    ev_step: np.ndarray
    ev_angles: np.ndarray
    seconds: float
    retries: int = 0
    replay_blocked: bool = False


def sub_csr(ptr: np.ndarray, idx: np.ndarray, robots: np.ndarray, renumber: bool = True
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rows ``robots`` ((k,) int64) of a CSR list (ptr (n+1,), idx): with ``renumber`` (a
    robot -> robot list) only the entries that are themselves in ``robots``, renumbered
    to their positions in it; else (robot -> obstacle) every entry, unchanged.
    Returns (ptr (k+1,), idx, positions in the old ``idx`` of the entries kept)."""
    counts = ptr[robots + 1] - ptr[robots]
    rows = np.repeat(np.arange(robots.size), counts)
    take = (np.repeat(ptr[robots], counts) + np.arange(counts.sum())
            - np.repeat(np.cumsum(counts) - counts, counts)).astype(np.int64)
    vals = idx[take]
    if renumber:
        where = np.full(ptr.size - 1, -1, dtype=np.int64)
        where[robots] = np.arange(robots.size)
        vals = where[vals]
        keep = vals >= 0
        rows, vals, take = rows[keep], vals[keep], take[keep]
    out_ptr = np.zeros(robots.size + 1, dtype=np.int64)
    np.cumsum(np.bincount(rows, minlength=robots.size), out=out_ptr[1:])
    return out_ptr, np.ascontiguousarray(vals, dtype=np.int64), take


def run_array(geom: ArrayGeometry, start: np.ndarray, dest: np.ndarray, movable: np.ndarray, *,
              step_deg: float, max_steps: int, md: float, greed, phobia, seed: int,
              cap: int | None = None, greedy_first: np.ndarray | None = None,
              beta_first: np.ndarray | None = None,
              robots: np.ndarray | None = None, script: tuple | None = None) -> StepRun:
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
    beta_first : (n,) bool or None, robots that retract beta first
        (:func:`rfp_twin.planners.stepwise.kernel.run_stepwise`) [default: none]
    robots : (k,) int64 increasing robot indices, or None (all): run only these, on
        their own neighbour lists; every per-robot argument (``start``, ``dest``,
        ``movable``, ``greed``, ``phobia``, ``greedy_first``, ``script``) and the result
        are then in their order (``ev_robot`` indexes ``robots``)
    script : (ptr, steps, angles) CSR paths or None: robots with a non-empty row replay
        them (:func:`rfp_twin.planners.stepwise.kernel.run_stepwise`); they must be given
        ``movable`` False. A run stopped by a replayed move that fails the step rule
        comes back with ``replay_blocked`` (and is not repeated).
    """
    arrays = _robot_arrays(geom, robots)
    n = arrays["base_xy"].shape[0]
    limits = arrays["limits"]
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
        a = arrays
        n_ev, n_steps = run_stepwise(
            a["base_xy"], start, dest, movable, a["nbr_ptr"], a["nbr_idx"], a["nbr_dist"],
            a["fid_ptr"], a["fid_idx"], geom.fid_xy, geom.fid_buffer,
            a["alpha_len"], a["seg_start"], a["seg_end"], a["buffer"], limits,
            step_deg, max_steps, md, greed, phobia, seed,
            ev_robot, ev_step, ev_angles, final, fid_end_xy=geom.fid_end_xy,
            greedy_first=greedy_first, script=script, beta_first=beta_first)
        seconds += time.perf_counter() - t0
        if n_ev == -2:
            return StepRun(final, int(n_steps), ev_robot[:0], ev_step[:0], ev_angles[:0],
                           seconds, retries, replay_blocked=True)
        if n_ev >= 0:
            return StepRun(final, int(n_steps), ev_robot[:n_ev], ev_step[:n_ev], ev_angles[:n_ev],
                           seconds, retries)
        cap *= 4
        retries += 1


def _robot_arrays(geom: ArrayGeometry, robots: np.ndarray | None) -> dict:
    """The kernel's per-robot arrays of ``geom``, of every robot or of ``robots`` only."""
    names = ("base_xy", "alpha_len", "seg_start", "seg_end", "buffer", "limits")
    out = {name: getattr(geom, name) for name in names}
    out.update(nbr_ptr=geom.nbr_ptr, nbr_idx=geom.nbr_idx, nbr_dist=geom.nbr_dist,
               fid_ptr=geom.fid_ptr, fid_idx=geom.fid_idx)
    if robots is None:
        return out
    robots = np.asarray(robots, dtype=np.int64)
    out = {name: np.ascontiguousarray(np.asarray(v)[robots]) for name, v in out.items()
           if name in names}
    out["nbr_ptr"], out["nbr_idx"], take = sub_csr(geom.nbr_ptr, geom.nbr_idx, robots)
    out["nbr_dist"] = np.ascontiguousarray(geom.nbr_dist[take])
    out["fid_ptr"], out["fid_idx"], _ = sub_csr(geom.fid_ptr, geom.fid_idx, robots,
                                                renumber=False)
    for name, v in out.items():       # the kernel's types as for the whole array: one compile
        v.flags.writeable = getattr(geom, name).flags.writeable
    return out
