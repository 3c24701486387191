"""A robot kind from a preset name or robot TOML.

A preset's top-level ``kind`` key says which kind it describes (``"alpha-beta"`` when
absent): :func:`load_kind` returns the matching :class:`~rfp_twin.models.kinds.base.RobotKind`.
"""
from __future__ import annotations

from pathlib import Path

from rfp_twin.models.errors import KindError
from rfp_twin.models.kinds.base import ALPHA_BETA, KINDS, MIRADAS_PROBE, RobotKind
from rfp_twin.models.robot import load_spec, preset_kind


def load_kind(name_or_path: str | Path) -> RobotKind:
    """The RobotKind a preset or robot TOML describes."""
    kind = preset_kind(name_or_path)
    if kind == ALPHA_BETA:
        from rfp_twin.models.kinds.alpha_beta import AlphaBetaKind

        return AlphaBetaKind(load_spec(name_or_path))
    if kind == MIRADAS_PROBE:
        from rfp_twin.models.kinds.probe_kind import ProbeArmKind
        from rfp_twin.models.kinds.probe_spec import load_probe_spec

        return ProbeArmKind(load_probe_spec(name_or_path))
    raise KindError(f"{name_or_path}: field 'kind' = {kind!r}; allowed: {', '.join(KINDS)}")
