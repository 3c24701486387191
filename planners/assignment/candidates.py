"""Candidates of a fiber assignment: (robot, target, arm, fiber) poses within reach.

A candidate is one way a robot can put one of its fibers on one target: the robot reaches
the target with a fiber the target accepts (``boss`` -> the BOSS fiber, ``apogee`` -> the
APOGEE fiber, ``any`` -> either), on its right arm (beta link turned by [0, 180] deg from
the alpha arm) or its left arm, inside its own travel range, and the pose keeps clear of
every obstacle (fiducials, guide-camera edges) by the collision rule plus a margin. Each
robot also has a parking candidate (the fold, weight 0): the pose of a robot left
without a target, which collides like any other pose. With ``parking="clear"`` a robot
has more parking candidates: the fold turned in alpha by whole multiples of
:data:`CLEAR_PARKING_STEP_DEG` (beta at the fold angle), each inside the robot's range and
clear of obstacles, weighing ``-PARKING_PENALTY``: the assigner moves an idle robot's
folded beta arm off a neighbour's target when that gains a target, and keeps the fold
otherwise.

A layout with fiber columns (a calibrated SDSS-V instrument) uses each robot's own BOSS
and APOGEE fibers (a robot of a ``Boss`` hole has no APOGEE fiber); a layout without them
has one fiber per robot at the spec's ``beta_length_mm`` that serves every target.

Inverse kinematics: :func:`rfp_twin.models.kinematics.inverse_fiber` (each robot's own
alpha arm and fiber, Sayres 2021 Eqs. 1-2) on all (robot, target) pairs within reach.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit
from scipy.spatial import cKDTree

from rfp_twin.models.catalogue import ANY, APOGEE, BOSS, Catalogue
from rfp_twin.models.geometry2d import beta_segment, segment_distance
from rfp_twin.models.kinematics import fiber_polar, inverse_fiber
from rfp_twin.models.layout.columns import FIBER_COLUMNS, fit_to_limits, robot_fibers

#: Arm codes of a candidate.
RIGHT, LEFT, PARKED = 0, 1, -1
ARMS = ("right", "left")
#: Parking modes: the fold only, or the fold and its alpha turns (module docstring).
PARKING_MODES = ("fold", "clear")
DEFAULT_PARKING = "clear"
#: Alpha step of the clear parking poses, deg: the fold turned by k x this, k = 1, 2, ...
CLEAR_PARKING_STEP_DEG = 60.0
#: Weight of a parking pose other than the fold: a tie-break far below any target's
#: priority (CP-SAT scales non-integer weights by 1000, so it stays a whole unit there).
PARKING_PENALTY = 1e-3
#: Fiber slots of a robot: 0 BOSS (or the one fiber of a generic robot), 1 APOGEE.
SLOT_NAMES = ("boss", "apogee")


@dataclass(frozen=True)
class Candidates:
    """Every candidate pose of an assignment (c candidates, n robots), grouped by robot.

    Candidates of robot ``i`` are ``ptr[i]:ptr[i + 1]``; the first of them is its
    fold (target -1, weight 0), then its other parking poses if any (target -1, weight
    ``-PARKING_PENALTY``), then its targets.

    Attributes
    ----------
    robot : (c,) int64 robot index
    target : (c,) int64 catalogue row, -1 for parking
    angles : (c, 2) float64 (alpha, beta) model angles, deg, inside the robot's range
    arm : (c,) int8 RIGHT / LEFT / PARKED
    slot : (c,) int8 fiber slot (0 BOSS or the generic fiber, 1 APOGEE; -1 parking)
    weight : (c,) float64 the target's priority (0 for the fold, ``-PARKING_PENALTY`` for
        another parking pose)
    seg : (c, 4) float64 beta collision segment (x0, y0, x1, y1), mm
    ptr : (n + 1,) int64
    """

    robot: np.ndarray
    target: np.ndarray
    angles: np.ndarray
    arm: np.ndarray
    slot: np.ndarray
    weight: np.ndarray
    seg: np.ndarray
    ptr: np.ndarray

    @property
    def n(self) -> int:
        return int(self.robot.size)

    @property
    def parking(self) -> np.ndarray:
        """(n_robots,) int64 index of each robot's fold candidate."""
        return self.ptr[:-1]


