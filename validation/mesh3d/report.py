"""What the 3D check reports (mm, s).

:class:`Check3DReport` (with ``ok``, ``to_dict`` for JSON, where non-finite numbers
become ``None``, and ``table`` for the terminal) holds one :class:`PairDistance` per
candidate pair and one :class:`Collision3D` per contact interval of two links;
:func:`rfp_twin.validation.mesh3d.validate_trajectory` fills it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from rfp_twin.validation.numerics import PlainRecord, collision_table, json_float

#: Columns of the terminal table of collisions: (title, attribute, format).
_COLUMNS = (("kind", "kind", "<9"), ("robot", "robot_a", ">7"), ("link", "link_a", ">7"),
            ("other", "other", ">7"), ("link", "link_b", ">9"), ("t_start", "t_start", ">11.5f"),
            ("t_end", "t_end", ">11.5f"), ("t_min", "t_min", ">11.5f"),
            ("min mm", "min_distance_mm", ">9.4f"))


@dataclass
class Collision3D(PlainRecord):
    """One contiguous time interval in which two links are within ``min_gap_mm``.

    Link ``link_a`` of robot ``robot_a`` and ``link_b`` of ``other`` (a robot, or an
    obstacle when ``kind == "fiducial"``: a fiducial post, ``link_b`` ``"fiducial"``, or a
    guide-camera wall, ``link_b`` ``"gfa"``; ``"robot"`` otherwise), from ``t_start`` to
    ``t_end`` (s: the first and last colliding sample, or the ends of a conservative
    interval).

    ``min_distance_mm`` is the smallest 3D distance found (0: touching or
    overlapping), at ``t_min`` (s). ``conservative`` marks an interval of length
    ``<= resolution_s`` that no sample found colliding but the bound could not clear
    (a grazing contact reported to be safe); its distance is the bound ``max(lb, 0)``.
    """

    kind: str
    robot_a: int
    link_a: str
    other: int
    link_b: str
    t_start: float
    t_end: float
    t_min: float
    min_distance_mm: float
    conservative: bool = False


@dataclass
class PairDistance:
    """Smallest 3D distance of one pair over the motion (one row of the report).

    ``kind`` ``"robot"`` / ``"fiducial"``; ``ids`` (robot id, other id); ``links`` the
    two links where it was found; ``min_distance_mm`` (mm) at ``t_min`` (s).
    """

    kind: str
    ids: tuple[int, int]
    links: tuple[str, str]
    min_distance_mm: float
    t_min: float

    def to_dict(self) -> dict:
        return {"kind": self.kind, "ids": [int(self.ids[0]), int(self.ids[1])],
                "links": list(self.links),
                "min_distance_mm": json_float(self.min_distance_mm),
                "t_min": json_float(self.t_min)}


@dataclass
class Check3DReport:
    """Result of :func:`rfp_twin.validation.mesh3d.validate_trajectory`.

    Attributes
    ----------
    min_gap_mm : float
        Distance at or below which two links count as colliding, mm.
    geometry : str
        Where the meshes came from (preset / TOML file, or "procedural").
    n_robots, n_fiducials : int
        Robots in the trajectory; fiducials of the layout.
    n_pairs, n_link_pairs : int
        Candidate pairs (robot-robot + robot-fiducial) and link pairs checked.
    duration_s : float
        Length of the checked span ``[T0, T1]``, s.
    pairs : list of PairDistance
        Per pair, its smallest 3D distance (sorted by distance).
    min_distance_mm : float
        Smallest 3D distance over all pairs, mm (``inf`` with no pair).
    link_kind_min_mm : dict
        Per link-kind pair (e.g. ``"beta-beta"``), the smallest exact distance
        evaluated, mm. A kind whose link pairs were never the closest of their robot
        pair may be evaluated little or not at all (``inf``); see the lower bound.
    link_kind_lower_bound_mm : dict
        Per link-kind pair, the smallest capsule bound over the motion (a lower
        bound of its true smallest distance, within the tolerance), mm.
    collisions : list of Collision3D
        Sorted by ``t_start``.
    n_capsule_evals, n_exact_evals, n_fcl_calls, n_gjk_calls : int
        Capsule-bound evaluations (link pair x time), link-pair distances, FCL distance
        calls (piece pairs) made, and how many of those were GJK calls on the pieces as
        convex solids (upper bounds; the rest are exact BVH distances).
    seconds_broadphase, seconds_exact, seconds : float
        Wall time of candidate selection + capsule bounds, of FCL work, and in all
        (includes numba compilation / cache loading on a first call), s.
    """

    min_gap_mm: float
    geometry: str
    n_robots: int
    n_fiducials: int
    n_pairs: int
    n_link_pairs: int
    duration_s: float
    pairs: list[PairDistance]
    min_distance_mm: float
    link_kind_min_mm: dict
    link_kind_lower_bound_mm: dict = field(default_factory=dict)
    collisions: list[Collision3D] = field(default_factory=list)
    n_capsule_evals: int = 0
    n_exact_evals: int = 0
    n_fcl_calls: int = 0
    n_gjk_calls: int = 0
    seconds_broadphase: float = 0.0
    seconds_exact: float = 0.0
    seconds: float = 0.0
    settings: dict = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        """True when no 3D collision was found."""
        return not self.collisions

    @property
    def min_clearance_mm(self) -> float:
        """``min_distance_mm - min_gap_mm`` (``> 0`` means clear)."""
        return self.min_distance_mm - self.min_gap_mm

    def to_dict(self) -> dict:
        """JSON-serialisable form (``inf`` becomes ``None``)."""
        return {
            "ok": self.ok,
            "min_gap_mm": float(self.min_gap_mm),
            "geometry": self.geometry,
            "n_robots": int(self.n_robots),
            "n_fiducials": int(self.n_fiducials),
            "n_pairs": int(self.n_pairs),
            "n_link_pairs": int(self.n_link_pairs),
            "duration_s": float(self.duration_s),
            "min_distance_mm": json_float(self.min_distance_mm),
            "min_clearance_mm": json_float(self.min_clearance_mm),
            "link_kind_min_mm": {k: json_float(v) for k, v in self.link_kind_min_mm.items()},
            "link_kind_lower_bound_mm": {k: json_float(v) for k, v in
                                         self.link_kind_lower_bound_mm.items()},
            "n_collisions": len(self.collisions),
            "collisions": [c.to_dict() for c in self.collisions],
            "n_capsule_evals": int(self.n_capsule_evals),
            "n_exact_evals": int(self.n_exact_evals),
            "n_fcl_calls": int(self.n_fcl_calls),
            "n_gjk_calls": int(self.n_gjk_calls),
            "seconds_broadphase": float(self.seconds_broadphase),
            "seconds_exact": float(self.seconds_exact),
            "seconds": float(self.seconds),
            "settings": dict(self.settings),
            "pairs": [p.to_dict() for p in self.pairs],
        }

    def table(self) -> str:
        """A short plain-text summary for the terminal."""
        md = "-" if not math.isfinite(self.min_distance_mm) else f"{self.min_distance_mm:.4f}"
        kinds = ", ".join(f"{k} {v:.3f}" for k, v in sorted(self.link_kind_min_mm.items())
                          if math.isfinite(v))
        return collision_table([
            f"3D check (FCL): {'OK' if self.ok else 'COLLISION'}  {self.n_robots} robots, "
            f"{self.n_fiducials} fiducials, {self.n_pairs} pairs ({self.n_link_pairs} link "
            f"pairs), {self.duration_s:.3f} s, min distance {md} mm (gap {self.min_gap_mm} mm)",
            f"  per link pair (mm): {kinds or '-'}",
            f"  {self.n_capsule_evals} capsule bounds, {self.n_exact_evals} distances "
            f"({self.n_fcl_calls} FCL calls, {self.n_gjk_calls} of them GJK); broadphase "
            f"{self.seconds_broadphase:.3f} s, exact {self.seconds_exact:.3f} s, total "
            f"{self.seconds:.3f} s",
        ], self.collisions, _COLUMNS)
