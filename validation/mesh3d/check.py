"""The 3D check of a whole trajectory: :func:`validate_trajectory` (mm, deg, s).

What is reported (:class:`Check3DReport`)
-----------------------------------------
* For every *pair* that can touch (robot-robot, robot-fiducial: some link of one can
  come within ``min_gap_mm`` of some link of the other for some joint angles,
  :mod:`rfp_twin.validation.mesh3d.scene`), the smallest 3D distance over the whole motion (the
  smallest FCL distance sampled, an upper bound of the true minimum, within
  ``distance_tol_mm + distance_rel_tol * clearance`` of it), its time and the two links.
* Every 3D collision: time interval, robots / fiducial, links, as :class:`Collision3D`.
  A "collision" is a distance ``<= min_gap_mm`` (default 0: contact). Solid overlap
  counts even when no surfaces cross (:mod:`rfp_twin.validation.mesh3d.exact`).

An interval is *cleared* (no collision inside) when the interval bound of
:mod:`rfp_twin.validation.mesh3d.broadphase` is ``> min_gap_mm``. Every part of ``[T0, T1]`` is
either cleared, or bisected until it is, or reported: as a collision when a sample is
``<= min_gap_mm``, or (``conservative = True``) when an interval no longer than
``resolution_s`` still cannot be cleared. No instant is left unexamined, so a contact,
however brief, is either found or covered by a conservative report.

Algorithm
---------
1. *Lower-bound minimum* (numba, every candidate link pair, :func:`capsule_min`):
   ``Cmin``, its time, and a *certificate* ``cert``: ``C(t) >= cert`` on the whole span
   (``-inf`` if a leaf hit ``resolution_s`` first).
2. *Seed* (FCL GJK): per pair, ``D`` at the time of ``Cmin`` of its link pairs, in
   increasing ``Cmin``, while ``Cmin`` is below the pair's best ``D`` so far minus the
   tolerance. ``best`` = the pair's smallest ``D``. The seed values are GJK distances
   of the pieces as convex solids: distances of two points of the solids, so upper
   bounds of the exact ``D`` (equal to it on most poses; exact BVH distances replace
   those ``<= min_gap_mm``). Every guarantee below holds for any upper bound: a pair
   is closed only by its lower bound reaching ``best - tol``, and an inaccurate seed
   only leaves more suspect intervals to the exact step 4.
3. *Suspect intervals* (numba, :func:`capsule_suspects`), only for link pairs whose
   certificate does not already exceed both ``min_gap_mm`` and ``cut = best - tol`` (on
   the SDSS-V meshes: none in a collision-free fold): bisection of ``C`` again, keeping
   what the bound cannot clear; emitted intervals are short enough (``L h <= 2 tol``)
   that exact values at their ends usually settle them, except where ``C`` is at or
   below the threshold at both ends (inside a contact): there intervals of up to
   :data:`CONTACT_MM` of relative motion are emitted whole, which two colliding ends
   settle at once.
4. *Exact* (FCL): ``D`` at the ends of every suspect interval (batched), then any
   interval still not cleared is bisected with exact values down to ``resolution_s``
   (collision start / end, conservative reports, and the pair minimum). A point whose
   ``C`` already exceeds both the threshold and the pair's cut keeps ``C`` (a lower
   bound is all the interval bound needs there) and costs no FCL call. FCL gives no
   penetration depth (``D = 0`` inside a collision), so an interval whose two ends
   collide is reported as colliding throughout: a collision's ``[t_start, t_end]`` may
   contain a brief separation, never a missed contact.

Per-robot geometry (layout columns, :func:`rfp_twin.validation.mesh3d.links.placement`):
each robot's alpha arm, base height and axis (the whole robot tilted) place its links; a
segment obstacle (a guide-camera edge) is a wall that beta arms are checked against
(reported as ``kind`` ``"fiducial"``, link ``"gfa"``). The bounds of steps 1 and 3 are
taken in a frame per pair with slacks for the tilts (:mod:`rfp_twin.validation.mesh3d.scene`);
FCL (steps 2 and 4) uses the true world transforms. Nominal layouts give the same
results, bit for bit, as without these columns.

Colliding samples and colliding intervals of one link pair at most ``resolution_s``
apart are merged into one :class:`Collision3D` (start / end accurate to
``resolution_s``). The report splits wall time into *broadphase* (candidate pairs,
lower bounds: steps 1 and 3) and *exact* (FCL calls and their bookkeeping: 2 and 4).
Robots of the layout that the trajectory does not list are not checked.
"""
from __future__ import annotations

