"""Where the calibration's configurations come from: neighbour directions, Sobol
samples of the joint ranges, and a local search that stays in 3D collision (mm, deg).
"""
from __future__ import annotations

import math

import numpy as np
from scipy.spatial import cKDTree
from scipy.stats import qmc

from rfp_twin.models.layout import Layout
from rfp_twin.models.robot import RobotSpec


def neighbour_directions(layout: Layout | None, pitch_mm: float) -> tuple[float, np.ndarray]:
    """Pitch and neighbour directions (deg, in [0, 180)) of a layout.

    With no layout: a hex grid of ``pitch_mm`` (0, 60, 120 deg). With a layout: the
    median nearest-neighbour base distance, and the directions of the robot pairs
    within 5 % of it, rounded to 0.1 deg and folded into [0, 180).
    """
    if layout is None or layout.n_robots < 2:
        return float(pitch_mm), np.array([0.0, 60.0, 120.0])
    xy = np.asarray(layout.robot_xy, dtype=np.float64)
    tree = cKDTree(xy)
    d, _ = tree.query(xy, k=2)
    pitch = float(np.median(d[:, 1]))
    pairs = tree.query_pairs(r=1.05 * pitch, output_type="ndarray")
    v = xy[pairs[:, 1]] - xy[pairs[:, 0]]
    dist = np.hypot(v[:, 0], v[:, 1])
    keep = np.abs(dist - pitch) <= 0.05 * pitch
    ang = np.round(np.degrees(np.arctan2(v[keep, 1], v[keep, 0])) % 180.0, 1) % 180.0
    dirs, counts = np.unique(ang, return_counts=True)
    # directions seen by at least 1 % of the pairs (drops a few crooked real-layout pairs)
    dirs = dirs[counts >= max(1, 0.01 * keep.sum())]
    return pitch, dirs


def uniform_configurations(spec: RobotSpec, n: int, seed: int) -> np.ndarray:
    """Sobol (scrambled) sample of the joint ranges, (n, 4) deg."""
    lo_a, hi_a = spec.alpha_limits_deg
    lo_b, hi_b = spec.beta_limits_deg
    m = int(math.ceil(math.log2(max(n, 2))))
    u = qmc.Sobol(d=4, scramble=True, seed=np.random.default_rng(seed)).random_base2(m)[:n]
    return qmc.scale(u, [lo_a, lo_b, lo_a, lo_b], [hi_a, hi_b, hi_a, hi_b])


def climb(objective, classify, ang0: np.ndarray, dir0: np.ndarray, rng, rounds: int,
          batch: int, step_deg: float = 1.0):
    """Local search raising ``objective`` while staying in 3D collision.

    From each start (rows of ``ang0`` (k, 4) deg, directions ``dir0``), every round
    proposes ``batch`` Gaussian steps; the best proposal whose objective is higher
    *and* that is verified in 3D collision (``classify``: bounds, FCL where needed) is
    kept; the step shrinks (x 0.6) when none is. All starts advance together (one
    ``classify`` call per round).

    Returns
    -------
    best_ang (k, 4) deg, best_val (k,), accepted (m, 4) deg, accepted_dir (m,),
    evaluations (int: 3D classifications).
    """
    cur = np.array(ang0, dtype=np.float64).reshape(-1, 4)
    d = np.asarray(dir0, dtype=np.int64).reshape(-1)
    k = len(cur)
    val = objective(cur, d)
    step = np.full(k, float(step_deg))
    acc_a, acc_d = [], []
    n_eval = 0
    for _ in range(rounds):
        live = np.flatnonzero(step >= 1e-4)
        if live.size == 0:
            break
        noise = rng.normal(0.0, 1.0, (live.size * batch, 4))
        prop = np.repeat(cur[live], batch, axis=0) + noise * np.repeat(step[live], batch)[:, None]
        pdir = np.repeat(d[live], batch)
        owner = np.repeat(live, batch)
        pv = objective(prop, pdir)
        better = np.flatnonzero(pv > val[owner])
        col = np.zeros(len(prop), dtype=bool)
        if better.size:
            col[better] = classify(prop[better], pdir[better])
            n_eval += better.size
        moved = np.zeros(k, dtype=bool)
        for j in np.flatnonzero(col)[np.argsort(-pv[col])]:
            i = owner[j]
            if not moved[i]:
                cur[i], val[i], moved[i] = prop[j], pv[j], True
                acc_a.append(prop[j])
                acc_d.append(d[i])
        step[live[~moved[live]]] *= 0.6
    return (cur, val, np.asarray(acc_a).reshape(-1, 4), np.asarray(acc_d, dtype=np.int64),
            n_eval)


def distinct_top(values: np.ndarray, ang: np.ndarray, dirs: np.ndarray, k: int,
                 cell_deg: float = 5.0) -> np.ndarray:
    """Indices of the ``k`` largest values whose configurations differ (5-deg cells)."""
    out, seen = [], set()
    for i in np.argsort(values)[::-1]:
        key = (int(dirs[i]), *np.floor(ang[i] / cell_deg).astype(int))
        if key in seen:
            continue
        seen.add(key)
        out.append(int(i))
        if len(out) == k:
            break
    return np.asarray(out, dtype=np.int64)
