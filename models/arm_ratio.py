"""The arm ratio alpha/beta as a design parameter: same reach, arms split differently.

Units: mm. A robot of reach ``R = alpha + beta`` with ratio ``q = alpha / beta`` has
``beta = R / (1 + q)`` and ``alpha = q R / (1 + q)``; its patrol annulus is
``|alpha - beta| .. R`` (a ratio of 1 reaches its own base, the design of the LBNL
raft robot, preset ``raft-6p2``).

The 2D collision segment follows the beta arm, whose head carries the fiber:

- a segment that ends on the fiber (``segment_end_mm == beta_length_mm``, as in
  ``raft-6p2``, ``pfs-cobra``, ``desi``, ``sdss-v``) ends on the new fiber;
- a numeric end elsewhere keeps its distance to the fiber (moved by the change of
  beta, never before ``segment_start_mm``);
- the SDSS-V production rule (``"sdss-production"``, a function of the buffer) becomes
  the number it gives at the spec's buffer, moved the same way.

The buffer, pitch and the rest of the spec are unchanged. The preset's ``[geometry]``
table (3D meshes) is not rescaled: it still describes the preset's own arms.
"""
from __future__ import annotations

import math
import numbers

from rfp_twin.models.errors import SpecError, field_error
from rfp_twin.models.robot import RobotSpec

#: Relative tolerance for "the segment ends on the fiber".
_ON_FIBER_RTOL = 1e-9


def arm_lengths(reach_mm: float, ratio: float) -> tuple[float, float]:
    """``(alpha, beta)`` mm with ``alpha + beta = reach_mm`` and ``alpha / beta = ratio``."""
    beta = reach_mm / (1.0 + ratio)
    return reach_mm - beta, beta


def check_ratio(ratio, where: str = "") -> float:
    """``ratio`` as a float if finite and > 0, else SpecError naming ``arm_ratio``."""
    ok = isinstance(ratio, numbers.Real) and not isinstance(ratio, bool)
    if ok:
        ok = math.isfinite(float(ratio)) and float(ratio) > 0
    if not ok:
        raise field_error(SpecError, "arm_ratio", ratio, "a finite number in (0, inf) "
                          "(alpha_length_mm / beta_length_mm)", where)
    return float(ratio)


def with_arm_ratio(spec: RobotSpec, ratio: float) -> RobotSpec:
    """A copy of ``spec`` with the same reach and ``alpha / beta = ratio``.

    Parameters
    ----------
    spec : RobotSpec
    ratio : float in (0, inf)
        alpha_length_mm / beta_length_mm of the copy.

    Returns
    -------
    RobotSpec
        Arms split at ``ratio`` (:func:`arm_lengths`), the collision segment end moved
        as the module docstring says; ``description`` notes the ratio. Validated again.

    Raises
    ------
    SpecError
        ``ratio`` not a finite number > 0 (field ``arm_ratio``), or a copy that fails the
        spec's own checks.
    """
    q = check_ratio(ratio, spec.source)
    alpha, beta = arm_lengths(spec.reach_mm, q)
    shift = beta - spec.beta_length_mm
    old_end = spec.segment_end()
    on_fiber = math.isclose(old_end, spec.beta_length_mm, rel_tol=_ON_FIBER_RTOL, abs_tol=1e-12)
    end = beta if on_fiber else max(old_end + shift, spec.segment_start_mm)
    note = f"with_arm_ratio {q:g}: alpha {alpha:.4g} + beta {beta:.4g} mm"
    description = f"{spec.description}; {note}" if spec.description else note
    return spec.with_overrides(alpha_length_mm=alpha, beta_length_mm=beta,
                               segment_end_mm=float(end), description=description)
