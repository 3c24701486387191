"""Exceptions raised on bad input anywhere in rfp-twin.

Every message names the offending field or robot and, where it applies, the allowed
range, so the CLI can print it on one line and exit non-zero.
"""
from __future__ import annotations


class RfpError(Exception):
    """Base class of every error rfp-twin raises on purpose."""


class SpecError(RfpError):
    """A robot spec (TOML preset or user file) is missing a field or has a bad value."""


class LayoutError(RfpError):
    """A layout (grid or CSV) is malformed: duplicate ids, NaN, overlapping bases."""


class UnknownRobotError(RfpError):
    """A robot id that the layout does not contain."""


class TargetError(RfpError):
    """A target configuration is unreachable, out of range, NaN or colliding."""


class PlanningError(RfpError):
    """A planner could not produce a plan that satisfies its contract."""


class CatalogueError(RfpError):
    """A target catalogue (file or mock) is malformed: NaN positions, repeated ids, an
    unknown kind or fiber, a negative priority, a bad density or field centre."""


class AssignmentError(RfpError):
    """A fiber assignment cannot be made as asked (e.g. a sky/standard quota no
    assignment can meet, or no target within reach of any robot)."""


class TrajectoryError(RfpError):
    """A trajectory is malformed (unsorted times, NaN, unknown robot, bad JSON)."""


class KindError(RfpError):
    """A component (planner, checker, loader) was given a robot kind it does not support."""


def field_error(cls: type[RfpError], field: str, value, allowed: str, where: str = "") -> RfpError:
    """Build a uniform one-line error: ``<where>: field 'x' = v; allowed: ...``."""
    prefix = f"{where}: " if where else ""
    return cls(f"{prefix}field '{field}' = {value!r}; allowed: {allowed}")
