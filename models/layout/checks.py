"""Field checks shared by the layout modules: ids, coordinates, lengths, base overlap.

Units: millimetres. Every failure raises :class:`rfp_twin.models.errors.LayoutError` with a
one-line message naming where (``where``: layout name or file:line), the field and the
allowed values.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.spatial import cKDTree

from rfp_twin.models.errors import LayoutError

#: Allowed values of the ``kind`` column.
KINDS = ("robot", "fiducial", "gfa")
#: Most positions a generated layout may have: planning takes ~0.9 GB per 30,000 robots
#: (benchmarks/RESULTS.md, raft:476), so 500,000 robots fill ~15 GB.
MAX_POSITIONS = 500_000


def check_size(n: float, where: str) -> None:
    """LayoutError when a generated layout would hold more than :data:`MAX_POSITIONS`."""
    if n > MAX_POSITIONS:
        raise LayoutError(f"{where}: {n:,.0f} positions; allowed: at most {MAX_POSITIONS:,} "
                          "(memory: planning takes ~0.9 GB per 30,000 robots)")


def readonly(a: np.ndarray) -> np.ndarray:
    """``a`` itself, made read-only."""
    a.setflags(write=False)
    return a


def as_ids(ids, where: str) -> np.ndarray:
    """``ids`` as a flat int64 array ``(n,)``; LayoutError if a value is not an integer."""
    arr = np.asarray(ids).reshape(-1)
    if arr.dtype.kind in "iu":
        return arr.astype(np.int64)
    try:
        as_float = arr.astype(np.float64)
    except (TypeError, ValueError):
        as_float = np.full(arr.shape, np.nan)
    bad = np.flatnonzero(~np.isfinite(as_float) | (as_float != np.round(as_float)))
    if len(bad):
        raise LayoutError(f"{where}: field 'id' = {arr[bad[0]].item()!r} is not an integer; "
                          f"allowed: unique integer ids")
    return as_float.astype(np.int64)


def as_xy(xy, where: str) -> np.ndarray:
    """``xy`` as an ``(n, 2)`` float64 array, mm; LayoutError on any other shape."""
    arr = np.array(xy, dtype=np.float64)
    if arr.size == 0:
        return arr.reshape(0, 2)
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise LayoutError(f"{where}: field 'xy' has shape {arr.shape}; allowed: (n, 2) mm")
    return arr


def check_positive(name: str, value, where: str) -> float:
    """``value`` as a float if it is finite and > 0 (a length in mm), else LayoutError."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = math.nan
    if not (math.isfinite(v) and v > 0):
        raise LayoutError(f"{where}: field '{name}' = {value!r}; allowed: a finite number > 0 mm")
    return v


def check_reach(reach_mm) -> float:
    """``reach_mm`` as a float if it is finite and >= 0, else LayoutError."""
    try:
        v = float(reach_mm)
    except (TypeError, ValueError):
        v = math.nan
    if not (math.isfinite(v) and v >= 0):
        raise LayoutError(f"field 'reach_mm' = {reach_mm!r}; allowed: a finite number >= 0 mm")
    return v


def closest_violation(xy: np.ndarray, min_separation_mm: float) -> tuple[int, int, float] | None:
    """The closest pair ``(i, j, distance)`` (``i < j`` rows of ``xy`` (n, 2), mm) of bases
    nearer than ``min_separation_mm``, or None (also when the minimum is <= 0)."""
    if min_separation_mm <= 0 or len(xy) < 2:
        return None
    pairs = cKDTree(xy).query_pairs(r=min_separation_mm, output_type="ndarray")
    if len(pairs) == 0:
        return None
    d = np.hypot(*(xy[pairs[:, 0]] - xy[pairs[:, 1]]).T)
    k = int(np.argmin(d))
    if d[k] >= min_separation_mm:
        return None
    i, j = sorted((int(pairs[k, 0]), int(pairs[k, 1])))
    return i, j, float(d[k])