def robot_fiber_slots(geom) -> np.ndarray:
    """(n, 2, 2) float64 each robot's fibers in the beta-arm frame, mm, by slot (BOSS,
    APOGEE); NaN where a robot does not carry one (module docstring)."""
    layout = geom.layout
    if any(c in layout.extra for cols in FIBER_COLUMNS.values() for c in cols):
        return robot_fibers(layout, {})[:, 1:3].copy()
    out = np.full((geom.n_robots, 2, 2), np.nan)
    out[:, 0] = (geom.spec.beta_length_mm, 0.0)
    return out


def _slot_accepts(generic: bool) -> np.ndarray:
    """(3 target fibers, 2 slots) bool: which slot serves which target fiber."""
    acc = np.zeros((3, 2), dtype=bool)
    if generic:
        acc[:, 0] = True
    else:
        acc[BOSS, 0] = acc[APOGEE, 1] = acc[ANY, 0] = acc[ANY, 1] = True
    return acc


def parking_angles(geom) -> np.ndarray:
    """(n, 2) deg each robot's parking pose: the spec's fold turned into its range."""
    fold = np.tile(np.asarray(geom.spec.fold_deg, dtype=np.float64), (geom.n_robots, 1))
    return fit_to_limits(fold, geom.limits)[0]


def clear_parking_angles(geom) -> tuple[np.ndarray, np.ndarray]:
    """The parking poses besides the fold (module docstring): ``(robot (p,) int64,
    angles (p, 2) deg)``, the fold's alpha turned by k x :data:`CLEAR_PARKING_STEP_DEG`
    (k = 1 .. 360 / step - 1), beta at the fold angle, kept where inside the robot's range."""
    n = geom.n_robots
    steps = np.arange(1, int(round(360.0 / CLEAR_PARKING_STEP_DEG)))
    fold = np.asarray(geom.spec.fold_deg, dtype=np.float64)
    ang = np.empty((n, steps.size, 2))
    ang[..., 0] = fold[0] + steps * CLEAR_PARKING_STEP_DEG
    ang[..., 1] = fold[1]
    fitted, inside = fit_to_limits(ang, geom.limits[:, None, :])
    robot = np.repeat(np.arange(n, dtype=np.int64), steps.size).reshape(n, steps.size)
    return robot[inside], fitted[inside].reshape(-1, 2)


#: A left-armed pose is a candidate only this far (mm) inside the rim of the patrol annulus:
#: at the rim both arm solutions are the same pose.
RIM_MM = 1e-9


def _solve(base: np.ndarray, xy: np.ndarray, la: np.ndarray, fiber_xy: np.ndarray,
           length: np.ndarray, left: bool) -> tuple[np.ndarray, np.ndarray]:
    """(angles (k, 2) deg, ok (k,) bool): model angles putting a fiber (``fiber_xy`` (k, 2)
    mm in the beta-arm frame, ``length`` (k,) mm from the beta axis) on ``xy`` (k, 2) from
    bases ``base`` (k, 2) with alpha arms ``la`` (k,), one arm; rows out of reach are not
    ok (their angles 0). The kinematics is
    :func:`rfp_twin.models.kinematics.inverse_fiber` on the reachable rows."""
    r = np.hypot(xy[:, 0] - base[:, 0], xy[:, 1] - base[:, 1])
    lo, hi = np.abs(la - length), la + length
    ok = (r >= lo) & (r <= hi)
    if left:
        ok &= (r > lo + RIM_MM) & (r < hi - RIM_MM)
    out = np.zeros((xy.shape[0], 2))
    if ok.any():
        out[ok] = inverse_fiber(base[ok], xy[ok], la[ok], fiber_xy[ok], right_arm=not left)
    return out, ok


