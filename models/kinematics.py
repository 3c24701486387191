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
from rfp_twin.models.kernel_cache import DELIVERY, warm_up

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
def _inverse_kernel(rel_xy, l_alphas, l_betas, right_arm, out):
    """Fills out (n, 2) with (alpha, beta) deg in [0, 360); NaN where unreachable.

    ``l_alphas``, ``l_betas`` (n,) mm: each robot's alpha arm and beta axis-to-fiber length.
    """
    for i in range(rel_xy.shape[0]):
        x = rel_xy[i, 0]
        y = rel_xy[i, 1]
        l_alpha = l_alphas[i]
        l_beta = l_betas[i]
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
    n = base_xy.shape[0]
    out = np.empty_like(base_xy)
    _inverse_kernel(np.ascontiguousarray(fiber_xy - base_xy), np.full(n, float(l_alpha)),
                    np.full(n, float(l_beta)), right_arm, out)
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
    np.clip(r, r_in + 1e-9, r_out - 1e-9, out=r)
    phi = rng.uniform(0.0, 2.0 * np.pi, size=n)
    # the arithmetic of inverse(zeros, xy, ...) without its (n, 2) temporaries (large draws:
    # 256 candidates a robot for 30,000 robots are 7.7M rows)
    xy = np.empty((n, 2))
    np.multiply(r, np.cos(phi), out=xy[:, 0])
    np.multiply(r, np.sin(phi), out=xy[:, 1])
    del r, phi
    out = np.empty((n, 2))
    _inverse_kernel(xy, np.broadcast_to(np.float64(l_alpha), (n,)),
                    np.broadcast_to(np.float64(l_beta), (n,)), right_arm, out)
    return out


def _at(error: TargetError, index: int) -> TargetError:
    """``error`` with ``error.index`` = the row (robot) it is about."""
    error.index = index
    return error


def fiber_polar(fiber_beta_xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A fiber's (x, y) in the beta-arm frame (n, 2) mm as (length mm, angle deg) (n,) each:
    its distance from the beta axis and its angle from the arm's axis."""
    f = np.asarray(fiber_beta_xy, dtype=np.float64).reshape(-1, 2)
    return np.hypot(f[:, 0], f[:, 1]), np.degrees(np.arctan2(f[:, 1], f[:, 0]))


def forward_fiber(base_xy: np.ndarray, angles: np.ndarray, l_alpha: np.ndarray,
                  fiber_beta_xy: np.ndarray) -> np.ndarray:
    """(n, 2) positions of one fiber per robot, mm: each robot's own alpha arm ``l_alpha``
    (n,) mm and fiber ``fiber_beta_xy`` (n, 2) mm in its beta-arm frame, at ``angles`` (n, 2)
    deg (model angles)."""
    length, phi = fiber_polar(fiber_beta_xy)
    a = np.radians(np.asarray(angles, dtype=np.float64)[:, 0])
    ab = a + np.radians(np.asarray(angles, dtype=np.float64)[:, 1] + phi)
    base = np.asarray(base_xy, dtype=np.float64)
    la = np.asarray(l_alpha, dtype=np.float64)
    return np.column_stack([base[:, 0] + la * np.cos(a) + length * np.cos(ab),
                            base[:, 1] + la * np.sin(a) + length * np.sin(ab)])


def inverse_fiber(base_xy: np.ndarray, target_xy: np.ndarray, l_alpha: np.ndarray,
                  fiber_beta_xy: np.ndarray, *, right_arm: bool = True,
                  ids: np.ndarray | None = None, fiber: str = "fiber") -> np.ndarray:
    """(alpha, beta) deg in [0, 360) (model angles) that put each robot's named fiber on
    ``target_xy``, with each robot's own geometry.

    Parameters
    ----------
    base_xy, target_xy : (n, 2) float64, mm
    l_alpha : (n,) float64 alpha arm lengths, mm
    fiber_beta_xy : (n, 2) float64 the fiber in each robot's beta-arm frame, mm (NaN: the
        robot does not carry this fiber)
    right_arm : the fiber's link (beta axis to fiber) turned by [0, 180] deg from the alpha arm
    ids, fiber : robot ids and the fiber's name, for messages

    Raises
    ------
    TargetError
        A robot without that fiber, a NaN target or one out of that robot's reach
        (naming the robot, the fiber and its own annulus).
    """
    base = np.asarray(base_xy, dtype=np.float64)
    tgt = np.asarray(target_xy, dtype=np.float64)
    n = base.shape[0]
    la = np.ascontiguousarray(np.broadcast_to(np.asarray(l_alpha, dtype=np.float64), (n,)))
    length, phi = fiber_polar(np.broadcast_to(fiber_beta_xy, (n, 2)))
    rid = (lambda k: int(ids[k]) if ids is not None else k)
    missing = np.flatnonzero(~np.isfinite(length))
    if missing.size:
        raise _at(TargetError(f"robot {rid(int(missing[0]))}: does not carry a {fiber} fiber; "
                              f"allowed: a fiber the robot carries ({missing.size} robot(s) in "
                              "all)"), int(missing[0]))
    if tgt.shape != base.shape:
        raise TargetError(f"{fiber} targets: shape {tgt.shape}; allowed: ({n}, 2) mm")
    out = np.empty_like(base)
    _inverse_kernel(np.ascontiguousarray(tgt - base), la, np.ascontiguousarray(length),
                    right_arm, out)
    bad = np.flatnonzero(~np.isfinite(out[:, 0]))
    if bad.size:
        k = int(bad[0])
        r = float(np.hypot(*(tgt[k] - base[k])))
        raise _at(TargetError(f"robot {rid(k)}: {fiber} fiber target at {r:.3f} mm from its base "
                              f"is out of its reach; allowed: [{abs(la[k] - length[k]):.3f}, "
                              f"{la[k] + length[k]:.3f}] mm ({bad.size} unreachable target(s) "
                              "in all)"), k)
    out[:, 1] = (out[:, 1] - phi) % 360.0
    out[out >= 360.0] = 0.0
    return out


# called from Python once the planner has run (loaded ahead from numba's cache)
warm_up(DELIVERY, forward)
