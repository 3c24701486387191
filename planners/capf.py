"""Cooperative artificial potential field (Macktoobian et al. 2019) on top of the APF.

Each robot's Cartesian push gets its cooperative neighbours' remaining errors
(Macktoobian Eq. 5)::

    F_i = -[ 2 lambda1 (q_i - q_iT) + 2 lambda3 sum_{j in N_i} (q_j - q_jT)
             + lambda2 sum_j grad_q_i rep(s_ij) ],        u_i = J_i^T F_i

Eq. 4 writes this as the gradient of a potential xi_i that contains
``lambda3 sum_j |q_j - q_jT|^2``, but that term does not depend on robot i's joints: its
true gradient with respect to robot i is zero. We therefore code Eq. 5 directly as a
vector field (not a gradient), as shared/references/README.md prescribes; the
repulsion has the same sign fix as :mod:`planners.apf` (the paper copies Makarem's
printed sign). A robot is thus pushed along the direction its neighbours still have to
go, ``q_jT - q_j``; near a deadlock this moves a robot that has arrived out of the way.

``N_i`` are the robots whose bases lie within ``coop_radius_mm`` (default 1.2 x the
median nearest base distance: the 6 hex neighbours of Macktoobian's Sect. 5.1), offline
robots excluded (they cannot reduce their error). Keeping ``lambda3 < lambda1 / 3``
guarantees that the cooperative term alone creates no spurious equilibrium on a hex
neighbour graph (README); the paper uses 0.03 (0.04 for its two largest cases), and we
accept any ``0 < lambda3 < lambda1`` (its Sect. 4.2 guideline).

The completeness equation of the paper (Eqs. 6-8) has sign and expansion errors and is
not used: completeness is checked by simulation (how many robots end within tolerance).

Everything else (collision models, saturation, singularities, guard, output) is the
APF's: see :mod:`planners.apf`. The kernel is shared (``lambda3 = 0`` is the APF).
"""
from __future__ import annotations

from dataclasses import dataclass

from models.array import ArrayGeometry
from models.errors import SpecError, field_error
from planners.apf import ApfResult, ApfSettings, plan_apf, plan_apf_reconfiguration
from planners.plan import Plan

#: Macktoobian 2019 Sect. 7 (0.04 for its two largest test cases).
DEFAULT_LAMBDA3 = 0.03


@dataclass(frozen=True)
class CapfSettings(ApfSettings):
    """:class:`planners.apf.ApfSettings` with the cooperative weight switched on.

    lambda3 : float, in (0, lambda1); default 0.03 (Macktoobian 2019).
    """

    lambda3: float = DEFAULT_LAMBDA3

    def __post_init__(self) -> None:
        super().__post_init__()
        if not self.lambda3 > 0.0:
            raise field_error(SpecError, "lambda3", self.lambda3,
                              f"(0, lambda1 = {self.lambda1}) (0 is the plain APF)", "CapfSettings")


def plan_capf(geom: ArrayGeometry, start, targets, settings: CapfSettings | None = None,
              movable=None, *, record: bool = True) -> ApfResult:
    """Plan ``start`` -> ``targets`` (deg, (n, 2)) with the cooperative field.

    Same contract as :func:`planners.apf.plan_apf`; the result's ``algorithm`` is "capf".
    """
    return plan_apf(geom, start, targets, settings or CapfSettings(), movable, record=record,
                    algorithm="capf")


def plan_capf_reconfiguration(geom: ArrayGeometry, targets, settings: CapfSettings | None = None,
                              *, start=None, offline=None) -> tuple[Plan, ApfResult]:
    """CLI-shaped entry, see :func:`planners.apf.plan_apf_reconfiguration`."""
    return plan_apf_reconfiguration(geom, targets, settings or CapfSettings(), start=start,
                                    offline=offline, algorithm="capf")