@njit(cache=True)
def _segments(base_xy, robot, angles, alpha_len, seg_start, seg_end, out):
    """Fill out (c, 4) with each candidate's beta collision segment, mm."""
    for k in range(robot.shape[0]):
        i = robot[k]
        x0, y0, x1, y1 = beta_segment(base_xy[i, 0], base_xy[i, 1], angles[k, 0], angles[k, 1],
                                      alpha_len[i], seg_start[i], seg_end[i])
        out[k, 0] = x0
        out[k, 1] = y0
        out[k, 2] = x1
        out[k, 3] = y1


@njit(cache=True)
def _obstacle_clear(robot, seg, fid_ptr, fid_idx, fid_xy, fid_end_xy, fid_buffer, buffer,
                    margin, out):
    """out[k] = True when candidate k's segment keeps clear of every obstacle near its robot
    by more than (robot buffer + obstacle keep-out + margin)."""
    for k in range(robot.shape[0]):
        i = robot[k]
        ok = True
        for q in range(fid_ptr[i], fid_ptr[i + 1]):
            f = fid_idx[q]
            d = segment_distance(seg[k, 0], seg[k, 1], seg[k, 2], seg[k, 3], fid_xy[f, 0],
                                 fid_xy[f, 1], fid_end_xy[f, 0], fid_end_xy[f, 1])
            if d <= buffer[i] + fid_buffer[f] + margin:
                ok = False
                break
        out[k] = ok


