"""Target sets for probe arms: random tips in the field, clear of each other.

Sabater et al. 2018 plan assignment plans of their target allocator (Sect. 2.1): one
target per arm at most, final poses clear of each other. Here an arm's target is a tip
position drawn uniformly in a disk of the field, turned into the pose reached soonest
from the arm's start (inverse kinematics, outside the ZoA) and kept when that pose is
clear of every other arm's final pose and reachable within the travel-time limit; arms
without a target keep their start pose. Units: mm, deg, s.
"""
from __future__ import annotations

import numpy as np

from rfp_twin.models.errors import TargetError
from rfp_twin.planners.roadmap.probe.world import arm_gaps

#: Tips drawn per arm before a target set is started again.
TRIES_PER_ARM = 200
#: Target sets started at most.
MAX_SETS = 200


def random_target_set(kind, rng: np.random.Generator, n_targets: int, start: np.ndarray | None = None,
                      *, radius_mm: float | None = None, max_travel_s: float = 120.0,
                      clearance_mm: float = 0.0, rest: np.ndarray | None = None,
                      arms: np.ndarray | None = None) -> np.ndarray:
    """(n_arms, 2) deg: ``n_targets`` arms (drawn at random) get a tip in the disk of
    ``radius_mm`` (default the field) about the field centre, the others go to ``rest``
    (default: stay at ``start``, itself park by default; the paper's allocator parks the
    arms it assigns no target, Sect. 2.1). ``arms`` names the arms that get a target
    (default: ``n_targets`` drawn at random).

    Each final pose is outside the ZoA, reached by the direct route within
    ``max_travel_s`` (Eq. 5), and its capsules are more than ``clearance_mm`` beyond
    both safety buffers from every other arm's final pose.
    """
    n = kind.n_arms
    if arms is not None:
        arms = np.asarray(arms, dtype=np.int64)
        n_targets = len(arms)
    if not 0 <= n_targets <= n:
        raise TargetError(f"n_targets = {n_targets}; allowed: [0, {n}] (arms on the bench)")
    start = kind.park() if start is None else np.asarray(start, dtype=np.float64)
    rest = start if rest is None else np.asarray(rest, dtype=np.float64)
    radius = kind.spec.field_radius_mm if radius_mm is None else float(radius_mm)
    vmax = kind.max_speed_deg_s()
    pad = 2.0 * kind.spec.buffer_mm + clearance_mm
    frames = kind.frames()
    for _ in range(MAX_SETS):
        goal = rest.copy()
        chosen = rng.permutation(n)[:n_targets] if arms is None else rng.permutation(arms)
        placed = np.zeros(n, dtype=bool)
        placed[np.setdiff1d(np.arange(n), chosen)] = True   # arms going to their rest pose
        ok = True
        for i in chosen:
            r = radius * np.sqrt(rng.random(TRIES_PER_ARM))
            phi = rng.uniform(0.0, 2.0 * np.pi, TRIES_PER_ARM)
            tips = kind.to_arm(int(i), np.column_stack([r * np.cos(phi), r * np.sin(phi)]))
            poses = kind.inverse(tips, start[i])
            fine = np.all(np.isfinite(poses), axis=1)
            fine &= np.max(np.abs(poses - start[i]) / vmax, axis=1) <= max_travel_s
            found = False
            for q in poses[fine]:
                goal[i] = q
                gaps = arm_gaps(goal, int(i), kind.links, kind.sizes, frames, pad)
                if np.all(gaps[placed] > 0.0):
                    found = True
                    break
            if not found:
                ok = False
                break
            placed[i] = True
        if ok:
            return goal
    raise TargetError(f"no set of {n_targets} clear targets in a {radius:g} mm disk after "
                      f"{MAX_SETS} tries; allowed: fewer targets or a larger disk")


def typical_scenario(kind, seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """A scenario like Sabater 2018 Sect. 8.1: every arm from park; nine targets near the
    field centre (tips drawn in the central :data:`TYPICAL_CORE_MM` disk, so that routes
    cross and pass other arms' goals: en-route and goal conflicts, Fig. 13), the other
    arms to blank sky anywhere in the field (the allocator's choice for arms without a
    target, Sect. 2.1; all 12 arms move in Tables 1-2). Returns ``(start, goal)``,
    (n_arms, 2) deg each. The paper's target positions are not published; this set is
    ours."""
    rng = np.random.default_rng(seed)
    start = kind.park()
    n_core = min(TYPICAL_TARGETS, kind.n_arms)
    goal = random_target_set(kind, rng, n_core, start, radius_mm=TYPICAL_CORE_MM)
    rest = np.flatnonzero(np.all(goal == start, axis=1))
    return start, random_target_set(kind, rng, 0, start, rest=goal, arms=rest)


#: Science targets of the typical scenario (Sabater 2018 Fig. 6: nine of twelve arms).
TYPICAL_TARGETS = 9
#: Radius of the central disk its targets are drawn in, mm.
TYPICAL_CORE_MM = 70.0
