"""Alpha/beta positioner kinematics (Sayres 2021 Eqs. 1-2), numba.

Angles in degrees, lengths in mm. ``alpha`` is measured from +x, ``beta`` from the
alpha arm's direction, both counter-clockwise. Right-armed configurations have beta in
[0, 180]; left-armed ones in [180, 360).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from rfp_twin.models.errors import TargetError

DEG = math.pi / 180.0


@njit(cache=True)
def forward(base_xy, angles, l_alpha, l_beta):
    """Fiber and elbow positions.

    Parameters
    ----------
    base_xy : (n, 2) float64, mm
    angles : (n, 2) float64, (alpha, beta) deg
    l_alpha, l_beta : float, mm

    Returns
    -------
    fiber, elbow : (n, 2) float64, mm
    """
    n = base_xy.shape[0]
    fiber = np.empty((n, 2))
    elbow = np.empty((n, 2))
    for i in range(n):
        a = angles[i, 0] * DEG
        ab = (angles[i, 0] + angles[i, 1]) * DEG
        elbow[i, 0] = base_xy[i, 0] + l_alpha * math.cos(a)
        elbow[i, 1] = base_xy[i, 1] + l_alpha * math.sin(a)
        fiber[i, 0] = elbow[i, 0] + l_beta * math.cos(ab)
        fiber[i, 1] = elbow[i, 1] + l_beta * math.sin(ab)
    return fiber, elbow


@njit(cache=True)
def _inverse_kernel(rel_xy, l_alpha, l_beta, right_arm, out):
    """Fills out (n, 2) with (alpha, beta) deg in [0, 360); NaN where unreachable."""
    for i in range(rel_xy.shape[0]):
        x = rel_xy[i, 0]
        y = rel_xy[i, 1]
        r2 = x * x + y * y
        c = (r2 - l_alpha * l_alpha - l_beta * l_beta) / (2.0 * l_alpha * l_beta)
        if c > 1.0 + 1e-12 or c < -1.0 - 1e-12 or not math.isfinite(c):
            out[i, 0] = np.nan
            out[i, 1] = np.nan
            continue
        c = min(1.0, max(-1.0, c))
        beta = math.acos(c)
        if not right_arm:
            beta = -beta
        alpha = math.atan2(y, x) - math.atan2(l_beta * math.sin(beta), l_alpha + l_beta * math.cos(beta))
        a = (alpha / DEG) % 360.0
        b = (beta / DEG) % 360.0
        out[i, 0] = 0.0 if a >= 360.0 else a
        out[i, 1] = 0.0 if b >= 360.0 else b


def inverse(base_xy: np.ndarray, fiber_xy: np.ndarray, l_alpha: float, l_beta: float,
            right_arm: bool = True, ids: np.ndarray | None = None) -> np.ndarray:
    """(alpha, beta) deg in [0, 360) that put each fiber on ``fiber_xy``.

    Parameters
    ----------
    base_xy, fiber_xy : (n, 2) float64, mm
    right_arm : bool
        Right-armed solutions have beta in [0, 180], left-armed in [180, 360).
    ids : (n,) robot ids, only used in error messages.

    Raises
    ------
    TargetError
        For a NaN target or one outside the patrol annulus, naming the robot.
    """
    base_xy = np.asarray(base_xy, dtype=np.float64)
    fiber_xy = np.asarray(fiber_xy, dtype=np.float64)
    if base_xy.ndim != 2 or base_xy.shape[1] != 2 or fiber_xy.shape != base_xy.shape:
        raise TargetError(f"inverse kinematics: base shape {base_xy.shape} and target shape "
                          f"{fiber_xy.shape}; allowed: both (n, 2) in mm")
    out = np.empty_like(base_xy)
    _inverse_kernel(np.ascontiguousarray(fiber_xy - base_xy), l_alpha, l_beta, right_arm, out)
    bad = np.flatnonzero(~np.isfinite(out[:, 0]))
    if bad.size:
        k = int(bad[0])
        rid = int(ids[k]) if ids is not None else k
        r = float(np.hypot(*(fiber_xy[k] - base_xy[k])))
        raise TargetError(f"robot {rid}: target at {r:.3f} mm from its base is unreachable; "
                          f"allowed: [{abs(l_alpha - l_beta):.3f}, {l_alpha + l_beta:.3f}] mm "
                          f"({bad.size} unreachable target(s) in all)")
    return out


def sample_patrol_zone(rng: np.random.Generator, n: int, l_alpha: float, l_beta: float,
                       right_arm: bool = True) -> np.ndarray:
    """Random configurations with the fiber uniform (by area) in the patrol annulus.

    Returns (n, 2) float64 (alpha, beta) deg. This is how Sayres 2021 Sect. 4.1 draws
    source coordinates.
    """
    r_in = abs(l_alpha - l_beta)
    r_out = l_alpha + l_beta
    r = np.sqrt(rng.uniform(r_in * r_in, r_out * r_out, size=n))
    # keep off the singular rim where acos loses precision
    r = np.clip(r, r_in + 1e-9, r_out - 1e-9)
    phi = rng.uniform(0.0, 2.0 * np.pi, size=n)
    xy = np.column_stack([r * np.cos(phi), r * np.sin(phi)])
    return inverse(np.zeros_like(xy), xy, l_alpha, l_beta, right_arm)
