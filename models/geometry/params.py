"""The ``[geometry]`` table of a preset, parsed and checked into :class:`GeometryParams`.

Keys are flat lengths in mm (see :mod:`rfp_twin.models.geometry.dimensions`), ``beta_shape =
"bar" | "p1"`` (the estimate bar, or the published P1 prototype tube), ``fibers = [{name,
x, y}, ...]`` in the beta frame, and two optional sub-tables: ``[geometry.meshes]``
(``body``/``alpha``/``beta``/``fiducial`` = path of an STL or OBJ file replacing that
link's visual mesh) and ``[geometry.collision]`` (link = list of convex-piece files).
Relative paths are relative to the TOML file. Missing keys take
:func:`rfp_twin.models.geometry.dimensions.default_params`. Any bad value raises
:class:`rfp_twin.models.errors.SpecError` naming the field and what is allowed.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from rfp_twin.models.errors import SpecError
from rfp_twin.models.geometry.dimensions import BETA_SHAPES, LINKS, GeometryParams, default_params
from rfp_twin.models.geometry.p1 import P1_BETA_ARM, p1_plan_distance
from rfp_twin.models.geometry.shapes import beta_outline
from rfp_twin.models.robot import RobotSpec

_INT_KEYS = {"circle_sections", "collision_slabs"}
_TABLE_KEYS = {"meshes", "collision"}


def params_from_tables(tables: dict, spec: RobotSpec, source: str = "<memory>",
                       base_dir: str | Path | None = None) -> GeometryParams:
    """GeometryParams from merged preset tables (the ``[geometry]`` table, if any).

    Parameters
    ----------
    tables : dict
        As returned by :func:`rfp_twin.models.robot.load_tables`.
    spec : RobotSpec
        Supplies the defaults for missing keys (:func:`default_params`).
    base_dir : path, optional
        Folder that relative mesh paths are resolved against.
    """
    where = f"{source}: [geometry]"
    table = tables.get("geometry", {})
    if not isinstance(table, dict):
        raise SpecError(f"{where}: not a table; allowed: a [geometry] table of mm values")
    values = default_params(spec)
    known = set(values) | _TABLE_KEYS
    unknown = sorted(set(table) - known)
    if unknown:
        raise SpecError(f"{where}: unknown field(s) {unknown}; allowed: {', '.join(sorted(known))}")
    for key, value in table.items():
        if key in _TABLE_KEYS:
            continue
        if key == "fibers":
            values[key] = _parse_fibers(value, where)
        elif key == "beta_shape":
            if not isinstance(value, str) or value not in BETA_SHAPES:
                raise SpecError(f"{where}: field 'beta_shape' = {value!r}; allowed: "
                                f"{', '.join(repr(v) for v in BETA_SHAPES)}")
            values[key] = value
        elif key in _INT_KEYS:
            if isinstance(value, bool) or not isinstance(value, int) or not 3 <= value <= 1024:
                raise SpecError(f"{where}: field '{key}' = {value!r}; allowed: an integer in [3, 1024]")
            values[key] = value
        else:
            values[key] = _number(value, key, where)
    meshes = _parse_paths(table.get("meshes", {}), "meshes", where, base_dir, single=True)
    collision = _parse_paths(table.get("collision", {}), "collision", where, base_dir, single=False)
    params = GeometryParams(meshes=meshes, collision=collision, source=source, **values)
    validate_params(params, spec)
    return params


def _number(value, key: str, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise SpecError(f"{where}: field '{key}' = {value!r}; allowed: a finite number (mm)")
    return float(value)


def _parse_fibers(value, where: str) -> tuple[tuple[str, float, float], ...]:
    allowed = "allowed: a list of {name = \"...\", x = mm, y = mm} in the beta frame"
    if not isinstance(value, list) or not value:
        raise SpecError(f"{where}: field 'fibers' = {value!r}; {allowed}")
    out = []
    for k, item in enumerate(value):
        if not isinstance(item, dict) or set(item) != {"name", "x", "y"} \
                or not isinstance(item["name"], str) or not item["name"]:
            raise SpecError(f"{where}: field 'fibers[{k}]' = {item!r}; {allowed}")
        out.append((item["name"], _number(item["x"], f"fibers[{k}].x", where),
                    _number(item["y"], f"fibers[{k}].y", where)))
    names = [n for n, _, _ in out]
    if len(set(names)) != len(names):
        raise SpecError(f"{where}: field 'fibers' has duplicate names {names}; allowed: unique names")
    return tuple(out)


def _parse_paths(table, name: str, where: str, base_dir, single: bool) -> dict:
    if not isinstance(table, dict):
        raise SpecError(f"{where}: field '{name}' = {table!r}; allowed: a table link = path")
    out = {}
    for link, value in table.items():
        if link not in LINKS:
            raise SpecError(f"{where}: field '{name}.{link}'; allowed links: {', '.join(LINKS)}")
        items = [value] if single else value
        if not isinstance(items, list) or not items or not all(isinstance(v, str) for v in items):
            kind = "a path" if single else "a list of paths"
            raise SpecError(f"{where}: field '{name}.{link}' = {value!r}; allowed: {kind} to "
                            f"STL/OBJ file(s)")
        paths = tuple(str(Path(base_dir) / v) if base_dir is not None and not Path(v).is_absolute()
                      else v for v in items)
        out[link] = paths[0] if single else paths
    return out


def validate_params(p: GeometryParams, spec: RobotSpec) -> None:
    """Check that the dimensions describe a buildable robot; SpecError otherwise."""
    where = f"{p.source}: [geometry]"

    def need(ok: bool, key: str, value, allowed: str) -> None:
        if not ok:
            raise SpecError(f"{where}: field '{key}' = {value!r}; allowed: {allowed}")

    positive = ("beta_half_width_mm", "beta_tip_mm", "beta_height_mm", "post_radius_mm",
                "ferrule_radius_mm", "fiber_radius_mm", "alpha_height_mm", "alpha_hub_radius_mm",
                "alpha_housing_radius_mm", "body_radius_mm", "body_length_mm",
                "fiducial_radius_mm", "plate_thickness_mm", "density_kg_mm3")
    for key in positive:
        v = getattr(p, key)
        need(v > 0, key, v, "> 0")
    for key in ("beta_tip_half_width_mm", "ferrule_drop_mm", "alpha_z_mm", "beta_rear_mm"):
        v = getattr(p, key)
        need(v >= 0, key, v, ">= 0")
    need(p.beta_tip_half_width_mm < p.beta_half_width_mm, "beta_tip_half_width_mm",
         p.beta_tip_half_width_mm, f"< beta_half_width_mm ({p.beta_half_width_mm})")
    need(p.beta_rear_mm <= p.head_centre_mm, "beta_rear_mm", p.beta_rear_mm,
         "a bar that starts behind the beta axis and ends after it")
    need(p.head_centre_mm > 0, "beta_tip_mm", p.beta_tip_mm,
         f"> sqrt(beta_half_width^2 - tip_half_width^2) "
         f"({p.beta_tip_mm - p.head_centre_mm:.3f} mm)")
    need(p.post_radius_mm < p.beta_half_width_mm, "post_radius_mm", p.post_radius_mm,
         f"< beta_half_width_mm ({p.beta_half_width_mm})")
    need(p.alpha_housing_radius_mm > p.post_radius_mm, "alpha_housing_radius_mm",
         p.alpha_housing_radius_mm, f"> post_radius_mm ({p.post_radius_mm}); the pitch "
         f"{spec.pitch_mm} mm may be too small for alpha arm {spec.alpha_length_mm} mm")
    need(p.beta_z_mm > p.alpha_top_mm, "beta_z_mm", p.beta_z_mm,
         f"> alpha_z_mm + alpha_height_mm ({p.alpha_top_mm}): the beta arm sits above the "
         "alpha arm")
    need(p.beta_z_mm - p.ferrule_drop_mm > p.alpha_top_mm, "ferrule_drop_mm", p.ferrule_drop_mm,
         f"< beta_z_mm - alpha top ({p.beta_z_mm - p.alpha_top_mm:.3f}): the ferrule hangs "
         "above the alpha arms")
    need(p.beta_shape in BETA_SHAPES, "beta_shape", p.beta_shape,
         ", ".join(repr(v) for v in BETA_SHAPES))
    if p.beta_shape == "p1":
        # the fibers sit on the axis of the P1 head: inside its planar footprint there
        head_r = P1_BETA_ARM[-2][2]
        for name, x, y in p.fibers:
            need(p1_plan_distance(x, y) <= head_r, f"fibers.{name}", (x, y),
                 f"a fiber position in the P1 head (within {head_r} mm of its axis, "
                 f"x {P1_BETA_ARM[-2][0]}..{P1_BETA_ARM[-1][0]} mm)")
        return
    fx, fy, fr = p.ferrule_x_mm, p.ferrule_y_mm, p.ferrule_radius_mm
    need(_point_in_outline(beta_outline(p), fx, fy, fr), "ferrule_radius_mm", fr,
         "a ferrule disk inside the beta bar outline (x, y, radius)")
    for name, x, y in p.fibers:
        need(_point_in_outline(beta_outline(p), x, y, 0.0), f"fibers.{name}", (x, y),
             "a fiber position on the beta bar")


def _point_in_outline(outline: np.ndarray, x: float, y: float, r: float) -> bool:
    """True when the disk (x, y, r) is inside the convex CCW outline (k, 2)."""
    a = outline
    b = np.roll(outline, -1, axis=0)
    edge = b - a
    length = np.hypot(edge[:, 0], edge[:, 1])
    ok = length > 0
    cross = (edge[ok, 0] * (y - a[ok, 1]) - edge[ok, 1] * (x - a[ok, 0])) / length[ok]
    return bool(np.all(cross >= r - 1e-9))