def build_candidates(geom, catalogue: Catalogue, *, margin_mm: float = 0.0,
                     arms: tuple[str, ...] = ARMS,
                     forbidden: set[tuple[int, int]] | None = None,
                     fixed: dict[int, tuple[float, float]] | None = None,
                     parking: str = DEFAULT_PARKING) -> Candidates:
    """Every candidate pose of ``catalogue`` on ``geom`` (module docstring).

    Parameters
    ----------
    geom : rfp_twin.models.array.ArrayGeometry
    catalogue : targets in the planning frame
    margin_mm : clearance beyond the collision rule that a pose keeps from obstacles
    arms : which arm solutions are candidates (``right``, ``left``)
    forbidden : {(robot id, target id)} pairs that may not be candidates
    fixed : {robot id: (alpha, beta) deg} robots that do not move (offline): their one
        candidate is that pose, in place of the parking pose
    parking : fold | clear (:data:`PARKING_MODES`): the fold only, or also its alpha turns
    """
    n = geom.n_robots
    slots = robot_fiber_slots(geom)
    generic = bool(np.all(np.isnan(slots[:, 1, 0])) and not any(
        c in geom.layout.extra for c in FIBER_COLUMNS["boss"]))
    accepts = _slot_accepts(generic)
    length = fiber_polar(slots.reshape(-1, 2))[0].reshape(n, 2)
    la = geom.alpha_len
    reach = float(np.nanmax(la[:, None] + length)) if n else 0.0

    pairs_r = np.zeros(0, dtype=np.int64)
    pairs_t = np.zeros(0, dtype=np.int64)
    if catalogue.n_targets and n:
        tree = cKDTree(catalogue.xy)
        hits = tree.query_ball_point(geom.base_xy, r=reach + 1e-9, return_sorted=False)
        counts = np.fromiter((len(h) for h in hits), dtype=np.int64, count=n)
        pairs_r = np.repeat(np.arange(n, dtype=np.int64), counts)
        pairs_t = (np.concatenate([np.asarray(h, dtype=np.int64) for h in hits])
                   if counts.sum() else np.zeros(0, dtype=np.int64))
    if forbidden:
        bad = np.array([(int(geom.robot_ids[r]), int(catalogue.ids[t])) in forbidden
                        for r, t in zip(pairs_r.tolist(), pairs_t.tolist())], dtype=bool)
        pairs_r, pairs_t = pairs_r[~bad], pairs_t[~bad]
    still = np.zeros(n, dtype=bool)
    fixed_rows = {geom.layout.robot_index(int(r)): ang for r, ang in (fixed or {}).items()}
    if fixed_rows:
        still[list(fixed_rows)] = True
        keep = ~still[pairs_r]       # an offline robot takes no target
        pairs_r, pairs_t = pairs_r[keep], pairs_t[keep]

    parts = []
    for s in range(2):
        keep = accepts[catalogue.fiber[pairs_t], s] & np.isfinite(length[pairs_r, s])
        r_s, t_s = pairs_r[keep], pairs_t[keep]
        for arm in arms:
            left = arm == "left"
            ang, ok = _solve(geom.base_xy[r_s], catalogue.xy[t_s], la[r_s], slots[r_s, s],
                             length[r_s, s], left)
            ang, inside = fit_to_limits(ang, geom.limits[r_s])
            ok &= inside
            parts.append((r_s[ok], t_s[ok], ang[ok], np.full(int(ok.sum()), LEFT if left else RIGHT,
                                                                dtype=np.int8),
                          np.full(int(ok.sum()), s, dtype=np.int8)))
    park = parking_angles(geom)
    for k, ang in fixed_rows.items():
        park[k] = ang
    parts.append((np.arange(n, dtype=np.int64), np.full(n, -1, dtype=np.int64), park,
                  np.full(n, PARKED, dtype=np.int8), np.full(n, -1, dtype=np.int8)))
    n_main = sum(p[0].size for p in parts)
    if parking == "clear":
        r_c, a_c = clear_parking_angles(geom)
        keep = ~still[r_c]
        r_c, a_c = r_c[keep], a_c[keep]
        parts.append((r_c, np.full(r_c.size, -1, dtype=np.int64), a_c,
                      np.full(r_c.size, PARKED, dtype=np.int8),
                      np.full(r_c.size, -1, dtype=np.int8)))
    robot = np.concatenate([p[0] for p in parts])
    target = np.concatenate([p[1] for p in parts])
    angles = np.concatenate([p[2] for p in parts]).reshape(-1, 2)
    arm = np.concatenate([p[3] for p in parts])
    slot = np.concatenate([p[4] for p in parts])
    seg = np.empty((robot.size, 4))
    _segments(geom.base_xy, robot, angles, geom.alpha_len, geom.seg_start, geom.seg_end, seg)
    clear = np.ones(robot.size, dtype=bool)
    if geom.fid_idx.size:
        _obstacle_clear(robot, seg, geom.fid_ptr, geom.fid_idx, geom.fid_xy, geom.fid_end_xy,
                        geom.fid_buffer, geom.buffer, float(margin_mm), clear)
    extra = np.arange(robot.size) >= n_main   # clear parking poses
    clear |= (arm == PARKED) & ~extra       # the fold is where every robot starts
    # the fold first within each robot, then the other parking poses, then targets in
    # catalogue order
    order = np.lexsort((target, extra, arm != PARKED, robot))
    order = order[clear[order]]
    robot, target, extra = robot[order], target[order], extra[order]
    weight = np.zeros(robot.size)
    weight[target >= 0] = catalogue.priority[target[target >= 0]]
    weight[extra] = -PARKING_PENALTY
    ptr = np.searchsorted(robot, np.arange(n + 1)).astype(np.int64)
    return Candidates(robot=robot, target=target, angles=angles[order], arm=arm[order],
                      slot=slot[order], weight=weight, seg=np.ascontiguousarray(seg[order]),
                      ptr=ptr)


def subset(cands: Candidates, keep: np.ndarray) -> tuple[Candidates, np.ndarray]:
    """The candidates where ``keep`` (c,) bool, still grouped by robot, and their indices
    in ``cands`` ((k,) int64). Every robot must keep at least one candidate."""
    sel = np.flatnonzero(keep)
    robot = cands.robot[sel]
    n = cands.ptr.size - 1
    ptr = np.searchsorted(robot, np.arange(n + 1)).astype(np.int64)
    return Candidates(robot=robot, target=cands.target[sel], angles=cands.angles[sel],
                      arm=cands.arm[sel], slot=cands.slot[sel], weight=cands.weight[sel],
                      seg=cands.seg[sel], ptr=ptr), sel
