"""RobotSpec: what one alpha/beta fiber positioner is, loaded from TOML presets.

Units: millimetres, degrees, seconds. A preset is a TOML file with a ``[robot]`` table
(arm lengths, pitch, limits, speed, fold state) and a ``[collision]`` table (the 2D
capsule model of Sayres 2021 Eq. 3: the beta collision segment and its buffer). A file
may say ``extends = "other-preset"`` to start from another preset and override a few
fields. Built-in presets live in ``models/presets/``; any path to a ``.toml`` file works
too.

Every field is checked; a bad value raises :class:`rfp_twin.models.errors.SpecError` naming the
file, the field and the allowed range.
"""
from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

from rfp_twin.models.errors import KindError, SpecError
from rfp_twin.models.kinds.base import ALPHA_BETA
from rfp_twin.models.spec_fields import check_range, fields_from_tables, with_fields

# The SDSS-V production numbers below are those of SDSS-V's own software: the coordinate
# package coordio (defaults) and the production planner kaiju 1.4.1.
#: ``segment_end_mm`` value selecting the SDSS-V production rule (kaiju 1.4.1).
SDSS_PRODUCTION_SEGMENT = "sdss-production"
#: Beta axis to the flat tip of the SDSS-V beta arm, mm (coordio defaults).
SDSS_BETA_TIP_MM = 16.2
#: Half-width of the SDSS-V flat tip, mm (tip 0.6 mm wide, coordio defaults).
SDSS_TIP_HALF_WIDTH_MM = 0.3
#: Constant of the production segment rule (tip corner protection), mm (coordio/kaiju).
SDSS_TIP_OFFSET_MM = 0.55
#: ``RobotSpec.source`` of a built-in preset is this prefix + the preset name.
_PRESET_PREFIX = "preset "


def sdss_production_segment_end(buffer_mm: float) -> float:
    """End of the beta collision segment SDSS-V uses in production, mm.

    ``16.2 - (sqrt(cb^2 + 0.3^2) - 0.55)``; 14.73 mm at cb = 2.0 mm.
    """
    return SDSS_BETA_TIP_MM - (math.hypot(buffer_mm, SDSS_TIP_HALF_WIDTH_MM) - SDSS_TIP_OFFSET_MM)


@dataclass(frozen=True)
class RobotSpec:
    """One positioner model.

    Attributes
    ----------
    name, description : str
    alpha_length_mm, beta_length_mm : float
        Alpha axis to beta axis, and beta axis to fiber (Sayres 2021 Eqs. 1-2).
    pitch_mm : float
        Nominal base-to-base distance of the hex grid this robot is designed for.
    alpha_limits_deg, beta_limits_deg : (float, float)
        Planning travel range of each axis, degrees.
    max_speed_deg_s, max_accel_deg_s2 : (float, float)
        Per-axis (alpha, beta) limits.
    fold_deg : (float, float)
        The folded lattice configuration (alpha, beta).
    angular_error_deg : (float, float)
        Worst-case angular error of each axis, for buffer budgets.
    buffer_mm : float
        Collision buffer sigma_cb: capsule radius around the beta segment.
    segment_start_mm : float
        Start of the beta collision segment along the beta arm, from the beta axis.
    segment_end_mm : float or "sdss-production"
        End of that segment; the string selects :func:`sdss_production_segment_end`.
    fiducial_buffer_mm : float
        Radius of the keep-out disk around each fiducial.
    path_delay_s : float
        Time between the command and the start of the motion in the firmware, s (SDSS-V
        production: 1 s); part of a fold's real duration.
    source : str
        Where the spec came from (file path or preset name), for messages.
    """

    name: str
    alpha_length_mm: float
    beta_length_mm: float
    pitch_mm: float
    alpha_limits_deg: tuple[float, float]
    beta_limits_deg: tuple[float, float]
    max_speed_deg_s: tuple[float, float]
    max_accel_deg_s2: tuple[float, float]
    fold_deg: tuple[float, float]
    angular_error_deg: tuple[float, float]
    buffer_mm: float
    segment_start_mm: float
    segment_end_mm: float | str
    fiducial_buffer_mm: float
    description: str = ""
    path_delay_s: float = 0.0
    source: str = field(default="<memory>", compare=False)

    def __post_init__(self) -> None:
        _validate(self)

    # -- derived quantities -------------------------------------------------
    @property
    def reach_mm(self) -> float:
        """Largest base-to-fiber distance, mm."""
        return self.alpha_length_mm + self.beta_length_mm

    @property
    def patrol_annulus_mm(self) -> tuple[float, float]:
        """Inner and outer radius of the fiber patrol zone, mm."""
        return abs(self.alpha_length_mm - self.beta_length_mm), self.reach_mm

    def segment_end(self, buffer_mm: float | None = None) -> float:
        """End of the beta collision segment for a buffer, mm."""
        if self.segment_end_mm == SDSS_PRODUCTION_SEGMENT:
            return sdss_production_segment_end(self.buffer_mm if buffer_mm is None else buffer_mm)
        return float(self.segment_end_mm)

    def collision_reach_mm(self, buffer_mm: float | None = None) -> float:
        """Largest distance from the base to any point of the capsule, mm."""
        b = self.buffer_mm if buffer_mm is None else buffer_mm
        seg = max(self.segment_end(b), self.segment_start_mm)
        return self.alpha_length_mm + seg + b

    def neighbour_reach_mm(self, buffer_mm: float | None = None) -> float:
        """Base distance within which two robots can collide (Sayres 2021 Eq. 4), mm."""
        return 2.0 * self.collision_reach_mm(buffer_mm)

    def step_seconds(self, step_deg: float) -> float:
        """Duration of one planner step at the slower axis speed (Eq. 5), s."""
        return step_deg / min(self.max_speed_deg_s)

    def with_overrides(self, **changes: Any) -> RobotSpec:
        """A copy with some fields changed; the copy is validated again."""
        return with_fields(self, **changes)