import math
import time
from typing import Callable, Optional

import numpy as np

from rfp_twin.models.errors import SpecError, field_error
from rfp_twin.models.geometry import LINKS, RobotGeometry, geometry_for_spec
from rfp_twin.models.layout import Layout
from rfp_twin.models.robot import RobotSpec
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.validation.mesh3d.broadphase import (bound_at, capsule_min, capsule_suspects,
                                                   poses_and_bounds, query_angles)
from rfp_twin.validation.mesh3d.exact import ExactDistance
from rfp_twin.validation.mesh3d.links import WALL, LinkModels
from rfp_twin.validation.mesh3d.report import Check3DReport, Collision3D, PairDistance
from rfp_twin.validation.mesh3d.scene import Scene
from rfp_twin.validation.numerics import axis_csr, checked_float, time_span

#: Samples whose capsule bound is within this of the current cut also get the (slower,
#: tighter) hull-prism bound, mm (and within this + 1 mm the 3D capsule bound,
#: :data:`rfp_twin.validation.mesh3d.bounds.CAPSULE3_WITHIN_MM`). 0: above the cut the hull
#: bound changes few decisions (~0.5 % more samples without it on a 500-robot fold) at a
#: high price (a 2D GJK per piece pair, ~45 % of that fold's broadphase).
TIGHT_MM = 0.0
#: Relative motion (mm) of a suspect interval whose capsule bound is at or below the
#: threshold at both ends, handed whole to the exact step (:func:`capsule_suspects`).
CONTACT_MM = 8.0


def _positive(value, name: str, allow_zero: bool = False) -> float:
    return checked_float(value, name, f"a finite number {'>=' if allow_zero else '>'} 0",
                         "validate_trajectory", strict=not allow_zero)


