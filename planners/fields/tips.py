"""Seeded random configurations with fiber tips apart: the tip model's starts and targets.

Makarem et al. 2014 (Sect. 6) test their planner on random starts and targets whose
fiber tips are "at least d apart". :func:`random_tip_configs` draws such
configurations: right-armed, tips uniform (by area) in the patrol annulus, clear of the
tips already placed and of the fiducial disks. Only tips count (not the arms' capsules):
for the segment model use :func:`rfp_twin.planners.plan.targets.random_targets` with
:func:`rfp_twin.planners.fields.apf_target_margin_mm`. Angles in deg, lengths in mm.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.errors import TargetError
from rfp_twin.models.kinematics import sample_patrol_zone
from rfp_twin.models.geometry2d import project_sq
from rfp_twin.planners.fields.settings import DEG, checked_number, obstacle_csr


@njit(cache=True)
def assign_tips(base, pool, fixed, out, nbr_ptr, nbr_idx, fid_ptr, fid_idx, fid_a, fid_b, la, lb,
                 sep, fid_sep):
    """For each robot in order, the first pool entry whose tip is > sep from the tips of
    robots already placed and > fid_sep[f] from each obstacle f (segment fid_a[f]-fid_b[f],
    (m, 2) mm, a point where equal). la : (n,) alpha lengths, mm; pool : (n, k, 2) deg.
    Returns the first robot without a fit, or -1."""
    n = base.shape[0]
    placed = fixed.copy()
    for i in range(n):
        if fixed[i]:
            continue
        ok_any = False
        for c in range(pool.shape[1]):
            a = pool[i, c, 0] * DEG
            b = pool[i, c, 1] * DEG
            tx = base[i, 0] + la[i] * math.cos(a) + lb * math.cos(a + b)
            ty = base[i, 1] + la[i] * math.sin(a) + lb * math.sin(a + b)
            ok = True
            for kk in range(nbr_ptr[i], nbr_ptr[i + 1]):
                j = nbr_idx[kk]
                if not placed[j]:
                    continue
                aj = out[j, 0] * DEG
                bj = out[j, 1] * DEG
                ux = base[j, 0] + la[j] * math.cos(aj) + lb * math.cos(aj + bj) - tx
                uy = base[j, 1] + la[j] * math.sin(aj) + lb * math.sin(aj + bj) - ty
                if ux * ux + uy * uy <= sep * sep:
                    ok = False
                    break
            if ok:
                for kk in range(fid_ptr[i], fid_ptr[i + 1]):
                    f = fid_idx[kk]
                    fs = fid_sep[f]
                    if fid_a[f, 0] == fid_b[f, 0] and fid_a[f, 1] == fid_b[f, 1]:
                        d2 = (fid_a[f, 0] - tx) ** 2 + (fid_a[f, 1] - ty) ** 2
                    else:
                        d2 = project_sq(tx, ty, fid_a[f, 0], fid_a[f, 1], fid_b[f, 0], fid_b[f, 1])[0]
                    if d2 <= fs * fs:
                        ok = False
                        break
            if ok:
                out[i, 0] = pool[i, c, 0]
                out[i, 1] = pool[i, c, 1]
                placed[i] = True
                ok_any = True
                break
        if not ok_any:
            return i
    return -1


def random_tip_configs(geom: ArrayGeometry, rng: np.random.Generator, min_sep_mm: float, *,
                       fixed=None, initial=None, pool: int = 256, attempts: int = 20) -> np.ndarray:
    """Seeded random right-armed configurations whose fiber tips are > min_sep_mm apart.

    Tips uniform (by area) in each robot's own patrol annulus (its alpha length,
    ``geom.alpha_len``, and the beta length); robots are placed in index order, each
    taking its first draw clear of the tips already placed and of the obstacles (points
    or segments, keep-out ``min_sep_mm / 2 + geom.fid_buffer``). Only the tips are
    considered: this is the tip model of Makarem 2014, whose targets are "at least d
    apart". Robots sharing an alpha length draw together (a nominal layout: one draw).

    Parameters
    ----------
    geom : ArrayGeometry
    rng : numpy Generator
    min_sep_mm : float > 0
    fixed : (n,) bool, rows of ``initial`` to keep (offline robots)
    initial : (n, 2) deg
    pool, attempts : draws per robot, whole-draw restarts

    Returns
    -------
    (n, 2) float64 deg

    Raises
    ------
    TargetError
        When no clear spot is found for some robot in ``attempts`` draws.
    """
    sep = checked_number(min_sep_mm, "min_sep_mm", 0.0, 1e3, "(0, 1000] mm", where="random_tip_configs")
    spec = geom.spec
    n = geom.n_robots
    la_arr = np.ascontiguousarray(geom.alpha_len, dtype=np.float64)
    la = float(la_arr.max()) if n else spec.alpha_length_mm
    lb = spec.beta_length_mm
    ptr, idx = geom.layout.neighbour_csr(2.0 * (la + lb) + sep)
    fsep = sep / 2.0 + spec.fiducial_buffer_mm
    fptr, fidx = obstacle_csr(geom, la + lb + fsep)
    fsep_arr = np.ascontiguousarray(sep / 2.0 + geom.fid_buffer, dtype=np.float64)
    groups = [np.flatnonzero(la_arr == v) for v in np.unique(la_arr)]
    fix = np.zeros(n, dtype=bool) if fixed is None else np.asarray(fixed, dtype=bool)
    bad = -1
    for _ in range(max(1, attempts)):
        out = np.zeros((n, 2)) if initial is None else np.array(initial, dtype=np.float64)
        draws = np.empty((n, pool, 2))
        for rows in groups:
            draws[rows] = sample_patrol_zone(rng, rows.size * pool, float(la_arr[rows[0]]),
                                             lb).reshape(rows.size, pool, 2)
        bad = assign_tips(geom.base_xy, draws, fix, out, np.asarray(ptr, dtype=np.int64),
                           np.asarray(idx, dtype=np.int64), fptr, fidx,
                           np.ascontiguousarray(geom.fid_xy, dtype=np.float64).reshape(-1, 2),
                           np.ascontiguousarray(geom.fid_end_xy, dtype=np.float64).reshape(-1, 2),
                           la_arr, lb, sep, fsep_arr)
        if bad < 0:
            return out
    raise TargetError(f"robot {int(geom.robot_ids[bad])}: no random tip position > {sep} mm from "
                      f"its neighbours' in {attempts} x {pool} draws; allowed: a smaller "
                      "'min_sep_mm'")