# -- validation ------------------------------------------------------------------
def _check_pair(spec: RobotSpec, name: str, value, lo: float, hi: float,
                lo_open: bool = False, ordered: bool = False) -> None:
    if not isinstance(value, tuple) or len(value) != 2:
        raise SpecError(f"{spec.source}: field '{name}' = {value!r}; allowed: a pair [alpha, beta]")
    for axis, v in zip(("alpha", "beta"), value):
        check_range(spec, f"{name}[{axis}]", v, lo, hi, lo_open)
    if ordered and not value[0] < value[1]:
        raise SpecError(f"{spec.source}: field '{name}' = {list(value)}; allowed: [low, high] with low < high")


def _validate(s: RobotSpec) -> None:
    if not isinstance(s.name, str) or not s.name:
        raise SpecError(f"{s.source}: field 'name' = {s.name!r}; allowed: a non-empty string")
    check_range(s, "alpha_length_mm", s.alpha_length_mm, 0.0, 1000.0, lo_open=True)
    check_range(s, "beta_length_mm", s.beta_length_mm, 0.0, 1000.0, lo_open=True)
    check_range(s, "pitch_mm", s.pitch_mm, 0.0, 10000.0, lo_open=True)
    _check_pair(s, "alpha_limits_deg", s.alpha_limits_deg, -720.0, 720.0, ordered=True)
    _check_pair(s, "beta_limits_deg", s.beta_limits_deg, -720.0, 720.0, ordered=True)
    _check_pair(s, "max_speed_deg_s", s.max_speed_deg_s, 0.0, 1e5, lo_open=True)
    _check_pair(s, "max_accel_deg_s2", s.max_accel_deg_s2, 0.0, 1e7, lo_open=True)
    _check_pair(s, "angular_error_deg", s.angular_error_deg, 0.0, 90.0)
    _check_pair(s, "fold_deg", s.fold_deg, -720.0, 720.0)
    for axis, v, (lo, hi) in zip(("alpha", "beta"), s.fold_deg,
                                 (s.alpha_limits_deg, s.beta_limits_deg)):
        if not lo <= v <= hi:
            raise SpecError(f"{s.source}: field 'fold_deg[{axis}]' = {v}; allowed: [{lo}, {hi}] "
                            f"({axis}_limits_deg)")
    check_range(s, "buffer_mm", s.buffer_mm, 0.0, 100.0, lo_open=True)
    check_range(s, "fiducial_buffer_mm", s.fiducial_buffer_mm, 0.0, 100.0)
    check_range(s, "path_delay_s", s.path_delay_s, 0.0, 60.0)
    check_range(s, "segment_start_mm", s.segment_start_mm, 0.0, 1000.0)
    if isinstance(s.segment_end_mm, str):
        if s.segment_end_mm != SDSS_PRODUCTION_SEGMENT:
            raise SpecError(f"{s.source}: field 'segment_end_mm' = {s.segment_end_mm!r}; allowed: "
                            f"a length in mm or \"{SDSS_PRODUCTION_SEGMENT}\"")
    else:
        check_range(s, "segment_end_mm", s.segment_end_mm, 0.0, 1000.0)
    if s.segment_end() < s.segment_start_mm:
        raise SpecError(f"{s.source}: field 'segment_end_mm' = {s.segment_end():.3f}; allowed: "
                        f">= segment_start_mm ({s.segment_start_mm})")


