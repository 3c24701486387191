"""The user's own CAD link meshes (STL/OBJ, mm): loading, checks, convex pieces.

Every link has a ``visual`` mesh (one watertight trimesh) and ``collision`` pieces
(convex watertight trimeshes: MuJoCo collides meshes as their convex hulls, so a
concave part must be given as convex pieces). A CAD link without collision pieces is
cut into ``collision_slabs`` slabs along x, each replaced by its convex hull. A bad
mesh (missing, unreadable, open, wrong units, origin off the joint axis) raises
:class:`rfp_twin.models.errors.SpecError` naming the field, the file and what is allowed.
"""
from __future__ import annotations

import math
from pathlib import Path

import manifold3d
import numpy as np
import trimesh

from rfp_twin.models.errors import SpecError

#: Mesh file types a user may give.
MESH_SUFFIXES = (".stl", ".obj")
#: A CAD mesh whose size is off the expected size by more than this factor is refused.
UNIT_RATIO_LIMIT = 5.0
#: Distinct unit mistakes and their scale relative to mm.
_UNIT_GUESSES = (("metres", 1e-3), ("centimetres", 0.1), ("inches", 25.4), ("micrometres", 1e3))


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
