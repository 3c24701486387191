"""Centred hexagonal grids: position counts, axial lattice coordinates, base coordinates.

Units: millimetres. A centred hex grid with ``r`` rings has ``1 + 3 r (r + 1)``
positions (7, 19, 37, 61, 91, ...). Axial coordinates ``(q, r)`` are ``(n, 2)`` int64;
base coordinates ``(n, 2)`` float64 mm, rows along +x as on the SDSS-V focal plane.
The Sayres 2021 all-robot grid is the 13-ring one (547 positions, Sect. 3.2).
:class:`rfp_twin.models.layout.Layout` builds its generated grids from these.
"""
from __future__ import annotations

import math

import numpy as np

#: Rings of the Sayres 2021 all-robot grid (1 + 3*13*14 = 547 positions).
SDSS_V_RINGS = 13
_SQRT3_2 = math.sqrt(3.0) / 2.0


def hex_count(n_rings: int) -> int:
    """Positions of a centred hex grid with ``n_rings`` rings: ``1 + 3 r (r + 1)``."""
    return 1 + 3 * n_rings * (n_rings + 1)


def hex_rings(n_positions: int) -> int | None:
    """Rings of a centred hex grid with ``n_positions`` positions, or None if none fits."""
    if n_positions < 1:
        return None
    r = int(round((math.sqrt(12 * n_positions - 3) - 3) / 6))
    return r if hex_count(r) == n_positions else None


def nearest_hex_counts(n) -> list[int]:
    """The centred hex counts just below and above ``n`` (``[1]`` if ``n`` < 1)."""
    try:
        x = float(n)
    except (TypeError, ValueError):
        x = 1.0
    r = 0
    while hex_count(r + 1) <= x:
        r += 1
    return sorted({hex_count(r), hex_count(r + 1)}) if x >= 1 else [1]


def hex_axial(n_rings: int) -> np.ndarray:
    """Axial lattice coordinates ``(q, r)`` of a centred hex grid, ``(n, 2)`` int64.

    Sorted by row ``r`` then ``q`` (i.e. by y then x of :func:`hex_xy`).
    """
    qs, rs = np.meshgrid(np.arange(-n_rings, n_rings + 1), np.arange(-n_rings, n_rings + 1))
    q, r = qs.ravel(), rs.ravel()
    keep = np.abs(q + r) <= n_rings
    qr = np.stack([q[keep], r[keep]], axis=1).astype(np.int64)
    return qr[np.lexsort((qr[:, 0], qr[:, 1]))]


def hex_xy(qr: np.ndarray, pitch_mm: float) -> np.ndarray:
    """Base coordinates, mm, ``(n, 2)``, of axial coordinates ``(n, 2)``.

    Lattice vectors ``(pitch, 0)`` and ``(pitch/2, pitch*sqrt(3)/2)``: rows run along +x.
    """
    q, r = qr[:, 0].astype(np.float64), qr[:, 1].astype(np.float64)
    return np.stack([(q + 0.5 * r) * pitch_mm, r * _SQRT3_2 * pitch_mm], axis=1)