# -- loading ---------------------------------------------------------------------
_ROBOT_FIELDS = {
    "name": "name", "description": "description",
    "alpha_length_mm": "alpha_length_mm", "beta_length_mm": "beta_length_mm",
    "pitch_mm": "pitch_mm", "alpha_limits_deg": "alpha_limits_deg",
    "beta_limits_deg": "beta_limits_deg", "max_speed_deg_s": "max_speed_deg_s",
    "max_accel_deg_s2": "max_accel_deg_s2", "fold_deg": "fold_deg",
    "angular_error_deg": "angular_error_deg", "path_delay_s": "path_delay_s",
}
_COLLISION_FIELDS = {
    "buffer_mm": "buffer_mm", "segment_start_mm": "segment_start_mm",
    "segment_end_mm": "segment_end_mm", "fiducial_buffer_mm": "fiducial_buffer_mm",
}
_OPTIONAL = {"description", "path_delay_s"}
#: Tables a preset may hold that other parts of rfp-twin read (e.g. 3D geometry).
_OTHER_TABLES = {"geometry", "actuators", "extends", "kind"}
#: The robot kind of a preset without a ``kind`` key (:mod:`rfp_twin.models.kinds`).
ALPHA_BETA_KIND = ALPHA_BETA


def list_presets(kind: str | None = ALPHA_BETA_KIND) -> list[str]:
    """Names of the built-in presets of one robot kind (the TOML's top-level ``kind``,
    ``"alpha-beta"`` when absent; :mod:`rfp_twin.models.kinds`), or of every kind (None)."""
    root = resources.files("rfp_twin.models") / "presets"
    names = sorted(p.name[:-5] for p in root.iterdir() if p.name.endswith(".toml"))
    if kind is None:
        return names
    return [n for n in names if preset_kind(n) == kind]


def preset_kind(name_or_path: str | Path) -> str:
    """The robot kind a preset or robot TOML describes (its top-level ``kind`` key,
    default ``"alpha-beta"``)."""
    kind = _read_toml(name_or_path)[0].get("kind", ALPHA_BETA_KIND)
    return kind if isinstance(kind, str) else repr(kind)


def _read_toml(name_or_path: str | Path, seen: tuple[str, ...] = ()) -> tuple[dict, str]:
    text, source = _toml_text(name_or_path)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SpecError(f"{source}: malformed TOML ({exc}); allowed: a TOML file with [robot] "
                        "and [collision] tables") from None
    base_name = data.get("extends")
    if base_name is not None:
        if not isinstance(base_name, str):
            raise SpecError(f"{source}: field 'extends' = {base_name!r}; allowed: a preset name or path")
        if _looks_like_path(base_name) and not Path(base_name).is_absolute() \
                and _looks_like_path(name_or_path):
            base_name = str(Path(name_or_path).parent / base_name)  # relative to this file
        if base_name in seen or str(name_or_path) == base_name:
            raise SpecError(f"{source}: field 'extends' forms a cycle through {base_name!r}; "
                            "allowed: a chain of presets that ends")
        base, _ = _read_toml(base_name, seen + (str(name_or_path),))
        data = _merge(base, {k: v for k, v in data.items() if k != "extends"})
    return data, source


