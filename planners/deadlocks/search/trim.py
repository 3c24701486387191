"""Cutting the detours robots make after arriving: :func:`trim_tails`.

A Markov run that deadlocks goes on to its step limit, and the robots around its stuck
ones keep stepping aside and back (Sayres 2021 Eq. 10) all that time. Before the search
(:mod:`rfp_twin.planners.deadlocks.search.resolve`) those detours are cut where the step rule
allows it, so that they are neither moving obstacles for the search nor length of the
plan.

Units: angles in deg, lengths in mm, time in planner steps.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.geometry2d import DEG, beta_segment, segment_distance, segments_within
from rfp_twin.planners.roadmap.alpha_beta.paths import PathSet


def trim_tails(geom: ArrayGeometry, paths: PathSet, dest: np.ndarray, skip: np.ndarray,
               md: float) -> list[int]:
    """Robots that reach their destination and leave it again stay there instead, where
    that is safe. Updates ``paths`` in place; returns the robot indices trimmed.

    A Markov run that deadlocks goes on to its step limit, and the arrived neighbours of
    its stuck robots keep stepping aside and back (Eq. 10) all that time: moving
    obstacles for the search, and a plan as long as the step limit. Robot j's path is
    cut at its first arrival (then it holds its destination) when, at every step from
    there to the end, its held capsule keeps the step rule (``buffer_j + buffer_k + MD``)
    with the *current* path of every Eq. 4 neighbour k; robots are taken in index order,
    each against the paths as trimmed so far, so every pair stays checked. The
    destination is clear of fiducials and offline robots (the caller checked it).

    Parameters
    ----------
    geom : ArrayGeometry (each robot's own ``alpha_len``, ``seg_start``, ``seg_end``,
        ``buffer``, (n,) mm); paths : PathSet (planning frame, step clock)
    dest : (n, 2) deg, destinations; skip : (n,) bool, robots left alone (stuck, offline)
    md : float, step-rule margin MD, mm
    """
    n = geom.n_robots
    end = max((paths.motion_end(i) for i in range(n)), default=0.0)
    trimmed = []
    for j in range(n):
        if skip[j]:
            continue
        st, an = paths.steps[j], paths.angles[j]
        at = np.flatnonzero(np.all(np.abs(an - dest[j]) < 1e-9, axis=1))
        if at.size == 0 or paths.motion_end(j) <= st[at[0]]:
            continue                    # never arrives, or arrives once and stays
        first = float(st[at[0]])
        bj = geom.base_xy[j]
        held = beta_segment(float(bj[0]), float(bj[1]), float(dest[j, 0]), float(dest[j, 1]),
                            float(geom.alpha_len[j]), float(geom.seg_start[j]),
                            float(geom.seg_end[j]))
        ks = np.arange(math.floor(first), math.ceil(end) + 1, dtype=np.float64)
        ok = True
        for k in geom.nbr_idx[geom.nbr_ptr[j]:geom.nbr_ptr[j + 1]]:
            k = int(k)
            bk = geom.base_xy[k]
            st_k, an_k = paths.steps[k], paths.angles[k]
            if held_meets(*held, np.interp(ks, st_k, an_k[:, 0]), np.interp(ks, st_k, an_k[:, 1]),
                          float(bk[0]), float(bk[1]), float(geom.alpha_len[k]),
                          float(geom.seg_start[k]), float(geom.seg_end[k]),
                          float(geom.buffer[j] + geom.buffer[k]) + md):
                ok = False
                break
        if ok:
            paths.steps[j] = np.append(st[:at[0] + 1], st[-1])
            paths.angles[j] = np.vstack([an[:at[0] + 1], dest[j][None, :]])
            trimmed.append(j)
    return trimmed


@njit(cache=True)
def held_meets(hx0, hy0, hx1, hy1, alpha, beta, bx, by, l_alpha, s0, s1, th):
    """Does a neighbour come within ``th`` mm of a held beta segment (hx0, hy0)-(hx1, hy1)
    at one of its configurations (alpha, beta) ((T,) deg each)? The neighbour's base
    (bx, by) and arm (l_alpha, segment s0..s1) in mm.

    The same answer as testing every configuration with ``segments_within``, which it
    uses; configurations that cannot reach the held segment are skipped: an end of the
    neighbour's segment moves by at most (l_alpha + s) |d alpha| + s |d beta| (s = its
    farther end, rad) from one configuration to the next, so a configuration at distance
    D leaves the next floor((D - th) / rate) ones farther than th (rate: the largest
    such move), and the segment distance follows its ends."""
    n = alpha.shape[0]
    reach = max(abs(s0), abs(s1))
    rate = 0.0
    for k in range(n - 1):
        move = ((l_alpha + reach) * abs(alpha[k + 1] - alpha[k])
                + reach * abs(beta[k + 1] - beta[k])) * DEG
        rate = max(rate, move)
    k = 0
    while k < n:
        x0, y0, x1, y1 = beta_segment(bx, by, alpha[k], beta[k], l_alpha, s0, s1)
        if segments_within(hx0, hy0, hx1, hy1, x0, y0, x1, y1, th):
            return True
        if rate == 0.0:
            return False               # it stands still: every configuration is this one
        gap = segment_distance(hx0, hy0, hx1, hy1, x0, y0, x1, y1) - th
        k += 1 + max(0, int(0.99 * gap / rate))
    return False
