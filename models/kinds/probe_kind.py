"""The MIRADAS probe arm as a :class:`~rfp_twin.models.kinds.base.RobotKind`, and its bench.

:class:`ProbeArmKind` wraps a :class:`~rfp_twin.models.kinds.probe_spec.ProbeArmSpec`
with the kernels of :mod:`rfp_twin.models.kinds.probe_kinematics`; the bench places arm
``k`` with its J1 at ``bench_radius_mm`` from the field centre, polar angle
``first_arm_deg + k 360 / n_arms`` (numbered counter-clockwise, Sabater 2018 Fig. 11),
its arm frame's x axis pointing at the field centre. World positions are mm with the
field centre at the origin.
"""
from __future__ import annotations

import numpy as np

from rfp_twin.models.errors import TargetError
from rfp_twin.models.kinds.base import MIRADAS_PROBE, RobotKind
from rfp_twin.models.kinds.probe_kinematics import (arm_capsules, d34_of, forbidden_poses,
                                                    forward_tip, inverse_tip)
from rfp_twin.models.kinds.probe_spec import ProbeArmSpec


class ProbeArmKind(RobotKind):
    """Closed-loop probe arm: joints (theta1, theta2) deg, five capsules."""

    name = MIRADAS_PROBE
    joint_names = ("theta1", "theta2")
    body_names = ("crank", "rocker", "cabinet", "tube", "head")

    def __init__(self, spec: ProbeArmSpec) -> None:
        self.spec = spec
        self.links = spec.links()
        self.sizes = spec.body_sizes()
        self.limits = np.ascontiguousarray(spec.limits_deg())

    # -- RobotKind -----------------------------------------------------------------
    def joint_limits_deg(self) -> np.ndarray:
        return self.limits.copy()

    def max_speed_deg_s(self) -> np.ndarray:
        return np.array(self.spec.max_speed_deg_s, dtype=np.float64)

    def forward(self, q_deg: np.ndarray) -> np.ndarray:
        return forward_tip(_rows(q_deg), self.links)

    def inverse(self, tip_xy: np.ndarray, ref_deg: np.ndarray | None = None) -> np.ndarray:
        """Allowed pose reached soonest from ``ref_deg`` (default: the park pose)."""
        ref = np.asarray(self.spec.park_deg if ref_deg is None else ref_deg, dtype=np.float64)
        return inverse_tip(_rows(tip_xy), self.links, self.limits, ref, self.max_speed_deg_s())

    def forbidden(self, q_deg: np.ndarray) -> np.ndarray:
        return forbidden_poses(_rows(q_deg), self.links, self.limits)

    def bodies(self, q_deg: np.ndarray) -> np.ndarray:
        return arm_capsules(_rows(q_deg), self.links, self.sizes)

    def d34(self, q_deg: np.ndarray) -> np.ndarray:
        """(m,) J3-J4 distance (Eq. 4), mm."""
        return d34_of(_rows(q_deg), self.links)

    # -- the bench -----------------------------------------------------------------
    @property
    def n_arms(self) -> int:
        return self.spec.n_arms

    def polar_deg(self) -> np.ndarray:
        """(n_arms,) polar angle of each arm's J1 about the field centre, deg."""
        return self.spec.polar_deg()

    def bases(self) -> np.ndarray:
        """(n_arms, 2) J1 of each arm, mm, field centre at the origin."""
        return self.spec.bases()

    def headings_rad(self) -> np.ndarray:
        """(n_arms,) direction of each arm frame's x axis (towards the centre), rad."""
        return self.spec.headings_rad()

    def frames(self) -> np.ndarray:
        """(n_arms, 4) float64: (x, y, cos, sin) of each arm frame in the world."""
        h = self.headings_rad()
        return np.ascontiguousarray(np.column_stack([self.bases(), np.cos(h), np.sin(h)]))

    def to_world(self, arm: int, xy: np.ndarray) -> np.ndarray:
        """Arm-frame points (..., 2) of arm ``arm`` in the world, mm."""
        x, y, c, s = self.frames()[arm]
        p = np.asarray(xy, dtype=np.float64)
        return np.stack([x + c * p[..., 0] - s * p[..., 1], y + s * p[..., 0] + c * p[..., 1]], -1)

    def to_arm(self, arm: int, xy: np.ndarray) -> np.ndarray:
        """World points (..., 2) in arm ``arm``'s frame, mm."""
        x, y, c, s = self.frames()[arm]
        p = np.asarray(xy, dtype=np.float64) - np.array([x, y])
        return np.stack([c * p[..., 0] + s * p[..., 1], -s * p[..., 0] + c * p[..., 1]], -1)

    def park(self) -> np.ndarray:
        """(n_arms, 2) every arm at the park pose, deg."""
        return np.tile(np.asarray(self.spec.park_deg, dtype=np.float64), (self.n_arms, 1))

    def tips_world(self, q_deg: np.ndarray) -> np.ndarray:
        """(n_arms, 2) tip of each arm at its row of ``q_deg`` (n_arms, 2), world mm."""
        tips = self.forward(q_deg)
        return np.array([self.to_world(k, tips[k]) for k in range(len(tips))])

    def poses_for_tips(self, tips_world: np.ndarray, ref_deg: np.ndarray | None = None) -> np.ndarray:
        """(n_arms, 2) deg putting each arm's tip on its row of ``tips_world`` (NaN rows
        leave that arm at ``ref_deg``, default park). Raises :class:`TargetError` naming
        the first arm whose target is out of its reach or only reachable in the ZoA."""
        ref = self.park() if ref_deg is None else np.asarray(ref_deg, dtype=np.float64)
        out = ref.copy()
        for k, xy in enumerate(np.asarray(tips_world, dtype=np.float64)):
            if not np.all(np.isfinite(xy)):
                continue
            q = self.inverse(self.to_arm(k, xy)[None, :], ref[k])[0]
            if not np.all(np.isfinite(q)):
                raise TargetError(f"arm {k}: target ({xy[0]:.2f}, {xy[1]:.2f}) mm has no pose; "
                                  f"allowed: a point of the arm's reach outside its ZoA "
                                  f"(d34 in ({self.spec.ds1_mm:g}, {self.spec.ds2_mm:g}) mm, "
                                  f"Eq. 4)")
            out[k] = q
        return out

    def check_poses(self, q_deg: np.ndarray, what: str = "target") -> None:
        """Raise :class:`TargetError` for the first arm whose pose is non-finite, out of
        the joint ranges or in the ZoA."""
        q = np.asarray(q_deg, dtype=np.float64)
        if q.shape != (self.n_arms, 2):
            raise TargetError(f"{what} poses of shape {q.shape}; allowed: ({self.n_arms}, 2) "
                              "(theta1, theta2) deg, one row per arm")
        bad = np.flatnonzero(self.forbidden(np.nan_to_num(q, nan=-1e9)))
        if bad.size:
            k = int(bad[0])
            t1, t2 = q[k]
            lim = self.limits
            if not (lim[0, 0] <= t1 <= lim[0, 1] and lim[1, 0] <= t2 <= lim[1, 1]):
                raise TargetError(f"arm {k}: {what} (theta1, theta2) = ({t1:g}, {t2:g}) deg; "
                                  f"allowed: theta1 in [{lim[0, 0]:g}, {lim[0, 1]:g}], theta2 in "
                                  f"[{lim[1, 0]:g}, {lim[1, 1]:g}] deg")
            d = float(self.d34(q[k:k + 1])[0])
            raise TargetError(f"arm {k}: {what} (theta1, theta2) = ({t1:g}, {t2:g}) deg is in the "
                              f"ZoA: d34 = {d:.2f} mm; allowed: ({self.spec.ds1_mm:g}, "
                              f"{self.spec.ds2_mm:g}) mm (Eq. 4)")


def _rows(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(np.atleast_2d(np.asarray(a, dtype=np.float64)))
