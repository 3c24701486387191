"""One MDP2 run on an array: kernel arguments from the geometry, its outcome as a StepRun.

:func:`run_mdp2` unpacks an :class:`rfp_twin.models.array.ArrayGeometry` (and the layout's
``fiducial_watch``, ``alpha_offset_deg`` and ``beta_offset_deg`` columns) into the arrays of
:func:`rfp_twin.planners.stepwise.mdp2.mdp2_kernel`, runs up to ``tries`` tries and returns
the last try as an :class:`Mdp2Run`: a :class:`rfp_twin.planners.stepwise.run.StepRun`
(breakpoints in the kernel's order, for :func:`rfp_twin.planners.plan.build_paths`) with the
tries made, whether the last one brought every robot to its destination, and the robots
that ended as nudgers.

Units: angles in deg, lengths in mm, time in planner steps (wall time in s).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.layout.columns import robot_column
from rfp_twin.planners.stepwise.mdp2 import GREED, PHOBIA, TRIES, mdp2_kernel
from rfp_twin.planners.stepwise.run import MAX_EVENTS, StepRun


@dataclass
class Mdp2Run(StepRun):
    """A :class:`StepRun` of MDP2's last try.

    Attributes (beyond StepRun's)
    -----------------------------
    tries : int, tries made (1 when the first converged)
    converged : bool, the last try brought every movable robot to its destination
    nudged : (n,) bool, the robots that were nudgers at the end
    """

    tries: int = 1
    converged: bool = False
    nudged: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))


def watched_robots(geom: ArrayGeometry) -> np.ndarray:
    """(n,) bool: the robots SDSS-V watches beside a fiducial (layout ``fiducial_watch``)."""
    layout = geom.layout
    flags = layout.extra.get("fiducial_watch")
    if flags is None:
        return np.zeros(geom.n_robots, dtype=bool)
    flags = np.asarray(flags, dtype=object)[np.asarray(layout.robot_mask)]
    return np.array([str(v).strip() not in ("", "0", "nan") for v in flags], dtype=bool)


def encoder_offsets(geom: ArrayGeometry) -> np.ndarray:
    """(n, 2) deg: each robot's encoder zero in model angles (model = encoder + offset)."""
    layout = geom.layout
    return np.ascontiguousarray(np.column_stack([
        robot_column(layout, "alpha_offset_deg", 0.0),
        robot_column(layout, "beta_offset_deg", 0.0)]), dtype=np.float64)


def _seed_state(seed: int) -> np.ndarray:
    """The kernel's splitmix64 state from a seed (any int)."""
    mixed = np.random.SeedSequence(int(seed) & ((1 << 63) - 1)).generate_state(1, np.uint64)
    return np.ascontiguousarray(mixed, dtype=np.uint64)


def run_mdp2(geom: ArrayGeometry, start: np.ndarray, dest: np.ndarray, movable: np.ndarray, *,
             step_deg: float, max_steps: int, md: float, seed: int, greed: float = GREED,
             phobia: float = PHOBIA, tries: int = TRIES, watch: np.ndarray | None = None,
             offsets: np.ndarray | None = None) -> Mdp2Run:
    """MDP2 from ``start`` towards ``dest`` ((n, 2) model deg) on ``geom``.

    Parameters
    ----------
    movable : (n,) bool; robots that are False never move (offline) and count as arrived
    step_deg : float, deg; max_steps : int, steps of one try; md : float, MD mm
        (:func:`rfp_twin.planners.stepwise.moves.array_max_displacement`)
    seed : int, seeds the kernel's generator (robot order, moves, coins)
    greed, phobia : float in [0, 1]; tries : int >= 1 (production: 0.7, 0.6, 5)
    watch : (n,) bool robots under kaiju's fiducialWatch rule [default: the layout's
        ``fiducial_watch`` column]; offsets : (n, 2) deg encoder zeros [default: the
        layout's columns, 0 where absent]
    """
    n = geom.n_robots
    watch = watched_robots(geom) if watch is None else np.ascontiguousarray(watch, dtype=bool)
    offsets = encoder_offsets(geom) if offsets is None else np.ascontiguousarray(offsets,
                                                                                  dtype=np.float64)
    start = np.ascontiguousarray(start, dtype=np.float64)
    dest = np.ascontiguousarray(dest, dtype=np.float64)
    movable = np.ascontiguousarray(movable, dtype=bool)
    geo = (geom.base_xy, np.ascontiguousarray(geom.alpha_len), np.ascontiguousarray(geom.seg_start),
           np.ascontiguousarray(geom.seg_end), np.ascontiguousarray(geom.buffer),
           (geom.nbr_ptr, geom.nbr_idx, geom.nbr_dist),
           (geom.fid_ptr, geom.fid_idx, geom.fid_xy, np.ascontiguousarray(geom.fid_end_xy),
            np.ascontiguousarray(geom.fid_buffer)))
    limits = np.ascontiguousarray(geom.limits, dtype=np.float64)
    nudge = np.zeros(n, dtype=bool)
    cap = max(1, min(n * (int(max_steps) + 2), MAX_EVENTS))
    rng = _seed_state(seed)
    seconds = 0.0
    retries = 0
    while True:
        state = (np.empty((n, 2)), np.empty((n, 4)), np.empty((n, 4)), np.empty(n), np.empty(n, dtype=bool),
                 nudge, np.empty(n, dtype=np.int64), np.empty(n, dtype=np.int64),
                 np.arange(9, dtype=np.int64), np.empty((n, 2)), np.empty(n, dtype=np.int64),
                 np.empty(n, dtype=np.int64), np.empty(n), np.empty(n, dtype=np.int64))
        ev = (np.empty(cap, dtype=np.int64), np.empty(cap, dtype=np.int64), np.empty((cap, 2)))
        t0 = time.perf_counter()
        n_ev, n_steps, made, converged = mdp2_kernel(
            geo, start, dest, movable, limits, watch, offsets, float(step_deg), int(max_steps),
            float(md), float(greed), float(phobia), int(tries), rng, state, ev)
        seconds += time.perf_counter() - t0
        if n_ev >= 0:
            break
        cap *= 4                    # the same run again from scratch, larger buffers
        retries += 1
        nudge[:] = False
        rng = _seed_state(seed)
    ev_robot, ev_step, ev_angles = ev
    return Mdp2Run(state[0].copy(), int(n_steps), ev_robot[:n_ev], ev_step[:n_ev],
                   ev_angles[:n_ev], seconds, retries, tries=int(made),
                   converged=bool(converged), nudged=nudge.copy())
