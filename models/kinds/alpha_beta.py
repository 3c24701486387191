"""The alpha/beta fiber positioner as a :class:`~rfp_twin.models.kinds.base.RobotKind`.

A view of a :class:`~rfp_twin.models.robot.RobotSpec`: the kinematics of Sayres 2021
Eqs. 1-2 (:func:`rfp_twin.models.kinematics.forward`), the spec's alpha/beta ranges as
the only forbidden zone and the 2D capsule of Eq. 3 (the beta collision segment, radius
the collision buffer) as the one collision body. The planners of alpha/beta robots keep
their own arrays (:class:`rfp_twin.models.array.ArrayGeometry`); this view states the
kind and gives the few generic calls kind-agnostic code needs.
"""
from __future__ import annotations

import numpy as np

from rfp_twin.models.kinds.base import ALPHA_BETA, RobotKind
from rfp_twin.models.kinematics import forward
from rfp_twin.models.robot import RobotSpec


class AlphaBetaKind(RobotKind):
    """Alpha/beta positioner of one spec. Joints (alpha, beta), deg; one body: the beta
    collision capsule (Sayres 2021 Eq. 3) of radius ``spec.buffer_mm``."""

    name = ALPHA_BETA
    joint_names = ("alpha", "beta")
    body_names = ("beta",)

    def __init__(self, spec: RobotSpec) -> None:
        self.spec = spec

    def joint_limits_deg(self) -> np.ndarray:
        return np.array([self.spec.alpha_limits_deg, self.spec.beta_limits_deg], dtype=np.float64)

    def max_speed_deg_s(self) -> np.ndarray:
        return np.array(self.spec.max_speed_deg_s, dtype=np.float64)

    def forward(self, q_deg: np.ndarray) -> np.ndarray:
        q = np.ascontiguousarray(np.atleast_2d(q_deg), dtype=np.float64)
        fiber, _ = forward(np.zeros((len(q), 2)), q, self.spec.alpha_length_mm,
                           self.spec.beta_length_mm)
        return fiber

    def inverse(self, tip_xy: np.ndarray) -> np.ndarray:
        """Right-armed solutions (beta in [0, 180]), alpha in [0, 360); NaN if unreachable."""
        xy = np.atleast_2d(np.asarray(tip_xy, dtype=np.float64))
        la, lb = self.spec.alpha_length_mm, self.spec.beta_length_mm
        r2 = np.einsum("ij,ij->i", xy, xy)
        c = (r2 - la * la - lb * lb) / (2.0 * la * lb)
        ok = np.abs(c) <= 1.0 + 1e-12
        beta = np.arccos(np.clip(c, -1.0, 1.0))
        alpha = np.arctan2(xy[:, 1], xy[:, 0]) - np.arctan2(lb * np.sin(beta), la + lb * np.cos(beta))
        out = np.column_stack([np.degrees(alpha) % 360.0, np.degrees(beta) % 360.0])
        out[~ok] = np.nan
        return out

    def forbidden(self, q_deg: np.ndarray) -> np.ndarray:
        q = np.atleast_2d(np.asarray(q_deg, dtype=np.float64))
        lim = self.joint_limits_deg()
        return np.any((q < lim[:, 0]) | (q > lim[:, 1]) | ~np.isfinite(q), axis=1)

    def bodies(self, q_deg: np.ndarray) -> np.ndarray:
        q = np.atleast_2d(np.asarray(q_deg, dtype=np.float64))
        s = self.spec
        a = np.radians(q[:, 0])
        ab = np.radians(q[:, 0] + q[:, 1])
        ex, ey = s.alpha_length_mm * np.cos(a), s.alpha_length_mm * np.sin(a)
        out = np.empty((len(q), 1, 5))
        for col, dist in ((0, s.segment_start_mm), (2, s.segment_end())):
            out[:, 0, col] = ex + dist * np.cos(ab)
            out[:, 0, col + 1] = ey + dist * np.sin(ab)
        out[:, 0, 4] = s.buffer_mm
        return out