def _looks_like_path(name_or_path: str | Path) -> bool:
    """A path (ends in .toml or names a file) rather than a built-in preset name."""
    path = Path(name_or_path)
    return path.suffix == ".toml" or path.is_file()


def _toml_text(name_or_path: str | Path) -> tuple[str, str]:
    path = Path(name_or_path)
    if _looks_like_path(path):
        if not path.is_file():
            raise SpecError(f"{path}: robot spec file not found; allowed: an existing .toml file "
                            f"or a preset ({', '.join(list_presets(None))})")
        return path.read_text(encoding="utf-8"), str(path)
    preset = resources.files("rfp_twin.models") / "presets" / f"{name_or_path}.toml"
    if not preset.is_file():
        raise SpecError(f"unknown preset {str(name_or_path)!r}; allowed: {', '.join(list_presets(None))} "
                        "or a path to a .toml file")
    return preset.read_text(encoding="utf-8"), f"{_PRESET_PREFIX}{name_or_path}"


def _merge(base: dict, over: dict) -> dict:
    out = dict(base)
    for key, value in over.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = _merge(out[key], value)
        else:
            out[key] = value
    return out


def spec_from_dict(data: dict, source: str = "<memory>") -> RobotSpec:
    """Build a RobotSpec from the parsed TOML tables, checking every field.

    A file of another robot kind (``kind = "miradas-probe"``) raises
    :class:`~rfp_twin.models.errors.KindError`: load it with
    :func:`rfp_twin.models.kinds.load_kind`."""
    kind = data.get("kind", ALPHA_BETA_KIND)
    if kind != ALPHA_BETA_KIND:
        raise KindError(f"{source}: field 'kind' = {kind!r}; allowed here: {ALPHA_BETA_KIND!r} "
                        f"(an alpha/beta positioner: {', '.join(list_presets())})")
    unknown = set(data) - {"robot", "collision"} - _OTHER_TABLES
    if unknown:
        raise SpecError(f"{source}: unknown table(s) {sorted(unknown)}; allowed: robot, collision, "
                        + ", ".join(sorted(_OTHER_TABLES)))
    kwargs = fields_from_tables(data, {"robot": _ROBOT_FIELDS, "collision": _COLLISION_FIELDS},
                                source, optional=_OPTIONAL,
                                missing_table="a preset with [robot] and [collision] tables",
                                missing_field=" (see models/presets/sdss-v.toml)")
    return RobotSpec(source=source, **kwargs)


def load_spec(name_or_path: str | Path = "sdss-v") -> RobotSpec:
    """Load a built-in preset by name (``sdss-v``, ``desi``, ...) or a TOML file by path."""
    data, source = _read_toml(name_or_path)
    return spec_from_dict(data, source)


def load_tables(name_or_path: str | Path = "sdss-v") -> dict:
    """The merged TOML tables of a preset, for modules that read extra tables."""
    return _read_toml(name_or_path)[0]


def load_tables_and_source(name_or_path: str | Path) -> tuple[dict, str]:
    """The merged TOML tables of a preset or robot TOML and its ``source`` text (for
    messages), for loaders of other robot kinds (:mod:`rfp_twin.models.kinds`)."""
    return _read_toml(name_or_path)


def spec_origin(spec: RobotSpec) -> str | None:
    """The preset name or ``.toml`` path a spec was loaded from (read off ``spec.source``),
    or None for a spec built in memory or whose file is gone. :func:`load_tables` of it
    gives the spec's other tables (``[geometry]``, ``[actuators]``)."""
    return source_origin(spec.source)


def source_origin(src: str) -> str | None:
    """The preset name or ``.toml`` path in a spec's ``source`` text (as ``summary.json``
    keeps it), or None."""
    if src.startswith(_PRESET_PREFIX):
        return src[len(_PRESET_PREFIX):]
    if src.endswith(".toml") and Path(src).is_file():
        return src
    return None
