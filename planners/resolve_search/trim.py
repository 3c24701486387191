"""Cutting the detours robots make after arriving: :func:`trim_tails`.

A Markov run that deadlocks goes on to its step limit, and the robots around its stuck
ones keep stepping aside and back (Sayres 2021 Eq. 10) all that time. Before the search
(:mod:`rfp_twin.planners.resolve_search.resolve`) those detours are cut where the step rule
allows it, so that they are neither moving obstacles for the search nor length of the
plan.

Units: angles in deg, lengths in mm, time in planner steps.
"""
from __future__ import annotations

import math

import numpy as np

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.planners.resolve_search.kernels import pair_conflict, segments_at
from rfp_twin.planners.resolve_search.paths import PathSet


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
        ks = np.arange(math.floor(first), math.ceil(end) + 1, dtype=np.float64)
        bj = geom.base_xy[j]
        held = segments_at(float(bj[0]), float(bj[1]), np.ascontiguousarray(
            np.repeat(dest[j][None, :], ks.size, axis=0)), float(geom.alpha_len[j]),
            float(geom.seg_start[j]), float(geom.seg_end[j]))
        ok = True
        for k in geom.nbr_idx[geom.nbr_ptr[j]:geom.nbr_ptr[j + 1]]:
            k = int(k)
            bk = geom.base_xy[k]
            seg_k = segments_at(float(bk[0]), float(bk[1]), np.ascontiguousarray(paths.sample(k, ks)),
                                 float(geom.alpha_len[k]), float(geom.seg_start[k]),
                                 float(geom.seg_end[k]))
            if pair_conflict(held, seg_k, float(geom.buffer[j] + geom.buffer[k]) + md):
                ok = False
                break
        if ok:
            paths.steps[j] = np.append(st[:at[0] + 1], st[-1])
            paths.angles[j] = np.vstack([an[:at[0] + 1], dest[j][None, :]])
            trimmed.append(j)
    return trimmed
