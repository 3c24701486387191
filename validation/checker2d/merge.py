"""One report of a whole trajectory from a full check and later re-checks of some pairs.

A caller that changes some robots' motions and re-checks only the pairs of those robots
(``check_trajectory(..., focus_ids=...)``) holds, for the trajectory as it now is, the
re-check for those pairs and the earlier check for every other pair. When every other
pair's relative motion is unchanged (both robots untouched, at most shifted together in
time), its earlier result is its result now, and :func:`merge_reports` joins the two into
the report a full check of the new trajectory would give: the same pairs, each pair's
minimum from its latest check, the collisions of the latest check of each pair, and the
smallest clearance over them (within the checker's refinement tolerance, since a shift in
time moves the sample grid). That condition is the caller's to keep; this module only
joins reports.

Units: mm, s; robots and obstacles by id.
"""
from __future__ import annotations

import numpy as np

from rfp_twin.validation.checker2d.report import CheckReport

__all__ = ["merge_reports"]

#: Ids are packed two to an int64 key; both must be below this.
_ID_LIMIT = 1 << 31


def _keys(ids: np.ndarray, symmetric: bool) -> np.ndarray:
    """(p,) int64 keys of (p, 2) id pairs; ``symmetric``: (a, b) and (b, a) share a key."""
    ids = np.asarray(ids, dtype=np.int64).reshape(-1, 2)
    if ids.size and (ids.min() < 0 or ids.max() >= _ID_LIMIT):
        raise ValueError(f"merge_reports: ids must lie in [0, {_ID_LIMIT}); "
                         f"got [{ids.min()}, {ids.max()}]")
    a, b = ids[:, 0], ids[:, 1]
    if symmetric:
        a, b = np.minimum(a, b), np.maximum(a, b)
    return a * _ID_LIMIT + b


def _collision_key(c) -> int:
    if c.kind == "robot":
        return min(c.robot_a, c.other) * _ID_LIMIT + max(c.robot_a, c.other)
    return c.robot_a * _ID_LIMIT + c.other


def merge_reports(older: CheckReport, newer: CheckReport) -> CheckReport:
    """``older``'s pairs, with those ``newer`` re-checked replaced by ``newer``'s results.

    Both reports must be of one buffer and carry their per-pair thresholds
    (``pair_threshold_mm``, ``fiducial_threshold_mm``, filled by ``check_trajectory``).
    Pairs only in ``newer`` are added. ``n_samples`` and ``seconds`` add up;
    ``n_robots`` and ``duration_s`` are the larger of the two.

    Raises
    ------
    ValueError : different buffers, or a report without its thresholds
    """
    if older.buffer_mm != newer.buffer_mm:
        raise ValueError(f"merge_reports: buffers differ ({older.buffer_mm} and "
                         f"{newer.buffer_mm} mm)")
    for name, rep in (("older", older), ("newer", newer)):
        if (len(rep.pair_threshold_mm) != len(rep.pair_ids)
                or len(rep.fiducial_threshold_mm) != len(rep.fiducial_pair_ids)):
            raise ValueError(f"merge_reports: the {name} report has no per-pair thresholds")
    robot_old, robot_new = _keys(older.pair_ids, True), _keys(newer.pair_ids, True)
    fid_old, fid_new = _keys(older.fiducial_pair_ids, False), _keys(newer.fiducial_pair_ids, False)
    keep_r = ~np.isin(robot_old, robot_new)
    keep_f = ~np.isin(fid_old, fid_new)

    def joined(attr: str, keep: np.ndarray, empty_shape: tuple) -> np.ndarray:
        a = np.asarray(getattr(older, attr))
        b = np.asarray(getattr(newer, attr))
        parts = [p for p in (a[keep] if a.size else np.empty(empty_shape), b) if p.size]
        return np.concatenate(parts) if parts else np.empty(empty_shape)

    pair_ids = joined("pair_ids", keep_r, (0, 2)).astype(np.int64).reshape(-1, 2)
    pair_min = joined("pair_min_distance_mm", keep_r, (0,))
    pair_thr = joined("pair_threshold_mm", keep_r, (0,))
    fid_ids = joined("fiducial_pair_ids", keep_f, (0, 2)).astype(np.int64).reshape(-1, 2)
    fid_min = joined("fiducial_min_distance_mm", keep_f, (0,))
    fid_thr = joined("fiducial_threshold_mm", keep_f, (0,))

    rechecked_r, rechecked_f = set(robot_new.tolist()), set(fid_new.tolist())
    collisions = [c for c in older.collisions
                  if _collision_key(c) not in (rechecked_r if c.kind == "robot" else rechecked_f)]
    collisions += list(newer.collisions)
    collisions.sort(key=lambda c: (c.t_start, c.kind, c.robot_a, c.other))

    clear = [pair_min - pair_thr, fid_min - fid_thr]
    clear += [np.array([c.min_distance_mm - c.threshold_mm for c in collisions])]
    clear = [c for c in clear if c.size]
    clearance = float(min(c.min() for c in clear)) if clear else np.inf
    return CheckReport(
        buffer_mm=older.buffer_mm, n_robots=max(older.n_robots, newer.n_robots),
        n_pairs=len(pair_ids), n_fiducial_pairs=len(fid_ids),
        duration_s=max(older.duration_s, newer.duration_s),
        n_samples=int(older.n_samples) + int(newer.n_samples),
        pair_ids=pair_ids, pair_min_distance_mm=pair_min,
        fiducial_pair_ids=fid_ids, fiducial_min_distance_mm=fid_min,
        min_clearance_mm=clearance, collisions=collisions,
        seconds=float(older.seconds) + float(newer.seconds),
        pair_threshold_mm=pair_thr, fiducial_threshold_mm=fid_thr)
