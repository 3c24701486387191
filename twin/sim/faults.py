"""Faults: what one robot is commanded or measures differs from the plan.

* :class:`Stuck` — from ``time_s`` (s) the robot's motors hold where they were commanded
  to be at that time: its tracking error grows as the trajectory moves on.
* :class:`Slow` — the robot runs its trajectory ``factor`` times slower (time warp
  ``t / factor``): it lags, and the lag grows with time.
* :class:`EncoderOffset` — the encoder reads ``true + offset`` (deg); the servo drives
  the reading onto the trajectory, so the true angle is off by ``-offset`` all the time.

:func:`fault_effects` turns a list of faults into per-robot arrays (n robots, layout
order) that the simulator applies to the commanded angles.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Union

import numpy as np

from rfp_twin.models.errors import TrajectoryError
from rfp_twin.models.layout import Layout


@dataclass(frozen=True)
class RobotFault:
    """A fault of robot ``robot_id``; :meth:`describe` says what it does."""

    robot_id: int

    def describe(self) -> str:
        return f"robot {self.robot_id} {self._effect()}"

    def _effect(self) -> str:
        raise NotImplementedError


@dataclass(frozen=True)
class Stuck(RobotFault):
    """Robot ``robot_id`` stops at ``time_s`` (s) and holds that position."""

    time_s: float

    def _effect(self) -> str:
        return f"stuck from t = {self.time_s:g} s"


@dataclass(frozen=True)
class Slow(RobotFault):
    """Robot ``robot_id`` runs its trajectory ``factor`` (> 0) times slower."""

    factor: float

    def _effect(self) -> str:
        return f"slow by a factor {self.factor:g}"


@dataclass(frozen=True)
class EncoderOffset(RobotFault):
    """Robot ``robot_id``'s encoders read ``true + offset`` (deg) on each axis."""

    alpha_deg: float = 0.0
    beta_deg: float = 0.0

    def _effect(self) -> str:
        return f"encoder offset ({self.alpha_deg:g}, {self.beta_deg:g}) deg"


Fault = Union[Stuck, Slow, EncoderOffset]


@dataclass
class FaultEffects:
    """The faults of a grid as arrays over its n robots (layout order).

    warp_scale (n,) : trajectory time scale (1 / product of Slow factors; 1 = on time).
    stuck_at (n,) : time from which the robot holds, s (inf: never).
    offset (n, 2) : encoder offset (alpha, beta), deg (sum of EncoderOffsets).
    """

    warp_scale: np.ndarray
    stuck_at: np.ndarray
    offset: np.ndarray


def fault_effects(faults, layout: Layout) -> FaultEffects:
    """Check ``faults`` (Stuck / Slow / EncoderOffset of robots of ``layout``) and
    combine them per robot.

    Raises
    ------
    UnknownRobotError
        A fault names a robot that is not in the layout.
    TrajectoryError
        A Stuck time < 0 s or a Slow factor <= 0 (or not finite); an unknown fault type.
    """
    n = layout.n_robots
    out = FaultEffects(np.ones(n), np.full(n, np.inf), np.zeros((n, 2)))
    for f in faults:
        k = layout.robot_index(int(f.robot_id))
        if isinstance(f, Stuck):
            if not (math.isfinite(f.time_s) and f.time_s >= 0):
                raise TrajectoryError(f"robot {f.robot_id}: field 'time_s' = {f.time_s!r}; "
                                      "allowed: >= 0 s")
            out.stuck_at[k] = min(out.stuck_at[k], f.time_s)
        elif isinstance(f, Slow):
            if not (math.isfinite(f.factor) and f.factor > 0):
                raise TrajectoryError(f"robot {f.robot_id}: field 'factor' = {f.factor!r}; "
                                      "allowed: > 0 (2 = half speed)")
            out.warp_scale[k] /= f.factor
        elif isinstance(f, EncoderOffset):
            out.offset[k] += (f.alpha_deg, f.beta_deg)
        else:
            raise TrajectoryError(f"unknown fault {f!r}; allowed: Stuck, Slow, EncoderOffset")
    return out
