"""Small plans and timing fixtures shared by the smoothing, timing and post-processing tests."""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from rfp_twin.planners.plan import Plan
from rfp_twin.planners.postprocess.smoothing import smooth_plan, window_for_limits
from rfp_twin.planners.postprocess.timing import TimeLaw, interaction_groups, interaction_pairs
from tests.planners.conftest import make_geom, plan_random

#: SDSS-V axis limits, deg/s and deg/s^2.
V, A = 30.0, 45.0


def make_plan(paths, step_deg: float = 0.1) -> Plan:
    """A Plan from per-robot (steps, angles) breakpoints, built inline."""
    n = len(paths)
    ptr = np.zeros(n + 1, dtype=np.int64)
    ptr[1:] = np.cumsum([len(s) for s, _ in paths])
    n_steps = int(max(s[-1] for s, _ in paths))
    return Plan(np.arange(1, n + 1), step_deg, step_deg / 30.0, n_steps, ptr,
                np.concatenate([np.asarray(s, float) for s, _ in paths]),
                np.concatenate([np.asarray(a, float).reshape(-1, 2) for _, a in paths]),
                np.array(["reached"] * n, dtype=object), np.zeros((n, 2)), np.zeros((n, 2)))


# one robot: alpha rises 0.1 deg/step for 300 steps then falls for 100 (a reversal);
# beta waits 100 steps, then falls 0.1 deg/step (a start corner)
CORNER = make_plan([([0, 100, 300, 400], [[10, 170], [20, 170], [40, 150], [30, 140]])])


def numeric_kinematics(path, robots, law: TimeLaw, dt: float = 2e-4):
    """Largest |dq/dt| and |d2q/dt2| of the smooth timed path, by finite differences."""
    t = np.arange(0.0, law.duration + dt, dt)
    q = path.evaluate(law.s_at(t), robots).reshape(t.size, -1)
    v = np.diff(q, axis=0) / dt
    a = np.diff(q, 2, axis=0) / dt**2
    return np.abs(v).max(), np.abs(a).max()


@lru_cache(maxsize=None)
def real_groups(n_positions: int = 37, buffer_mm: float = 2.0, seed: int = 2):
    """A real greedy plan at 0.1 deg, smoothed as the pipeline does (window v^2 / (a d)),
    and its interaction groups (1 mm): (path, [robot index arrays]). Cached: read only."""
    geom = make_geom(n_positions, buffer_mm)
    _, plan = plan_random(geom, seed, step_deg=0.1)
    sp = smooth_plan(plan, window_steps=window_for_limits((V, V), (A, A), plan.step_deg))
    pairs, cl = interaction_pairs(plan, geom, 1.0)
    labels = interaction_groups(geom.n_robots, pairs[cl < 1.0])
    return sp, [np.flatnonzero(labels == g) for g in np.unique(labels)]
