"""What the 2D check reports: :class:`Collision` and :class:`CheckReport` (mm, s).

Plain dataclasses with JSON (``to_dict``, ``inf`` as ``None``) and terminal (``table``)
forms; :func:`rfp_twin.validation.checker2d.check_trajectory` fills them.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from rfp_twin.validation.numerics import PlainRecord, collision_table, json_float

#: Columns of the terminal table of collisions: (title, attribute, format).
_COLUMNS = (("kind", "kind", "<9"), ("robot", "robot_a", ">7"), ("other", "other", ">7"),
            ("t_start", "t_start", ">11.5f"), ("t_end", "t_end", ">11.5f"),
            ("t_min", "t_min", ">11.5f"), ("min mm", "min_distance_mm", ">9.4f"),
            ("thr mm", "threshold_mm", ">8.3f"))


@dataclass
class Collision(PlainRecord):
    """One contiguous time interval in which a pair is in collision.

    Attributes
    ----------
    kind : str
        ``"robot"`` (robot-robot) or ``"fiducial"`` (robot-obstacle: any non-robot row
        of the layout, a fiducial or a guide-camera edge).
    robot_a : int
        Robot id.
    other : int
        The other robot's id, or the obstacle's (fiducial's) id.
    t_start, t_end : float
        First and last colliding sample of the interval, s (for a conservative
        interval: its ends).
    t_min : float
        Time of the smallest distance found in the interval, s.
    min_distance_mm : float
        Smallest centre-line (segment) distance found in the interval, mm; for a
        conservative interval the lower bound ``max(lb, 0)``.
    threshold_mm : float
        ``buffer_i + buffer_j`` (or ``buffer_i +`` the obstacle's buffer), mm: each
        robot's own buffer (``buffer_mm`` plus its ``buffer_add_mm``).
    conservative : bool
        True when no sample collided but the bound could not clear an interval of
        length ``<= resolution_s`` (a grazing contact reported to be safe).
    """

    kind: str
    robot_a: int
    other: int
    t_start: float
    t_end: float
    t_min: float
    min_distance_mm: float
    threshold_mm: float
    conservative: bool = False


@dataclass
class CheckReport:
    """Result of :func:`rfp_twin.validation.checker2d.check_trajectory`.

    Attributes
    ----------
    buffer_mm : float
    n_robots : int
        Robots in the trajectory.
    n_pairs, n_fiducial_pairs : int
        Candidate robot-robot and robot-obstacle pairs checked.
    duration_s : float
        Length of the checked time span ``[T0, T1]``, s.
    n_samples : int
        Pair distances evaluated in all (coarse grid + refinement).
    pair_ids : (p, 2) int64
        Robot ids of the checked robot pairs.
    pair_min_distance_mm : (p,) float64
        Smallest sampled segment distance per robot pair, mm.
    fiducial_pair_ids : (q, 2) int64
        ``(robot id, obstacle id)``.
    fiducial_min_distance_mm : (q,) float64
    min_clearance_mm : float
        Smallest ``distance - threshold`` over all pairs (and conservative collision
        bounds); ``> 0`` means clear, ``inf`` when there is no pair.
    collisions : list of Collision
        Sorted by ``t_start``.
    seconds : float
        Wall time of the check (includes numba compilation on a first call), s.
    pair_threshold_mm : (p,) float64
        Each robot pair's collision threshold ``buffer_i + buffer_j``, mm.
    fiducial_threshold_mm : (q,) float64
        Each robot-obstacle pair's threshold, mm. Both are left out of ``to_dict``; they
        let :func:`rfp_twin.validation.checker2d.merge.merge_reports` recompute the
        clearance of a merged report.
    """

    buffer_mm: float
    n_robots: int
    n_pairs: int
    n_fiducial_pairs: int
    duration_s: float
    n_samples: int
    pair_ids: np.ndarray
    pair_min_distance_mm: np.ndarray
    fiducial_pair_ids: np.ndarray
    fiducial_min_distance_mm: np.ndarray
    min_clearance_mm: float
    collisions: list[Collision] = field(default_factory=list)
    seconds: float = 0.0
    pair_threshold_mm: np.ndarray = field(default_factory=lambda: np.empty(0), repr=False)
    fiducial_threshold_mm: np.ndarray = field(default_factory=lambda: np.empty(0), repr=False)

    @property
    def ok(self) -> bool:
        """True when no collision was found."""
        return not self.collisions

    def merged_with(self, newer: "CheckReport") -> "CheckReport":
        """This report with the pairs ``newer`` re-checked replaced by its results
        (:func:`rfp_twin.validation.checker2d.merge.merge_reports`)."""
        from rfp_twin.validation.checker2d.merge import merge_reports

        return merge_reports(self, newer)

    def to_dict(self) -> dict:
        """JSON-serialisable summary (``inf`` becomes ``None``)."""
        return {
            "ok": self.ok,
            "buffer_mm": float(self.buffer_mm),
            "n_robots": int(self.n_robots),
            "n_pairs": int(self.n_pairs),
            "n_fiducial_pairs": int(self.n_fiducial_pairs),
            "duration_s": float(self.duration_s),
            "n_samples": int(self.n_samples),
            "min_clearance_mm": json_float(self.min_clearance_mm),
            "n_collisions": len(self.collisions),
            "collisions": [c.to_dict() for c in self.collisions],
            "pair_ids": np.asarray(self.pair_ids, dtype=np.int64).tolist(),
            "pair_min_distance_mm": [json_float(v) for v in self.pair_min_distance_mm],
            "fiducial_pair_ids": np.asarray(self.fiducial_pair_ids, dtype=np.int64).tolist(),
            "fiducial_min_distance_mm": [json_float(v) for v in self.fiducial_min_distance_mm],
            "seconds": float(self.seconds),
        }

    def table(self) -> str:
        """A short plain-text table for the terminal."""
        clear = "-" if not math.isfinite(self.min_clearance_mm) else f"{self.min_clearance_mm:.4f}"
        return collision_table([
            f"2D dense check: {'OK' if self.ok else 'COLLISION'}  buffer {self.buffer_mm} mm, "
            f"{self.n_robots} robots, {self.n_pairs} robot pairs, {self.n_fiducial_pairs} "
            f"fiducial pairs, {self.duration_s:.3f} s, {self.n_samples} samples, "
            f"min clearance {clear} mm, {self.seconds:.3f} s",
        ], self.collisions, _COLUMNS)
