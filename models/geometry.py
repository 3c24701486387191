"""The 3D robot: procedural trimesh meshes of each link, or the user's own CAD meshes.

A positioner has four kinds of rigid parts ("links"), each in its own frame (mm, z up):

``body``
    The fixed body, a cylinder below the robot frame's z = 0 plane. Robot frame: origin on
    the alpha axis at the top face of the fixed body, x along alpha = 0.
``alpha``
    The rotating upper body: a convex "stadium" around the hub on the alpha axis and the
    housing of the beta motor around the beta axis. Frame: origin on the alpha axis at
    ``alpha_z_mm`` above the robot frame, x towards the beta axis.
``beta``
    The beta arm as it is: a bar ``2 * beta_half_width_mm`` wide and ``beta_height_mm``
    high that starts behind the beta axis (rounded rear end), runs along +x and ends in a
    rounded head cut flat at ``beta_tip_mm`` (flat ``2 * beta_tip_half_width_mm`` wide);
    the fiber ferrule hangs ``ferrule_drop_mm`` below the bar near its tip and the beta
    post (the shaft) joins it to the alpha arm. Frame: origin on the beta axis at the
    bottom face of the bar, ``beta_z_mm`` above the robot frame, x along the arm.
``fiducial``
    A fixed cylinder from the bottom of the fixed bodies up to the focal surface.

The fiber tips lie on the top face of the beta bar, which is the focal surface
(``focal_z_mm`` in the wok frame; the model is flat).

Every link has a ``visual`` mesh (one watertight trimesh, what MuJoCo draws and what a
3D validator may use) and ``collision`` pieces (convex watertight trimeshes, what MuJoCo
collides: MuJoCo collides meshes as their convex hulls, so a concave part must be given
as convex pieces). The procedural pieces are exact: the beta bar outline (capsule cut by
the flat tip) is convex, so it is one piece; post and ferrule are cylinders.

The beta collision pieces stay inside the planner's 2D envelope: in the plane, every
vertex is within ``beta_half_width_mm`` of the segment from the beta axis to the head
centre ``beta_tip_mm - sqrt(hw^2 - tip_hw^2)`` (14.73 mm for SDSS-V). Pieces are convex
and a capsule is convex, so the whole pieces are inside. A 2D plan checked with buffer
>= 1.5 mm on a segment reaching >= 14.73 mm therefore keeps the 3D beta arms apart.
:meth:`RobotGeometry.beta_envelope_mm` measures this for any geometry (also user CAD).

Geometry comes from the ``[geometry]`` table of a preset (see ``models/presets``): flat
keys in mm, ``fibers = [{name, x, y}, ...]`` in the beta frame, and two optional
sub-tables: ``[geometry.meshes]`` (``body``/``alpha``/``beta``/``fiducial`` = path of an STL
or OBJ file replacing that link's visual mesh; frame as above, millimetres, watertight)
and ``[geometry.collision]`` (link = list of convex-piece files). A CAD link without
collision pieces is cut into ``collision_slabs`` slabs along x, each replaced by its
convex hull. Relative paths are relative to the TOML file. Any bad value or mesh raises
:class:`models.errors.SpecError` naming the field, the file and what is allowed.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import manifold3d
import numpy as np
import trimesh
from scipy.spatial import ConvexHull

from models.errors import SpecError
from models.robot import RobotSpec, load_spec, load_tables

#: Link names, in tree order.
LINKS = ("body", "alpha", "beta", "fiducial")
#: Links that move (have a joint).
MOVING_LINKS = ("alpha", "beta")
#: Mesh file types a user may give.
MESH_SUFFIXES = (".stl", ".obj")
#: A CAD mesh whose size is off the expected size by more than this factor is refused.
UNIT_RATIO_LIMIT = 5.0
#: Distinct unit mistakes and their scale relative to mm.
_UNIT_GUESSES = (("metres", 1e-3), ("centimetres", 0.1), ("inches", 25.4), ("micrometres", 1e3))

#: SDSS-V defaults, mm (deg where stated). Source of each number in the comment;
#: "estimate" = no published figure, chosen to be plausible and self-consistent.
SDSS_V_DEFAULTS: dict[str, Any] = {
    "beta_half_width_mm": 1.5,      # Sayres 2021 Sect. 3.3: physical arm half-width
    "beta_tip_mm": 16.2,            # kaiju-anchor: beta axis to the flat top edge
    "beta_tip_half_width_mm": 0.3,  # kaiju-anchor: flat tip 0.6 mm wide
    "beta_rear_mm": 1.5,            # estimate: rounded rear end centred on the beta axis
    "beta_height_mm": 2.0,          # estimate
    "beta_z_mm": 5.8,               # estimate: alpha top 4.3 + ferrule drop 1.0 + 0.5 clearance
    "post_radius_mm": 0.5,          # kaiju-anchor: beta post radius
    "ferrule_x_mm": 14.64,          # estimate: centred between metrology and BOSS/APOGEE
    "ferrule_y_mm": 0.0,
    "ferrule_radius_mm": 0.9,       # estimate: holds the three fibers, inside the bar outline
    "ferrule_drop_mm": 1.0,         # estimate: hangs below the bar
    "fiber_radius_mm": 0.06,        # estimate: drawn fiber core (visual only)
    "alpha_z_mm": 0.3,              # estimate: gap above the fixed body
    "alpha_height_mm": 4.0,         # estimate
    "alpha_hub_radius_mm": 4.0,     # estimate
    "alpha_housing_radius_mm": 3.2, # estimate: beta motor housing; reach 10.6 < 22.4 / 2
    "body_radius_mm": 5.0,          # estimate: visual only
    "body_length_mm": 20.0,         # estimate: visible length above the focal plate
    "fiducial_radius_mm": 1.0,      # estimate: inside the 1.5 mm fiducial keep-out disk
    "plate_thickness_mm": 5.0,      # estimate: visual only
    "focal_z_mm": 143.1,            # kaiju-anchor: focal surface in the wok frame
    "circle_sections": 32,          # facets per full circle of the procedural meshes
    "collision_slabs": 8,           # slabs of a CAD link without given collision pieces
    "density_kg_mm3": 2.7e-6,       # estimate: aluminium, for link masses
    "fibers": (("metrology", 14.314, 0.0),   # kaiju-anchor, beta frame
               ("boss", 14.965, -0.376),
               ("apogee", 14.965, 0.376)),
}
_INT_KEYS = {"circle_sections", "collision_slabs"}
_TABLE_KEYS = {"meshes", "collision"}


@dataclass(frozen=True)
class GeometryParams:
    """Dimensions of the 3D robot, mm (see the module docstring for frames).

    One field per key of the ``[geometry]`` table; defaults are SDSS-V
    (:data:`SDSS_V_DEFAULTS`, sources there). ``fibers`` is a tuple of
    ``(name, x_mm, y_mm)`` in the beta frame. ``meshes`` maps a link to a CAD file,
    ``collision`` a link to a tuple of convex-piece files.
    """

    beta_half_width_mm: float
    beta_tip_mm: float
    beta_tip_half_width_mm: float
    beta_rear_mm: float
    beta_height_mm: float
    beta_z_mm: float
    post_radius_mm: float
    ferrule_x_mm: float
    ferrule_y_mm: float
    ferrule_radius_mm: float
    ferrule_drop_mm: float
    fiber_radius_mm: float
    alpha_z_mm: float
    alpha_height_mm: float
    alpha_hub_radius_mm: float
    alpha_housing_radius_mm: float
    body_radius_mm: float
    body_length_mm: float
    fiducial_radius_mm: float
    plate_thickness_mm: float
    focal_z_mm: float
    circle_sections: int
    collision_slabs: int
    density_kg_mm3: float
    fibers: tuple[tuple[str, float, float], ...]
    meshes: dict[str, str] = field(default_factory=dict)
    collision: dict[str, tuple[str, ...]] = field(default_factory=dict)
    source: str = field(default="<memory>", compare=False)

    # -- derived -------------------------------------------------------------
    @property
    def alpha_top_mm(self) -> float:
        """Top of the alpha arm in the robot frame."""
        return self.alpha_z_mm + self.alpha_height_mm

    @property
    def fiber_z_mm(self) -> float:
        """Fiber tips (top of the beta bar) in the robot frame: the focal surface."""
        return self.beta_z_mm + self.beta_height_mm

    @property
    def head_centre_mm(self) -> float:
        """Centre of the rounded head along the beta arm: where the flat tip cuts the
        circle of radius ``beta_half_width_mm``."""
        hw, th = self.beta_half_width_mm, self.beta_tip_half_width_mm
        return self.beta_tip_mm - math.sqrt(hw * hw - th * th)


# -- building params from TOML ---------------------------------------------------
def default_params(spec: RobotSpec) -> dict[str, Any]:
    """Geometry defaults for a spec with no ``[geometry]`` table.

    SDSS-V numbers, with the arm-length-dependent ones moved with the beta length
    (tip, ferrule and fibers keep their distance to the fiber at ``beta_length_mm``) and
    the alpha arm and fixed body shrunk if the pitch is too small for them.
    """
    d = dict(SDSS_V_DEFAULTS)
    shift = spec.beta_length_mm - 15.0
    d["beta_tip_mm"] += shift
    d["ferrule_x_mm"] += shift
    d["fibers"] = tuple((n, x + shift, y) for n, x, y in d["fibers"])
    half = spec.pitch_mm / 2.0
    d["alpha_housing_radius_mm"] = min(d["alpha_housing_radius_mm"],
                                       half - spec.alpha_length_mm - 0.3)
    d["alpha_hub_radius_mm"] = min(d["alpha_hub_radius_mm"], half - 0.3)
    d["body_radius_mm"] = min(d["body_radius_mm"], half - 0.3)
    return d


def params_from_tables(tables: dict, spec: RobotSpec, source: str = "<memory>",
                       base_dir: str | Path | None = None) -> GeometryParams:
    """GeometryParams from merged preset tables (the ``[geometry]`` table, if any).

    Parameters
    ----------
    tables : dict
        As returned by :func:`models.robot.load_tables`.
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


