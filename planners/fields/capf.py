"""Cooperative artificial potential field (Macktoobian et al. 2019): its settings.

Each robot's Cartesian push gets its cooperative neighbours' remaining errors
(Macktoobian 2019, Eq. 5)::

    F_i = -[ 2 lambda1 (q_i - q_iT) + 2 lambda3 sum_{j in N_i} (q_j - q_jT)
             + lambda2 sum_j grad_q_i rep(s_ij) ],        u_i = J_i^T F_i

Eq. 4 writes this as the gradient of a potential xi_i that contains
``lambda3 sum_j |q_j - q_jT|^2``, but that term does not depend on robot i's joints: its
true gradient with respect to robot i is zero. The kernel therefore codes Eq. 5 directly
as a vector field (not a gradient); the repulsion has the same sign fix as the APF
(:mod:`rfp_twin.planners.fields.field`; the paper copies Makarem 2014's printed sign). A robot is
thus pushed along the direction its neighbours still have to go, ``q_jT - q_j``; near a
deadlock this moves a robot that has arrived out of the way.

``N_i`` are the robots whose bases lie within ``coop_radius_mm`` (default 1.2 x the
median nearest base distance: the 6 hex neighbours of Macktoobian 2019 Sect. 3,
Definition 5), offline robots excluded (they cannot reduce their error). Without
repulsion, an equilibrium solves ``(lambda1 I + lambda3 A) e = 0`` for the tip errors
``e`` (``A`` the adjacency of the neighbour graph); the eigenvalues of a hex graph's
adjacency (and, by interlacing, of any part of it) are >= -3, so ``lambda3 < lambda1 /
3`` leaves ``e = 0`` as the only one. The paper uses 0.03 (0.04 for its two largest
cases, Sect. 7), and we accept any ``0 < lambda3 < lambda1`` (its Sect. 4.2 guideline).

The completeness equation of the paper (Eqs. 6-8) has sign and expansion errors and is
not used: completeness is checked by simulation (how many robots end within tolerance).

Everything else (collision models, saturation, singularities, guard, output) is the
APF's, and so is the kernel (``lambda3 = 0`` is the APF): plan with
``rfp_twin.planners.fields.plan_apf(..., CapfSettings(), algorithm="capf")``.
"""
from __future__ import annotations

from dataclasses import dataclass

from rfp_twin.models.errors import SpecError, field_error
from rfp_twin.planners.fields.settings import ApfSettings

#: Macktoobian 2019 Sect. 7 (0.04 for its two largest test cases).
DEFAULT_LAMBDA3 = 0.03


@dataclass(frozen=True)
class CapfSettings(ApfSettings):
    """:class:`rfp_twin.planners.fields.ApfSettings` with the cooperative weight switched on.

    lambda3 : float, in (0, lambda1); default 0.03 (Macktoobian 2019).
    """

    lambda3: float = DEFAULT_LAMBDA3

    def __post_init__(self) -> None:
        super().__post_init__()
        if not self.lambda3 > 0.0:
            raise field_error(SpecError, "lambda3", self.lambda3,
                              f"(0, lambda1 = {self.lambda1}) (0 is the plain APF)", "CapfSettings")
