"""Robot kinds: what a robot is, for the planners and checkers that support it.

:class:`RobotKind` (kinematics, joint ranges and forbidden zones, 2D collision bodies,
speed limits); :data:`ALPHA_BETA` positioners (:class:`AlphaBetaKind`, a view of a
:class:`~rfp_twin.models.robot.RobotSpec`) and the :data:`MIRADAS_PROBE` closed-loop
arm (:class:`ProbeArmKind` of a :class:`ProbeArmSpec`, Sabater et al. 2018);
:func:`load_kind` from a preset, :func:`require_kind` for components that support only
some kinds. Names below other than those of :mod:`~rfp_twin.models.kinds.base` load
their module (numba kernels) on first use.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

from rfp_twin.models.kinds.base import (ALPHA_BETA, KINDS, MIRADAS_PROBE, RobotKind,
                                        require_kind)
from rfp_twin.models.lazy import lazy_exports

_LAZY = {
    "AlphaBetaKind": "rfp_twin.models.kinds.alpha_beta",
    "ProbeArmKind": "rfp_twin.models.kinds.probe_kind",
    "ProbeArmSpec": "rfp_twin.models.kinds.probe_spec",
    "probe_spec_from_dict": "rfp_twin.models.kinds.probe_spec",
    "load_kind": "rfp_twin.models.kinds.loading",
    "load_probe_spec": "rfp_twin.models.kinds.probe_spec",
    "probe_bench_layout": "rfp_twin.models.kinds.bench",
}

if TYPE_CHECKING:
    from rfp_twin.models.kinds.alpha_beta import AlphaBetaKind
    from rfp_twin.models.kinds.bench import probe_bench_layout
    from rfp_twin.models.kinds.loading import load_kind
    from rfp_twin.models.kinds.probe_kind import ProbeArmKind
    from rfp_twin.models.kinds.probe_spec import ProbeArmSpec, load_probe_spec, probe_spec_from_dict

__getattr__, __dir__ = lazy_exports(__name__, _LAZY)

__all__ = ["ALPHA_BETA", "KINDS", "MIRADAS_PROBE", "RobotKind", "require_kind", *_LAZY]