def validate_trajectory(traj: Trajectory, spec: RobotSpec, layout: Layout,
                        geometry: RobotGeometry | LinkModels | None = None, *,
                        min_gap_mm: float = 0.0, resolution_s: float = 1e-5,
                        distance_tol_mm: float = 0.01, distance_rel_tol: float = 0.05,
                        coarse_mm: float = 4.0,
                        progress: Optional[Callable[[str, int, int], None]] = None
                        ) -> Check3DReport:
    """Check a trajectory against the 3D collision meshes with FCL.

    Parameters
    ----------
    traj : Trajectory
        Robots are matched to the layout by id; layout robots it does not list are
        not checked.
    spec : RobotSpec
        Used for the default geometry (:func:`rfp_twin.models.geometry.geometry_for_spec`).
    layout : Layout
        Robot bases and obstacles (checked against every robot), with each robot's own
        geometry where the layout has the columns.
    geometry : RobotGeometry or LinkModels, optional
        The meshes; build :class:`LinkModels` once to reuse them over many checks.
    min_gap_mm : float
        Two links at a 3D distance ``<= min_gap_mm`` collide (default 0: contact).
    resolution_s : float
        Shortest interval bisected; an interval this short that the bounds cannot
        clear is reported as a (conservative) collision. Also the precision of
        collision start / end times.
    distance_tol_mm, distance_rel_tol : float
        Per-pair minima are found to within ``distance_tol_mm + distance_rel_tol *
        (distance - min_gap)``.
    coarse_mm : float
        Spacing of the first grid: the pair's mean point speed times the spacing.
        Sets only where refinement starts, not the guarantee.
    progress : callable(stage, done, total), optional
        Called as stages advance (``"capsule bounds"``, ``"exact distances"``).

    Returns
    -------
    Check3DReport

    Raises
    ------
    UnknownRobotError
        A trajectory robot id that is not a robot of the layout.
    TrajectoryError
        Duplicate robot ids, or an axis that jumps.
    SpecError
        A parameter out of range.
    """
    clock = time.perf_counter()
    thr = _positive(min_gap_mm, "min_gap_mm", allow_zero=True)
    res = _positive(resolution_s, "resolution_s")
    tol = _positive(distance_tol_mm, "distance_tol_mm", allow_zero=True)
    rel = _positive(distance_rel_tol, "distance_rel_tol", allow_zero=True)
    coarse = _positive(coarse_mm, "coarse_mm")
    if res < 1e-12:
        raise field_error(SpecError, "resolution_s", resolution_s, "a finite number >= 1e-12 s",
                          "validate_trajectory")
    if isinstance(geometry, LinkModels):
        models = geometry
    else:
        models = LinkModels.from_geometry(geometry if geometry is not None
                                          else geometry_for_spec(spec))
    report_progress = progress or (lambda stage, done, total: None)

    scene = Scene(traj, layout, models, thr)
    models = scene.models                  # with the layout's guide-camera walls, if any
    t_lo, t_hi = time_span(traj)
    n_lp = scene.n_link_pairs
    if traj.n_robots:
        pa, ta, aa, ra = axis_csr(traj, 0)
        pb, tb, ab, rb = axis_csr(traj, 1)
    else:
        pa = pb = np.zeros(1, dtype=np.int64)
        ta = aa = ra = tb = ab = rb = np.zeros(0)

    # per object and link kind: global and mean point-speed bounds, mm/s
    vglob, vmean = scene.link_speeds(models, (pa, ta, ra), (pb, tb, rb), t_hi - t_lo)

    kern = (scene.lp_oa, scene.lp_ka, scene.lp_ob, scene.lp_kb, scene.obj_rob, scene.obj_x,
            scene.obj_y, scene.place)
    traj_a = (pa, ta, aa, ra, pb, tb, ab, rb)
    geo = (models.kind_ptr, models.cap, models.zlim, models.poly_ptr, models.poly_xy,
           scene.rad_alpha, scene.rad_beta)

    # -- 1. capsule minimum per link pair ------------------------------------------
    report_progress("capsule bounds", 0, 2)
    n_cap = 0
    if n_lp:
        cmin, tcmin, cert, ne = capsule_min(*kern, *traj_a, *geo, vglob, vmean, t_lo, t_hi,
                                            coarse, TIGHT_MM, res, thr, tol, rel)
        n_cap += int(ne)
    else:
        cmin = tcmin = cert = np.zeros(0)
    t_broad = time.perf_counter() - clock
    report_progress("capsule bounds", 1, 2)

    exact = ExactDistance(models)
    bnd_args = (scene.lp_oa, scene.lp_ka, scene.lp_ob, scene.lp_kb, scene.obj_rob,
                scene.obj_x, scene.obj_y, scene.place, pa, ta, aa, pb, tb, ab,
                models.kind_ptr, models.cap, models.zlim, models.poly_ptr, models.poly_xy,
                models.max_piece_pairs)
    n_groups = len(scene.groups)
    best = np.full(n_groups, np.inf)
    best_t = np.full(n_groups, np.nan)
    best_lp = np.full(n_groups, -1, dtype=np.int64)
    lp_best = np.full(n_lp, np.inf)
    hits: dict[int, list] = {}      # link pair -> [(t_start, t_end, d, t_d, conservative)]

    def eval_exact(qp: np.ndarray, qt: np.ndarray, upper: bool = False) -> np.ndarray:
        """Distances of link pairs ``qp`` at times ``qt`` (exact; ``upper``: GJK upper
        bounds, exact at or below ``thr``), folded into the pair minima and the hits.

        Without ``upper``, a query whose capsule bound ``C`` (the smallest piece-pair
        bound) already exceeds both the threshold and its pair's refinement cut gets ``C``
        instead of an FCL distance: a lower bound of the distance there, which is all the
        interval bounds need, and proof that the instant is neither a contact nor where
        the pair's minimum lies (it does not enter the pair minima)."""
        above = thr if upper else None
        qp = np.asarray(qp, dtype=np.int64)
        qt = np.asarray(qt, dtype=np.float64)
        poses, bounds = poses_and_bounds(qp, qt, *bnd_args)
        if upper:
            settled = np.zeros(len(qp), dtype=bool)
        else:
            cbound = bounds.min(axis=1)
            settled = (cbound > thr) & (cbound >= cuts(best[scene.lp_group[qp]]))
        if scene.placed:       # FCL on the true (tilted) world transforms
            ang = query_angles(qp, qt, scene.lp_oa, scene.lp_ob, scene.obj_rob,
                               pa, ta, aa, pb, tb, ab)
            rot_a, tr_a = scene.world_frames(scene.lp_oa[qp], scene.lp_ka[qp], ang[:, 0], ang[:, 1])
            rot_b, tr_b = scene.world_frames(scene.lp_ob[qp], scene.lp_kb[qp], ang[:, 2], ang[:, 3])
        out = np.empty(len(qp))
        for k in range(len(qp)):
            p = int(qp[k])
            if settled[k]:
                out[k] = cbound[k]
                continue
            ka, kb = int(scene.lp_ka[p]), int(scene.lp_kb[p])
            if scene.placed:
                d = exact.distance_between(ka, rot_a[k], tr_a[k], kb, rot_b[k], tr_b[k],
                                           bounds[k], above)
            else:
                d = exact.distance(ka, poses[k, :3], models.offset_z[ka], kb, poses[k, 3:],
                                   models.offset_z[kb], bounds[k], above)
            out[k] = d
            if d < lp_best[p]:
                lp_best[p] = d
            g = int(scene.lp_group[p])
            if d < best[g]:
                best[g], best_t[g], best_lp[g] = d, float(qt[k]), p
            if d <= thr:
                hits.setdefault(p, []).append((float(qt[k]), float(qt[k]), d, float(qt[k]), False))
        return out

    def cuts(b: np.ndarray) -> np.ndarray:
        """Refinement cut of pair minima ``b``: ``b - tol - rel max(b - thr, 0)`` (inf
        where ``b`` is): a pair whose lower bound reaches it is known to its tolerance."""
        out = np.full(b.shape, np.inf)
        fin = np.isfinite(b)
        out[fin] = b[fin] - tol - rel * np.maximum(b[fin] - thr, 0.0)
        return out

    def want(g: int) -> float:
        return float(cuts(best[g:g + 1])[0])

    # -- 2. seed: distance at the capsule minimum (GJK upper bounds) ------------------
    # Per pair, its link pairs in increasing Cmin while Cmin is below the pair's cut;
    # taken in rounds (the r-th link pair of every pair at once), which evaluates
    # exactly the link pairs the one-by-one order would.
    t0 = time.perf_counter()
    order = np.lexsort((cmin, scene.lp_group))
    grp = scene.lp_group[order]
    first = np.r_[0, np.flatnonzero(np.diff(grp)) + 1] if n_lp else np.zeros(0, dtype=np.int64)
    rank = np.arange(n_lp) - np.repeat(first, np.diff(np.r_[first, n_lp]).astype(np.int64))
    n_rounds = int(rank.max()) + 1 if n_lp else 0
    seen = 0
    for r in range(n_rounds):
        cand = order[rank == r]
        take = cand[cmin[cand] < cuts(best[scene.lp_group[cand]])]
        for s in range(0, len(take), 4096):
            eval_exact(take[s:s + 4096], tcmin[take[s:s + 4096]], upper=True)
            report_progress("exact distances", seen + s, 3 * max(n_lp, 1))
        seen += len(cand)
    t_exact = time.perf_counter() - t0

    # -- 3. suspect intervals (capsule bound cannot clear) ------------------------------
    t0 = time.perf_counter()
    if n_lp:
        cut = cuts(best[scene.lp_group])
        gb = best[scene.lp_group]
        tolp = tol + rel * np.where(np.isfinite(gb), np.maximum(gb - thr, 0.0), 0.0)
        tolp = np.maximum(tolp, 1e-6)
        # step 1 already proved C >= cert[p] everywhere: pairs with cert above both the
        # threshold and their cut need no second pass
        done = (cert > thr) & (cert >= cut - 1e-9 * (1.0 + np.abs(cut)))
        sel = np.flatnonzero(~done).astype(np.int64)
        rows, ne = capsule_suspects(*kern, *traj_a, *geo, vglob, vmean, t_lo, t_hi, coarse,
                                    TIGHT_MM, res, thr, cut, tolp, sel, CONTACT_MM)
        n_cap += int(ne)
    else:
        rows = np.zeros((0, 6))
    t_broad += time.perf_counter() - t0
    report_progress("capsule bounds", 2, 2)

    # -- 4. exact values at the ends of the suspect intervals, then refinement ---------
    t0 = time.perf_counter()
    if len(rows):
        ends = np.concatenate([rows[:, [0, 1]], rows[:, [0, 2]]])
        keys, inv = np.unique(ends, axis=0, return_inverse=True)
        inv = inv.reshape(-1)
        vals = np.empty(len(keys))
        chunk = 4096
        for s in range(0, len(keys), chunk):
            vals[s:s + chunk] = eval_exact(keys[s:s + chunk, 0].astype(np.int64),
                                           keys[s:s + chunk, 1])
            report_progress("exact distances", n_lp + int(s * n_lp / max(len(keys), 1)),
                            3 * max(n_lp, 1))
        d_a, d_b = vals[inv[:len(rows)]], vals[inv[len(rows):]]
        for k in range(len(rows)):
            p = int(rows[k, 0])
            a, b, ca, cb, L = rows[k, 1], rows[k, 2], rows[k, 3], rows[k, 4], rows[k, 5]
            _refine(p, a, b, d_a[k], d_b[k], ca, cb, L, thr, res, scene, eval_exact, want, hits,
                    bnd_args)
    t_exact += time.perf_counter() - t0
    report_progress("exact distances", 3, 3)

    # -- report -------------------------------------------------------------------------
    collisions = _merge_hits(hits, scene, res)
    pairs = []
    kind_min: dict[str, float] = {}
    names = models.kind_names
    for g in range(n_groups):
        kind, a_id, b_id = scene.pair_ids(g)
        p = int(best_lp[g])
        links = (names[int(scene.lp_ka[p])], names[int(scene.lp_kb[p])]) if p >= 0 else ("", "")
        pairs.append(PairDistance(kind, (a_id, b_id), links, float(best[g]), float(best_t[g])))
    # per link-kind pair: smallest exact distance evaluated, and the capsule lower bound
    kind_lb: dict[str, float] = {}
    order = (*LINKS, WALL)
    for p in range(n_lp):
        key = "-".join(sorted((names[int(scene.lp_ka[p])], names[int(scene.lp_kb[p])]),
                              key=order.index))
        kind_min[key] = min(kind_min.get(key, math.inf), float(lp_best[p]))
        kind_lb[key] = min(kind_lb.get(key, math.inf), float(cmin[p]))
    pairs.sort(key=lambda x: (x.min_distance_mm, x.kind, x.ids))
    min_d = min([pd.min_distance_mm for pd in pairs] + [c.min_distance_mm for c in collisions],
                default=math.inf)
    return Check3DReport(
        min_gap_mm=thr, geometry=str(models.geometry.params.source), n_robots=scene.n_robots,
        n_fiducials=scene.n_fiducials, n_pairs=n_groups, n_link_pairs=n_lp,
        duration_s=t_hi - t_lo, pairs=pairs, min_distance_mm=float(min_d),
        link_kind_min_mm=kind_min, link_kind_lower_bound_mm=kind_lb, collisions=collisions,
        n_capsule_evals=n_cap,
        n_exact_evals=exact.n_evals,
        n_fcl_calls=exact.n_calls + exact.n_hull_calls, n_gjk_calls=exact.n_hull_calls,
        seconds_broadphase=t_broad, seconds_exact=t_exact,
        seconds=time.perf_counter() - clock,
        settings={"resolution_s": res, "distance_tol_mm": tol, "distance_rel_tol": rel,
                  "coarse_mm": coarse})


