"""The 3D robot: :class:`RobotGeometry`, one :class:`Link` per part, built from a spec.

Meshes are procedural (:mod:`rfp_twin.models.geometry.shapes`) or the user's CAD files
(:mod:`rfp_twin.models.geometry.cad`), in link frames (mm, z up; see
:mod:`rfp_twin.models.geometry.dimensions`). Angles in degrees, transforms 4x4.

The beta collision pieces stay inside the planner's 2D envelope: in the plane, every
vertex is within ``beta_half_width_mm`` of the segment from the beta axis to the head
centre ``beta_tip_mm - sqrt(hw^2 - tip_hw^2)`` (14.73 mm for SDSS-V). Pieces are convex
and a capsule is convex, so the whole pieces are inside. A 2D plan checked with buffer
>= 1.5 mm on a segment reaching >= 14.73 mm therefore keeps the 3D beta arms apart.
:meth:`RobotGeometry.beta_envelope_mm` measures this for any geometry (also user CAD).
The P1 prototype tube (``beta_shape = "p1"``) is much wider: its base sphere has a
radius of 3.44 mm and its head reaches 14.7 + 2.61 mm from the beta axis.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import trimesh

from rfp_twin.models.errors import SpecError
from rfp_twin.models.geometry.cad import load_cad_mesh, slab_pieces
from rfp_twin.models.geometry.dimensions import LINKS, MOVING_LINKS, GeometryParams
from rfp_twin.models.geometry.params import params_from_tables, validate_params
from rfp_twin.models.geometry.shapes import procedural_pieces, union
from rfp_twin.models.robot import RobotSpec, load_spec, load_tables, spec_origin


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
        """Fiber tips in the beta frame (x, y, z) mm: on the top face of the bar, or on
        the axis of the P1 head (:attr:`GeometryParams.fiber_height_mm`)."""
        z = self.params.fiber_height_mm
        return {n: (x, y, z) for n, x, y in self.params.fibers}

    def beta_envelope_mm(self, seg_start_mm: float = 0.0, seg_end_mm: float | None = None) -> float:
        """Largest planar distance of the beta collision pieces from the segment
        ``[seg_start, seg_end]`` on the beta x axis, mm: the smallest 2D buffer whose
        capsule holds the real arm. Default end: :attr:`GeometryParams.beta_end_mm` (the
        head centre of the bar, the end of the P1 polyline)."""
        end = self.params.beta_end_mm if seg_end_mm is None else float(seg_end_mm)
        pts = self._plan_points("beta")
        t = np.clip(pts[:, 0], seg_start_mm, end)
        return float(np.max(np.hypot(pts[:, 0] - t, pts[:, 1])))

    def alpha_reach_mm(self) -> float:
        """Largest distance of the alpha collision pieces from the alpha axis, mm."""
        pts = self._plan_points("alpha")
        return float(np.max(np.hypot(pts[:, 0], pts[:, 1])))

    def alpha_arms_can_touch(self, pitch_mm: float | None = None) -> bool:
        """True if two alpha arms ``pitch_mm`` apart (default the spec's) can touch."""
        pitch = self.spec.pitch_mm if pitch_mm is None else pitch_mm
        return 2.0 * self.alpha_reach_mm() >= pitch

    def beta_reach_mm(self) -> float:
        """Largest distance of any beta collision piece from the alpha axis, mm."""
        pts = self._plan_points("beta")
        return self.spec.alpha_length_mm + float(np.max(np.hypot(pts[:, 0], pts[:, 1])))

    def _plan_points(self, link: str) -> np.ndarray:
        """(k, 2) x, y of every vertex of a link's collision pieces, link frame, mm."""
        return np.vstack([m.vertices[:, :2] for m in self.links[link].collision])

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
    pieces = procedural_pieces(params, spec)
    links = {}
    for name in LINKS:
        expected = _expected_size(name, params, spec)
        cad = params.meshes.get(name)
        if cad is not None:
            visual = load_cad_mesh(cad, f"meshes.{name}", expected, name in MOVING_LINKS, where)
        else:
            visual = union(pieces[name])
        if name in params.collision:
            coll = [load_cad_mesh(f, f"collision.{name}", expected, False, where).convex_hull
                    for f in params.collision[name]]
        elif cad is not None:
            coll = slab_pieces(visual, params.collision_slabs)
        else:
            coll = pieces[name]
        links[name] = Link(name, visual, tuple(coll),
                           source="procedural" if cad is None else str(cad))
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
    origin = spec_origin(spec)
    if origin is None:
        return build_geometry(spec)
    return load_geometry(origin, spec)
