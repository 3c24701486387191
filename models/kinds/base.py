"""RobotKind: what every kind of robot tells the rest of rfp-twin about itself.

A kind is a robot's mechanism: its joints and their ranges, the forbidden zones of its
configuration space, its forward and inverse kinematics, the 2D bodies that may collide
and the speed of each joint. Alpha/beta fiber positioners are one kind
(:mod:`rfp_twin.models.kinds.alpha_beta`), the closed-loop MIRADAS probe arm another
(:mod:`rfp_twin.models.kinds.probe_kind`). Planners state which kinds they support
(:func:`require_kind`) and refuse the others with a one-line error.

Units: mm, degrees, seconds. Configurations are ``(m, d)`` arrays of joint angles in
degrees (``d`` joints); positions are in the robot's own frame (its first joint at the
origin) unless a method says otherwise. 2D collision bodies are capsules: rows
``(x0, y0, x1, y1, radius)`` in mm.
"""
from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np

from rfp_twin.models.errors import KindError

#: Name of the alpha/beta fiber positioner kind (SDSS-V, DESI, MOONS-like, ...).
ALPHA_BETA = "alpha-beta"
#: Name of the closed-loop MIRADAS probe arm kind (Sabater et al. 2018).
MIRADAS_PROBE = "miradas-probe"
#: Every kind rfp-twin knows.
KINDS = (ALPHA_BETA, MIRADAS_PROBE)


class RobotKind(ABC):
    """One kind of robot, as planners and checkers see it.

    Attributes
    ----------
    name : str, one of :data:`KINDS`
    joint_names : tuple of str, one per joint (``d`` of them)
    body_names : tuple of str, one per 2D collision capsule
    """

    name: str = ""
    joint_names: tuple[str, ...] = ()
    body_names: tuple[str, ...] = ()

    @property
    def n_joints(self) -> int:
        return len(self.joint_names)

    @abstractmethod
    def joint_limits_deg(self) -> np.ndarray:
        """(d, 2) float64: the planning range [low, high] of each joint, deg."""

    @abstractmethod
    def max_speed_deg_s(self) -> np.ndarray:
        """(d,) float64: the largest speed of each joint, deg/s."""

    @abstractmethod
    def forward(self, q_deg: np.ndarray) -> np.ndarray:
        """(m, 2) float64: the tip (fiber, pick-off mirror) of each configuration of
        ``q_deg`` (m, d), mm in the robot frame."""

    @abstractmethod
    def inverse(self, tip_xy: np.ndarray) -> np.ndarray:
        """(m, d) float64: a configuration putting the tip on each of ``tip_xy`` (m, 2)
        (robot frame, mm), deg; NaN rows where no allowed configuration does."""

    @abstractmethod
    def forbidden(self, q_deg: np.ndarray) -> np.ndarray:
        """(m,) bool: True where a configuration is outside the joint ranges or in a
        forbidden zone of the configuration space."""

    @abstractmethod
    def bodies(self, q_deg: np.ndarray) -> np.ndarray:
        """(m, len(body_names), 5) float64: the 2D collision capsules of each
        configuration, robot frame, mm (radius without any safety buffer)."""


def require_kind(kind: str, supported: tuple[str, ...], who: str) -> None:
    """Raise :class:`KindError` unless ``kind`` is one of ``supported``.

    ``who`` names the component in the one-line message (e.g. ``"planner 'greedy'"``).
    """
    if kind not in supported:
        raise KindError(f"{who} does not support robot kind {kind!r}; allowed: "
                        f"{', '.join(supported)}")
