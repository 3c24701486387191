"""Why a target within reach was not assigned: what blocks each of its candidate poses.

For a finished assignment, every target that some robot reaches but nobody took gets
the most benign reason any of its candidate poses has, in this order:

- ``other``: a candidate whose robot is parked and whose pose collides with no chosen
  pose (the assignment left it for another reason: a forbidden pair of the plannable
  loop, a time-limited solve, a quota);
- ``parked_neighbour``: a candidate whose robot is parked and whose pose collides only
  with parked neighbours (their parking pose, e.g. the fold, is in the way: another
  parking pose would free it);
- ``assigned_neighbour``: a candidate whose robot is parked, blocked by a neighbour on
  another target;
- ``robot_busy``: every robot that reaches it holds another target.

Poses collide by the assigner's own rule (:func:`rfp_twin.planners.assignment.conflicts.conflict_pairs`).
"""
from __future__ import annotations

import numpy as np

from rfp_twin.planners.assignment.candidates import Candidates
from rfp_twin.planners.assignment.conflicts import conflict_pairs, neighbour_pairs

__all__ = ["MISS_REASONS", "chosen_candidates", "miss_reasons"]

#: Reasons, most benign first (:func:`miss_reasons` keeps a target's most benign one).
MISS_REASONS = ("other", "parked_neighbour", "assigned_neighbour", "robot_busy")


def chosen_candidates(cands: Candidates, assignment) -> np.ndarray:
    """(n_robots,) int64: the candidate index of each robot's assigned pose (a parked
    robot's parking candidate at its angles, else its fold; the fold too when the pose is
    not among ``cands``)."""
    chosen = cands.ptr[:-1].copy()
    for r in np.flatnonzero(assignment.target < 0):
        lo, hi = cands.ptr[r], cands.ptr[r + 1]
        hit = np.flatnonzero((cands.target[lo:hi] < 0)
                             & np.all(np.abs(cands.angles[lo:hi] - assignment.angles[r]) < 1e-9,
                                      axis=1))
        if hit.size:
            chosen[r] = lo + hit[0]
    for r in np.flatnonzero(assignment.target >= 0):
        lo, hi = cands.ptr[r], cands.ptr[r + 1]
        hit = np.flatnonzero((cands.target[lo:hi] == assignment.target[r])
                             & (cands.arm[lo:hi] == assignment.arm[r])
                             & (cands.slot[lo:hi] == assignment.slot[r]))
        if hit.size:
            chosen[r] = lo + hit[0]
    return chosen


def miss_reasons(geom, cands: Candidates, assignment, margin_mm: float,
                 wanted: np.ndarray) -> dict[str, int]:
    """{reason: number of targets} over the ``wanted`` targets ((t,) bool over the
    catalogue rows) that some candidate reaches and no robot took (module docstring)."""
    chosen = chosen_candidates(cands, assignment)
    is_chosen = np.zeros(cands.n, dtype=bool)
    is_chosen[chosen] = True
    parking = cands.target < 0
    a, b = conflict_pairs(cands, neighbour_pairs(geom, margin_mm), geom.buffer, margin_mm)
    by_parked = np.zeros(cands.n, dtype=np.int64)
    by_assigned = np.zeros(cands.n, dtype=np.int64)
    for x, y in ((a, b), (b, a)):
        hit = is_chosen[y]
        np.add.at(by_parked, x[hit & parking[y]], 1)
        np.add.at(by_assigned, x[hit & ~parking[y]], 1)
    robot_parked = parking[chosen][cands.robot]
    code = np.where(~robot_parked, 3, np.where(by_assigned > 0, 2, np.where(by_parked > 0, 1, 0)))
    real = cands.target >= 0
    n_t = wanted.shape[0]
    best = np.full(n_t, len(MISS_REASONS), dtype=np.int64)
    np.minimum.at(best, cands.target[real], code[real])
    taken = np.zeros(n_t, dtype=bool)
    taken[assignment.target[assignment.target >= 0]] = True
    missed = wanted & ~taken & (best < len(MISS_REASONS))
    counts = np.bincount(best[missed], minlength=len(MISS_REASONS))
    return {name: int(counts[k]) for k, name in enumerate(MISS_REASONS)}