# -- procedural shapes -----------------------------------------------------------
def _arc(cx: float, cy: float, r: float, a0: float, a1: float, n: int) -> np.ndarray:
    """Points (n, 2) on a circle from angle a0 to a1 (rad), both ends included."""
    t = np.linspace(a0, a1, max(n, 2))
    return np.column_stack([cx + r * np.cos(t), cy + r * np.sin(t)])


def _hull2d(points: np.ndarray) -> np.ndarray:
    """Convex hull of 2D points, CCW, (k, 2)."""
    return points[ConvexHull(points).vertices]


def prism(outline: np.ndarray, z0: float, z1: float) -> trimesh.Trimesh:
    """Watertight prism of a convex CCW outline (k, 2) between heights z0 < z1, mm."""
    k = len(outline)
    verts = np.vstack([np.column_stack([outline, np.full(k, z0)]),
                       np.column_stack([outline, np.full(k, z1)])])
    faces = []
    for i in range(1, k - 1):               # caps: fans (outline is convex)
        faces.append((0, i + 1, i))         # bottom, facing -z
        faces.append((k, k + i, k + i + 1))  # top, facing +z
    for i in range(k):                      # sides
        j = (i + 1) % k
        faces.append((i, j, k + j))
        faces.append((i, k + j, k + i))
    mesh = trimesh.Trimesh(verts, np.array(faces), process=True)
    return mesh


