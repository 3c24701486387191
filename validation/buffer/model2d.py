"""The 2D model's distance of two robots and the buffer that forbids a configuration.

``D2(c; b)``: the distance of the two beta collision segments ``[segment_start,
spec.segment_end(b)]`` (Sayres et al. 2021, Eq. 3) of robot A (base at the origin) and
robot B (base at an offset) in configuration ``c = (alpha_A, beta_A, alpha_B, beta_B)``;
"safe in 2D at buffer b" is ``D2 > 2 b``. ``required(c)``, the smallest buffer whose 2D
model forbids ``c``, is ``D2(c) / 2`` for a fixed segment and is found by bisection when
the segment end depends on the buffer (``D2(c; b) - 2 b`` does not increase with ``b``
because ``|d segment_end / d b| <= 1``). Units: mm, deg (rad inside the kernel).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from rfp_twin.models.robot import RobotSpec
from rfp_twin.validation.numerics import beta_segment, segment_distance


@njit(cache=True)
def _d2_kernel(ang, ox, oy, la, s0, s1):
    """Beta-segment distances, (n,) mm; ``ang`` (n, 4) rad, ``ox``/``oy``/``s1`` (n,)."""
    n = ang.shape[0]
    out = np.empty(n)
    for k in range(n):
        p0x, p0y, p1x, p1y = beta_segment(0.0, 0.0, ang[k, 0], ang[k, 1], la, s0, s1[k])
        q0x, q0y, q1x, q1y = beta_segment(ox[k], oy[k], ang[k, 2], ang[k, 3], la, s0, s1[k])
        out[k] = segment_distance(p0x, p0y, p1x, p1y, q0x, q0y, q1x, q1y)
    return out


def _configurations(offsets, angles_deg) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(angles (n, 4) rad, offset x (n,), offset y (n,)), contiguous, offsets broadcast."""
    ang = np.ascontiguousarray(np.deg2rad(np.asarray(angles_deg, dtype=np.float64).reshape(-1, 4)))
    off = np.broadcast_to(np.asarray(offsets, dtype=np.float64).reshape(-1, 2), (len(ang), 2))
    return ang, np.ascontiguousarray(off[:, 0]), np.ascontiguousarray(off[:, 1])


def pair_segment_distances(spec: RobotSpec, offsets: np.ndarray, angles_deg: np.ndarray,
                           buffer_mm: float | None = None) -> np.ndarray:
    """2D model distance ``D2`` of robot A (base at the origin) and robot B (base at
    ``offsets``) per configuration.

    Parameters
    ----------
    spec : RobotSpec
        ``alpha_length_mm``, ``segment_start_mm``, ``segment_end(buffer)``.
    offsets : (n, 2) or (2,) float, mm
    angles_deg : (n, 4) float, deg: (alpha_A, beta_A, alpha_B, beta_B)
    buffer_mm : float, optional
        Selects the segment end when it depends on the buffer (default: the spec's).

    Returns
    -------
    (n,) float64, mm
    """
    ang, ox, oy = _configurations(offsets, angles_deg)
    s1 = np.full(len(ang), float(spec.segment_end(buffer_mm)))
    return _d2_kernel(ang, ox, oy, float(spec.alpha_length_mm), float(spec.segment_start_mm), s1)


_END_TABLES: dict = {}


def _segment_end_table(spec: RobotSpec, hi_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """``spec.segment_end(b)`` on 4097 buffers in [0, hi] (for a buffer-dependent
    segment end; interpolated linearly, error < 1e-6 mm for the SDSS-V production rule)."""
    key = (spec, float(hi_mm))
    if key not in _END_TABLES:
        grid = np.linspace(0.0, hi_mm, 4097)
        _END_TABLES[key] = (grid, np.array([spec.segment_end(float(b)) for b in grid]))
    return _END_TABLES[key]


def required_buffer(spec: RobotSpec, offsets, angles, hi_mm: float) -> np.ndarray:
    """Smallest buffer whose 2D model forbids each configuration (``D2(b) <= 2 b``), (n,) mm;
    ``hi_mm`` when even that buffer does not forbid it."""
    if not isinstance(spec.segment_end_mm, str):
        return np.minimum(pair_segment_distances(spec, offsets, angles) / 2.0, hi_mm)
    ang, ox, oy = _configurations(offsets, angles)
    n = len(ang)
    grid, ends = _segment_end_table(spec, hi_mm)
    lo, hi = np.zeros(n), np.full(n, float(hi_mm))
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        d = _d2_kernel(ang, ox, oy, float(spec.alpha_length_mm), float(spec.segment_start_mm),
                       np.interp(mid, grid, ends))
        forb = d <= 2.0 * mid
        hi = np.where(forb, mid, hi)
        lo = np.where(forb, lo, mid)
    return hi
