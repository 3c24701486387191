"""Small arrays and helpers shared by the potential-field tests (tests/planners/fields/test_*.py)."""
from __future__ import annotations

import numpy as np

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.kinematics import forward, inverse
from rfp_twin.models.layout import Layout
from rfp_twin.models.robot import load_spec

DESI = load_spec("desi")
SDSS = load_spec("sdss-v")


def desi_geom(n_positions: int = 61) -> ArrayGeometry:
    return ArrayGeometry(DESI, Layout.hex_grid_positions(n_positions, DESI.pitch_mm), DESI.buffer_mm)


def custom_geom(spec, xy, kinds=None, buffer_mm=None) -> ArrayGeometry:
    n = len(xy)
    lay = Layout(np.arange(n), np.asarray(xy, dtype=float), kinds or ["robot"] * n, "test")
    return ArrayGeometry(spec, lay, spec.buffer_mm if buffer_mm is None else buffer_mm)


def angles_for(geom, i, rel_xy, right=True):
    """(alpha, beta) deg putting robot i's tip at base + rel_xy (mm)."""
    b = geom.base_xy[[i]]
    return inverse(b, b + np.asarray([rel_xy], dtype=float), geom.spec.alpha_length_mm,
                   geom.spec.beta_length_mm, right_arm=right)[0]


def tips(geom, angles):
    return forward(geom.base_xy, np.ascontiguousarray(angles, dtype=float),
                   geom.spec.alpha_length_mm, geom.spec.beta_length_mm)[0]