def cylinder(x: float, y: float, r: float, z0: float, z1: float, sections: int) -> trimesh.Trimesh:
    """Vertical cylinder (a prism of a regular polygon inscribed in the circle)."""
    return prism(_arc(x, y, r, 0.0, 2 * math.pi, sections + 1)[:-1], z0, z1)


def beta_outline(p: GeometryParams) -> np.ndarray:
    """Planar outline of the beta bar in the beta frame, CCW, (k, 2) mm.

    A capsule of radius ``beta_half_width_mm`` around the segment from
    ``beta_half_width_mm - beta_rear_mm`` to :attr:`GeometryParams.head_centre_mm` on the
    x axis, cut flat at ``x = beta_tip_mm``. Every vertex lies on that capsule.
    """
    hw, n = p.beta_half_width_mm, p.circle_sections
    x_rear = hw - p.beta_rear_mm
    xc = p.head_centre_mm
    rear = _arc(x_rear, 0.0, hw, math.pi / 2, 3 * math.pi / 2, n // 2 + 1)
    a_tip = math.asin(p.beta_tip_half_width_mm / hw)  # angle of the tip corners on the head
    head = _arc(xc, 0.0, hw, -math.pi / 2, -a_tip, n // 4 + 1)
    head = np.vstack([head, _arc(xc, 0.0, hw, a_tip, math.pi / 2, n // 4 + 1)])
    corners = np.array([[p.beta_tip_mm, -p.beta_tip_half_width_mm],
                        [p.beta_tip_mm, p.beta_tip_half_width_mm]])
    return _hull2d(np.vstack([rear, head, corners]))


def alpha_outline(p: GeometryParams, l_alpha: float) -> np.ndarray:
    """Planar outline of the alpha arm (hub + beta housing stadium), CCW, (k, 2) mm."""
    n = p.circle_sections
    pts = np.vstack([_arc(0.0, 0.0, p.alpha_hub_radius_mm, 0, 2 * math.pi, n + 1)[:-1],
                     _arc(l_alpha, 0.0, p.alpha_housing_radius_mm, 0, 2 * math.pi, n + 1)[:-1]])
    return _hull2d(pts)


def _procedural_pieces(p: GeometryParams, spec: RobotSpec) -> dict[str, list[trimesh.Trimesh]]:
    """Convex pieces of every link in its own frame."""
    n = p.circle_sections
    gap = p.beta_z_mm - p.alpha_top_mm            # between alpha top and beta bar bottom
    return {
        "body": [cylinder(0.0, 0.0, p.body_radius_mm, -p.body_length_mm, 0.0, n)],
        "alpha": [prism(alpha_outline(p, spec.alpha_length_mm), 0.0, p.alpha_height_mm)],
        "beta": [prism(beta_outline(p), 0.0, p.beta_height_mm),
                 cylinder(0.0, 0.0, p.post_radius_mm, -gap, 0.0, n),
                 cylinder(p.ferrule_x_mm, p.ferrule_y_mm, p.ferrule_radius_mm,
                          -p.ferrule_drop_mm, 0.0, n)],
        "fiducial": [cylinder(0.0, 0.0, p.fiducial_radius_mm, -p.body_length_mm,
                              p.fiber_z_mm, n)],
    }


def union(meshes: list[trimesh.Trimesh]) -> trimesh.Trimesh:
    """Boolean union (manifold3d) of watertight meshes; one watertight mesh."""
    if len(meshes) == 1:
        return meshes[0].copy()
    return trimesh.boolean.union(meshes, engine="manifold")


# -- CAD meshes ------------------------------------------------------------------
def load_cad_mesh(path: str | Path, field_name: str, expected_mm: float,
                  axis_origin: bool = True, where: str = "") -> trimesh.Trimesh:
    """A user's STL/OBJ link mesh, checked.

    Parameters
    ----------
    path : path of the mesh file (millimetres).
    field_name : the TOML field that named it, for messages.
    expected_mm : float
        Expected largest bounding-box extent, mm; a mesh more than
        :data:`UNIT_RATIO_LIMIT` times smaller or larger is refused (wrong units).
    axis_origin : bool
        Require the frame origin on the joint axis (inside the xy bounding box).

    Raises
    ------
    SpecError
        Missing file, unknown type, unreadable or empty mesh, not watertight, wrong
        units, origin off the joint axis.
    """
    path = Path(path)
    prefix = f"{where}: " if where else ""
    head = f"{prefix}field '{field_name}' = '{path}'"
    if path.suffix.lower() not in MESH_SUFFIXES:
        raise SpecError(f"{head}: unknown mesh type; allowed: {', '.join(MESH_SUFFIXES)} files")
    if not path.is_file():
        raise SpecError(f"{head}: file not found; allowed: an existing STL or OBJ file")
    try:
        mesh = trimesh.load(str(path), force="mesh", process=True)
    except Exception as exc:  # noqa: BLE001 (trimesh raises many types)
        raise SpecError(f"{head}: unreadable mesh ({exc}); allowed: a valid STL or OBJ file") from None
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise SpecError(f"{head}: empty mesh; allowed: a closed triangle mesh")
    mesh.merge_vertices()
    if not mesh.is_watertight:
        open_edges = int(len(trimesh.grouping.group_rows(mesh.edges_sorted, require_count=1)))
        raise SpecError(f"{head}: mesh is not watertight ({open_edges} open edges); allowed: "
                        "a closed (watertight) triangle mesh")
    if mesh.volume < 0:
        mesh.invert()
    extent = float(np.max(mesh.extents))
    ratio = extent / expected_mm
    if not 1.0 / UNIT_RATIO_LIMIT <= ratio <= UNIT_RATIO_LIMIT:
        guess = min(_UNIT_GUESSES, key=lambda g: abs(math.log(ratio / g[1])))
        raise SpecError(f"{head}: bounding box {extent:.4g} mm is {ratio:.3g}x the expected "
                        f"~{expected_mm:.3g} mm (is the file in {guess[0]}?); allowed: "
                        f"millimetres, within {UNIT_RATIO_LIMIT:g}x of the expected size")
    if axis_origin:
        lo, hi = mesh.bounds[0, :2], mesh.bounds[1, :2]
        tol = 0.1 * extent
        if np.any(lo > tol) or np.any(hi < -tol):
            raise SpecError(f"{head}: frame origin is {_fmt(lo)}..{_fmt(hi)} away from the mesh "
                            "(not on the joint axis); allowed: origin on the joint axis, x along "
                            "the arm, z up, mm")
    return mesh


def _fmt(v) -> str:
    return "(" + ", ".join(f"{x:.3g}" for x in v) + ")"


def slab_pieces(mesh: trimesh.Trimesh, n_slabs: int) -> list[trimesh.Trimesh]:
    """Convex pieces of a (possibly concave) watertight mesh: ``n_slabs`` slabs along x,
    each replaced by its convex hull (manifold3d). Exact for shapes convex within each slab."""
    man = manifold3d.Manifold(manifold3d.Mesh(
        vert_properties=np.asarray(mesh.vertices, dtype=np.float32),
        tri_verts=np.asarray(mesh.faces, dtype=np.uint32)))
    x0, x1 = float(mesh.bounds[0, 0]), float(mesh.bounds[1, 0])
    cuts = np.linspace(x0, x1, n_slabs + 1)
    pieces = []
    for a, b in zip(cuts[:-1], cuts[1:]):
        slab = man.trim_by_plane((1.0, 0.0, 0.0), float(a)).trim_by_plane((-1.0, 0.0, 0.0), -float(b))
        if slab.is_empty():
            continue
        out = slab.hull().to_mesh()
        piece = trimesh.Trimesh(np.asarray(out.vert_properties)[:, :3], np.asarray(out.tri_verts))
        if piece.volume > 1e-9:
            pieces.append(piece)
    return pieces or [mesh.convex_hull]


# -- the robot -------------------------------------------------------------------
@dataclass(frozen=True)
class Link:
    """One rigid part.

    Attributes
    ----------
    name : one of :data:`LINKS`
    visual : trimesh.Trimesh, watertight, link frame, mm
    collision : tuple of convex watertight trimesh.Trimesh, link frame, mm
    source : "procedural" or the CAD file
    """

    name: str
    visual: trimesh.Trimesh
    collision: tuple[trimesh.Trimesh, ...]
    source: str = "procedural"

    @property
    def collision_mesh(self) -> trimesh.Trimesh:
        """The collision pieces as one (not merged) trimesh, link frame."""
        return trimesh.util.concatenate(list(self.collision))


@dataclass(frozen=True)
class RobotGeometry:
    """The 3D robot: its spec, its dimensions and one :class:`Link` per name.

    Frames (mm): robot frame at the top face of the fixed body on the alpha axis; see
    :meth:`link_transform` for where each link frame sits.
    """

    spec: RobotSpec
    params: GeometryParams
    links: dict[str, Link]

    # -- frames --------------------------------------------------------------
    def link_offset(self, name: str) -> np.ndarray:
        """Translation (3,) of a link frame from its parent's: body and fiducial from the
        robot frame, alpha from the robot frame, beta from the alpha frame (mm)."""
        p = self.params
        return {"body": np.zeros(3), "fiducial": np.zeros(3),
                "alpha": np.array([0.0, 0.0, p.alpha_z_mm]),
                "beta": np.array([self.spec.alpha_length_mm, 0.0, p.beta_z_mm - p.alpha_z_mm]),
                }[name]

    def link_transform(self, name: str, alpha_deg: float = 0.0, beta_deg: float = 0.0) -> np.ndarray:
        """4x4 transform from a link frame to the robot frame at (alpha, beta) deg."""
        t_alpha = _rot_z(alpha_deg, self.link_offset("alpha"))
        if name == "alpha":
            return t_alpha
        if name == "beta":
            return t_alpha @ _rot_z(beta_deg, self.link_offset("beta"))
        return _rot_z(0.0, self.link_offset(name))

    # -- meshes --------------------------------------------------------------
    def link_meshes(self, kind: str = "collision") -> dict[str, trimesh.Trimesh]:
        """Per-link meshes in their link frames: ``kind`` = "collision" (the convex
        pieces MuJoCo collides, concatenated) or "visual". For a 3D validator (FCL)."""
        if kind not in ("collision", "visual"):
            raise SpecError(f"field 'kind' = {kind!r}; allowed: collision, visual")
        return {n: (lk.collision_mesh if kind == "collision" else lk.visual.copy())
                for n, lk in self.links.items()}

    def robot_meshes(self, alpha_deg: float, beta_deg: float, kind: str = "collision",
                     links=("body", "alpha", "beta")) -> dict[str, trimesh.Trimesh]:
        """Meshes of one robot posed at (alpha, beta) deg, in the robot frame."""
        base = self.link_meshes(kind)
        out = {}
        for name in links:
            m = base[name].copy()
            m.apply_transform(self.link_transform(name, alpha_deg, beta_deg))
            out[name] = m
        return out

    def fiber_positions(self) -> dict[str, tuple[float, float, float]]:
        """Fiber tips in the beta frame (x, y, z) mm: on the top face of the bar."""
        z = self.params.beta_height_mm
        return {n: (x, y, z) for n, x, y in self.params.fibers}

    def beta_envelope_mm(self, seg_start_mm: float = 0.0, seg_end_mm: float | None = None) -> float:
        """Largest planar distance of the beta collision pieces from the segment
        ``[seg_start, seg_end]`` on the beta x axis, mm: the smallest 2D buffer whose
        capsule holds the real arm. Default end: :attr:`GeometryParams.head_centre_mm`."""
        end = self.params.head_centre_mm if seg_end_mm is None else float(seg_end_mm)
        pts = np.vstack([m.vertices[:, :2] for m in self.links["beta"].collision])
        t = np.clip(pts[:, 0], seg_start_mm, end)
        return float(np.max(np.hypot(pts[:, 0] - t, pts[:, 1])))

    def alpha_reach_mm(self) -> float:
        """Largest distance of the alpha collision pieces from the alpha axis, mm."""
        pts = np.vstack([m.vertices[:, :2] for m in self.links["alpha"].collision])
        return float(np.max(np.hypot(pts[:, 0], pts[:, 1])))

    def alpha_arms_can_touch(self, pitch_mm: float | None = None) -> bool:
        """True if two alpha arms ``pitch_mm`` apart (default the spec's) can touch."""
        pitch = self.spec.pitch_mm if pitch_mm is None else pitch_mm
        return 2.0 * self.alpha_reach_mm() >= pitch

    def beta_reach_mm(self) -> float:
        """Largest distance of any beta collision piece from the alpha axis, mm."""
        pts = np.vstack([m.vertices[:, :2] for m in self.links["beta"].collision])
        return self.spec.alpha_length_mm + float(np.max(np.hypot(pts[:, 0], pts[:, 1])))

    def with_params(self, **changes: Any) -> RobotGeometry:
        """A copy with some dimensions changed (meshes rebuilt)."""
        return build_geometry(self.spec, replace(self.params, **changes))


def _rot_z(deg: float, offset: np.ndarray) -> np.ndarray:
    a = math.radians(deg)
    c, s = math.cos(a), math.sin(a)
    t = np.eye(4)
    t[:2, :2] = [[c, -s], [s, c]]
    t[:3, 3] = offset
    return t


def _expected_size(name: str, p: GeometryParams, spec: RobotSpec) -> float:
    return {"body": max(2 * p.body_radius_mm, p.body_length_mm),
            "alpha": spec.alpha_length_mm + p.alpha_hub_radius_mm + p.alpha_housing_radius_mm,
            "beta": p.beta_tip_mm + p.beta_rear_mm,
            "fiducial": p.body_length_mm + p.fiber_z_mm}[name]


def build_geometry(spec: RobotSpec, params: GeometryParams | None = None) -> RobotGeometry:
    """Meshes of every link: procedural, or the CAD files named in ``params.meshes``.

    Raises
    ------
    SpecError
        Bad dimensions (see :func:`validate_params`) or a bad CAD mesh.
    """
    if params is None:
        params = params_from_tables({}, spec, spec.source)
    validate_params(params, spec)
    where = f"{params.source}: [geometry]"
    pieces = _procedural_pieces(params, spec)
    links = {}
    for name in LINKS:
        expected = _expected_size(name, params, spec)
        if name in params.meshes:
            path = params.meshes[name]
            visual = load_cad_mesh(path, f"meshes.{name}", expected, name in MOVING_LINKS, where)
            if name in params.collision:
                coll = [load_cad_mesh(f, f"collision.{name}", expected, False, where).convex_hull
                        for f in params.collision[name]]
            else:
                coll = slab_pieces(visual, params.collision_slabs)
            links[name] = Link(name, visual, tuple(coll), source=str(path))
        else:
            coll = pieces[name]
            if name in params.collision:
                coll = [load_cad_mesh(f, f"collision.{name}", expected, False, where).convex_hull
                        for f in params.collision[name]]
            links[name] = Link(name, union(pieces[name]), tuple(coll))
    return RobotGeometry(spec, params, links)


def load_geometry(name_or_path: str | Path = "sdss-v", spec: RobotSpec | None = None) -> RobotGeometry:
    """The 3D robot of a preset (``sdss-v``, ``desi``, ...) or a TOML file.

    Parameters
    ----------
    name_or_path : preset name or path to a ``.toml`` file.
    spec : RobotSpec, optional
        Use this spec (e.g. with overrides) instead of the file's.
    """
    tables = load_tables(name_or_path)
    if spec is None:
        spec = load_spec(name_or_path)
    path = Path(name_or_path)
    base_dir = path.parent if path.suffix == ".toml" or path.is_file() else None
    return build_geometry(spec, params_from_tables(tables, spec, spec.source, base_dir))


def geometry_for_spec(spec: RobotSpec) -> RobotGeometry:
    """The 3D robot for a spec: the ``[geometry]`` table of the file or preset it came
    from (``spec.source``), else :func:`default_params` of the spec."""
    src = spec.source
    name = None
    if src.startswith("preset "):
        name = src[len("preset "):]
    elif src.endswith(".toml") and Path(src).is_file():
        name = src
    if name is None:
        return build_geometry(spec)
    return load_geometry(name, spec)


__all__ = ["LINKS", "SDSS_V_DEFAULTS", "GeometryParams", "Link", "RobotGeometry",
           "alpha_outline", "beta_outline", "build_geometry", "cylinder", "default_params",
           "geometry_for_spec", "load_cad_mesh", "load_geometry", "params_from_tables",
           "prism", "slab_pieces", "union", "validate_params"]