def _refine(p, a, b, da, db, ca, cb, L, thr, res, scene, eval_exact, want, hits, bnd_args):
    """Settle one suspect interval of link pair p with exact values (bisection).

    Clears sub-intervals whose bound ``max(lb_D, lb_C)`` exceeds both the threshold and
    the pair's refinement cut; records colliding intervals and conservative ones.
    """
    g = int(scene.lp_group[p])
    stack = [(a, b, da, db, ca, cb)]
    while stack:
        a, b, da, db, ca, cb = stack.pop()
        h = b - a
        lb = max(0.5 * (da + db - L * h), 0.5 * (ca + cb - L * h))
        col_a, col_b = da <= thr, db <= thr
        split = unresolved = False
        if col_a and col_b:
            # FCL gives no penetration depth (D = 0 inside), so nothing proves an exit
            # between two colliding samples: the interval is reported as colliding
            hits.setdefault(p, []).append((a, b, min(da, db), a if da <= db else b, False))
        elif col_a or col_b:
            split = h > res
            if not split:
                hits.setdefault(p, []).append((a if col_a else b, a if col_a else b,
                                               da if col_a else db, a if col_a else b, False))
        elif lb <= thr:
            split = h > res
            unresolved = not split
        elif lb < want(g):
            split = h > res
        if split:
            m = a + 0.5 * h
            dm = float(eval_exact(np.array([p]), np.array([m]))[0])
            cm = float(bound_at(p, m, *bnd_args[:19], max(thr, want(g)) + TIGHT_MM))
            stack.append((m, b, dm, db, cm, cb))
            stack.append((a, m, da, dm, ca, cm))
        elif unresolved:
            hits.setdefault(p, []).append((a, b, max(lb, 0.0), a + 0.5 * h, True))


def _merge_hits(hits: dict, scene: Scene, res: float) -> list[Collision3D]:
    """Per link pair, merge colliding samples / intervals at most ``res`` apart."""
    out = []
    for p, items in hits.items():
        items = sorted(items)
        any_real = any(not it[4] for it in items)
        if any_real:
            items = [it for it in items if not it[4]]
        runs = []
        for ts, te, d, td, cons in items:
            if runs and ts - runs[-1][1] <= res * (1 + 1e-9):
                r = runs[-1]
                r[1] = max(r[1], te)
                if d < r[2]:
                    r[2], r[3] = d, td
            else:
                runs.append([ts, te, d, td, cons])
        g = int(scene.lp_group[p])
        kind, a_id, b_id = scene.pair_ids(g)
        la, lb = (scene.models.kind_names[int(scene.lp_ka[p])],
                  scene.models.kind_names[int(scene.lp_kb[p])])
        for ts, te, d, td, cons in runs:
            out.append(Collision3D(kind, a_id, la, b_id, lb, ts, te, td, d, cons))
    out.sort(key=lambda c: (c.t_start, c.kind, c.robot_a, c.other, c.link_a, c.link_b))
    return out

