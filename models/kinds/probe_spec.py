"""ProbeArmSpec: the MIRADAS probe arm (Sabater et al. 2018, Sect. 3), from a TOML preset.

The arm is a closed-loop planar linkage (Sabater 2018 Fig. 5): J1 at the arm frame's
origin and J2 at ``(d12, 0)`` are fixed revolute joints driven by the two motors
(theta1, theta2); the crank J1-J3 (``d13``) and the rocker J2-J4 (``d24``) carry J3
(revolute) and J4, which slides and turns on the long tube that starts at J3 and ends
at the tip (pick-off mirror, ``d3tip`` from J3). J4 must stay between the stops s1
(collimator cabinet, ``ds1`` from J3) and s2 (end of the long tube, ``ds2``): the zone of
avoidance (ZoA) is every pose with ``d34`` outside ``(ds1, ds2)`` (Eq. 4).

The preset is a TOML file with ``kind = "miradas-probe"`` and the tables ``[robot]``
(linkage, joint ranges, park pose, speed), ``[collision]`` (2D capsules, safety buffer)
and ``[bench]`` (the circular bench). Units: mm, deg, s. Every field is checked; a bad
value raises :class:`~rfp_twin.models.errors.SpecError` naming the file, the field and
the allowed range, in one line.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from rfp_twin.models.errors import KindError, SpecError
from rfp_twin.models.spec_fields import check_range, fields_from_tables, with_fields

#: [robot] fields: name -> (low, high) of the allowed range (None: checked otherwise).
_ROBOT = {
    "d12_mm": (0.0, 10000.0), "d13_mm": (0.0, 10000.0), "d24_mm": (0.0, 10000.0),
    "d3tip_mm": (0.0, 10000.0), "ds1_mm": (0.0, 10000.0), "ds2_mm": (0.0, 10000.0),
}
_PAIRS = {"theta1_limits_deg": (-360.0, 360.0), "theta2_limits_deg": (-720.0, 720.0),
          "park_deg": (-720.0, 720.0), "max_speed_deg_s": (0.0, 1e4)}
_COLLISION = {
    "buffer_mm": (0.0, 100.0), "link_radius_mm": (0.0, 500.0), "cabinet_radius_mm": (0.0, 500.0),
    "tube_radius_mm": (0.0, 500.0), "tube_rear_mm": (0.0, 1000.0), "head_radius_mm": (0.0, 500.0),
    "head_length_mm": (0.0, 1000.0),
}
_BENCH = {"radius_mm": (0.0, 100000.0), "field_radius_mm": (0.0, 100000.0),
          "first_arm_deg": (-360.0, 360.0)}
#: [bench] keys stored under another attribute name.
_BENCH_ATTR = {"radius_mm": "bench_radius_mm"}
#: Poses sampled per joint to decide whether the ZoA leaves any feasible pose.
_ZOA_SAMPLES = 181


@dataclass(frozen=True)
class ProbeArmSpec:
    """One MIRADAS-like probe arm and its bench.

    Attributes
    ----------
    name, description : str
    d12_mm, d13_mm, d24_mm, d3tip_mm : float, link lengths of Sabater 2018 Fig. 5, mm
    ds1_mm, ds2_mm : float, J3 to the stops s1 (collimator cabinet) and s2 (end of the
        long tube): J4 must keep ``ds1 < d34 < ds2`` (Eq. 4), mm
    theta1_limits_deg, theta2_limits_deg : (float, float), planning range of each motor
    park_deg : (float, float), the park pose (theta1, theta2)
    max_speed_deg_s : (float, float), largest speed of each motor
    buffer_mm : float, safety area added around every body of each arm (Sect. 2.1)
    link_radius_mm : float, capsule radius of the crank J1-J3 and the rocker J2-J4
    cabinet_radius_mm : float, capsule radius of the collimator cabinet (tube from
        ``tube_rear_mm`` behind J3 to s1)
    tube_radius_mm : float, capsule radius of the long tube (J3 to the head)
    tube_rear_mm : float, length of tube and cabinet behind J3
    head_radius_mm, head_length_mm : float, the pick-off head: a capsule along the tube
        ending at the tip
    bench_radius_mm : float, distance of each arm's J1 from the field centre
    field_radius_mm : float, radius of the instrument field (Sect. 1: 250 mm across)
    first_arm_deg : float, polar angle of arm 0's J1 on the bench; arms are numbered
        counter-clockwise (Fig. 11)
    n_arms : int, arms on the bench
    source : str, the file or preset it came from, for messages
    """

    name: str
    d12_mm: float
    d13_mm: float
    d24_mm: float
    d3tip_mm: float
    ds1_mm: float
    ds2_mm: float
    theta1_limits_deg: tuple[float, float]
    theta2_limits_deg: tuple[float, float]
    park_deg: tuple[float, float]
    max_speed_deg_s: tuple[float, float]
    buffer_mm: float
    link_radius_mm: float
    cabinet_radius_mm: float
    tube_radius_mm: float
    tube_rear_mm: float
    head_radius_mm: float
    head_length_mm: float
    bench_radius_mm: float
    field_radius_mm: float
    first_arm_deg: float = 0.0
    n_arms: int = 12
    description: str = ""
    source: str = field(default="<memory>", compare=False)

    def __post_init__(self) -> None:
        _validate(self)

    @property
    def kind(self) -> str:
        from rfp_twin.models.kinds.base import MIRADAS_PROBE

        return MIRADAS_PROBE

    def links(self) -> np.ndarray:
        """(6,) float64: d12, d13, d24, d3tip, ds1, ds2 in mm (the kernels' argument)."""
        return np.array([self.d12_mm, self.d13_mm, self.d24_mm, self.d3tip_mm, self.ds1_mm,
                         self.ds2_mm])

    def body_sizes(self) -> np.ndarray:
        """(6,) float64: link, cabinet, tube, head radius, tube rear, head length, mm."""
        return np.array([self.link_radius_mm, self.cabinet_radius_mm, self.tube_radius_mm,
                         self.head_radius_mm, self.tube_rear_mm, self.head_length_mm])

    def limits_deg(self) -> np.ndarray:
        """(2, 2) float64: [low, high] of theta1 and theta2, deg."""
        return np.array([self.theta1_limits_deg, self.theta2_limits_deg], dtype=np.float64)

    def polar_deg(self) -> np.ndarray:
        """(n_arms,) polar angle of each arm's J1 about the field centre, deg (arms
        numbered counter-clockwise, Sabater 2018 Fig. 11)."""
        return self.first_arm_deg + 360.0 / self.n_arms * np.arange(self.n_arms)

    def bases(self) -> np.ndarray:
        """(n_arms, 2) J1 of each arm, mm, field centre at the origin."""
        phi = np.radians(self.polar_deg())
        return self.bench_radius_mm * np.column_stack([np.cos(phi), np.sin(phi)])

    def headings_rad(self) -> np.ndarray:
        """(n_arms,) direction of each arm frame's x axis (towards the centre), rad."""
        return np.radians(self.polar_deg()) + np.pi

    def d34_range_mm(self) -> tuple[float, float]:
        """Smallest and largest J3-J4 distance over every motor angle, mm (Eq. 4)."""
        return (max(0.0, self.d12_mm - self.d13_mm - self.d24_mm),
                self.d12_mm + self.d13_mm + self.d24_mm)

    def with_overrides(self, **changes: Any) -> "ProbeArmSpec":
        """A copy with some fields changed, validated again."""
        return with_fields(self, **changes)


def d34_mm(spec: ProbeArmSpec, theta1_rad: np.ndarray, theta2_rad: np.ndarray) -> np.ndarray:
    """Sabater 2018 Eq. 4: the J3-J4 distance, mm, for motor angles in radians."""
    dx = spec.d12_mm - spec.d24_mm * np.cos(theta2_rad) - spec.d13_mm * np.cos(theta1_rad)
    dy = spec.d24_mm * np.sin(theta2_rad) - spec.d13_mm * np.sin(theta1_rad)
    return np.hypot(dx, dy)


# -- validation ------------------------------------------------------------------
def _fail(spec: ProbeArmSpec, name: str, value, allowed: str) -> SpecError:
    return SpecError(f"{spec.source}: field '{name}' = {value!r}; allowed: {allowed}")


def _validate(s: ProbeArmSpec) -> None:
    if not isinstance(s.name, str) or not s.name:
        raise _fail(s, "name", s.name, "a non-empty string")
    for name, (lo, hi) in _ROBOT.items():
        check_range(s, name, getattr(s, name), lo, hi, lo_open=True)
    for name, (lo, hi) in _PAIRS.items():
        v = getattr(s, name)
        if not isinstance(v, tuple) or len(v) != 2:
            raise _fail(s, name, v, "a pair [theta1, theta2]" if "limits" not in name
                        else "a pair [low, high]")
        for k, x in enumerate(v):
            check_range(s, f"{name}[{k}]", x, lo, hi, lo_open=name == "max_speed_deg_s")
    for name in ("theta1_limits_deg", "theta2_limits_deg"):
        lo, hi = getattr(s, name)
        if not lo < hi:
            raise _fail(s, name, list(getattr(s, name)), "[low, high] with low < high")
    for name, (lo, hi) in _COLLISION.items():
        check_range(s, name, getattr(s, name), lo, hi, lo_open=name.endswith("radius_mm"))
    for key, (lo, hi) in _BENCH.items():
        name = _BENCH_ATTR.get(key, key)
        check_range(s, name, getattr(s, name), lo, hi, lo_open=key != "first_arm_deg")
    if not isinstance(s.n_arms, int) or isinstance(s.n_arms, bool) or not 1 <= s.n_arms <= 64:
        raise _fail(s, "n_arms", s.n_arms, "an integer in [1, 64]")
    _validate_linkage(s)


def _validate_linkage(s: ProbeArmSpec) -> None:
    """The loop must close (Eqs. 1-4), the ZoA leave feasible poses, park be outside it."""
    if s.d12_mm <= s.d13_mm + s.d24_mm:
        raise _fail(s, "d12_mm", s.d12_mm, f"> d13_mm + d24_mm = {s.d13_mm + s.d24_mm:g} "
                    "(Eqs. 1-3: J4 stays ahead of J3 on the long tube)")
    if not s.ds1_mm < s.ds2_mm:
        raise _fail(s, "ds2_mm", s.ds2_mm, f"> ds1_mm = {s.ds1_mm:g} (s2 beyond s1 on the tube)")
    if not s.ds2_mm < s.d3tip_mm:
        raise _fail(s, "d3tip_mm", s.d3tip_mm, f"> ds2_mm = {s.ds2_mm:g} (the tip beyond the "
                    "end stop s2 of the long tube)")
    lo, hi = s.d34_range_mm()
    if s.ds1_mm >= hi or s.ds2_mm <= lo:
        raise _fail(s, "ds1_mm, ds2_mm", (s.ds1_mm, s.ds2_mm), f"an interval meeting "
                    f"[{lo:g}, {hi:g}] mm, the J3-J4 distances the links can close the loop at")
    t1 = np.radians(np.linspace(*s.theta1_limits_deg, _ZOA_SAMPLES))
    t2 = np.radians(np.linspace(*s.theta2_limits_deg, _ZOA_SAMPLES))
    d = d34_mm(s, t1[:, None], t2[None, :])
    if not np.any((d > s.ds1_mm) & (d < s.ds2_mm)):
        raise _fail(s, "ds1_mm, ds2_mm", (s.ds1_mm, s.ds2_mm), "a ZoA leaving feasible poses "
                    f"in the joint ranges (d34 there spans [{d.min():.1f}, {d.max():.1f}] mm)")
    for k, name in enumerate(("theta1_limits_deg", "theta2_limits_deg")):
        lim = getattr(s, name)
        if not lim[0] <= s.park_deg[k] <= lim[1]:
            raise _fail(s, f"park_deg[{k}]", s.park_deg[k], f"[{lim[0]:g}, {lim[1]:g}] ({name})")
    dp = float(d34_mm(s, math.radians(s.park_deg[0]), math.radians(s.park_deg[1])))
    if not s.ds1_mm < dp < s.ds2_mm:
        raise _fail(s, "park_deg", list(s.park_deg), f"a pose outside the ZoA: d34 = {dp:.2f} mm "
                    f"there, allowed ({s.ds1_mm:g}, {s.ds2_mm:g}) mm (Eq. 4)")


# -- loading ---------------------------------------------------------------------
_TABLES = {"robot": {k: k for k in ("name", "description", *_ROBOT, *_PAIRS)},
           "collision": {k: k for k in _COLLISION},
           "bench": {k: _BENCH_ATTR.get(k, k) for k in (*_BENCH, "n_arms")}}
_OPTIONAL = {"description", "first_arm_deg", "n_arms"}


def load_probe_spec(name_or_path: str | Path = "miradas-probe") -> "ProbeArmSpec":
    """The ProbeArmSpec of a probe-arm preset or TOML file; a file of another kind raises
    :class:`~rfp_twin.models.errors.KindError`."""
    from rfp_twin.models.kinds.base import ALPHA_BETA, MIRADAS_PROBE
    from rfp_twin.models.robot import load_tables_and_source

    data, source = load_tables_and_source(name_or_path)
    kind = data.get("kind", ALPHA_BETA)
    if kind != MIRADAS_PROBE:
        raise KindError(f"{source}: field 'kind' = {kind!r}; allowed here: {MIRADAS_PROBE!r}")
    return probe_spec_from_dict(data, source)


def probe_spec_from_dict(data: dict, source: str = "<memory>") -> ProbeArmSpec:
    """A ProbeArmSpec from the parsed TOML tables (``kind`` key included), every field checked."""
    unknown = set(data) - set(_TABLES) - {"kind", "extends"}
    if unknown:
        raise SpecError(f"{source}: unknown table(s) {sorted(unknown)}; allowed: "
                        + ", ".join(_TABLES))
    kwargs = fields_from_tables(
        data, _TABLES, source, optional=_OPTIONAL, integers={"n_arms"},
        missing_table="a probe-arm preset with [robot], [collision] and [bench] (see "
                      "models/presets/miradas-probe.toml)")
    return ProbeArmSpec(source=source, **kwargs)
