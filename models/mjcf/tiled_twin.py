"""A large array as several small MuJoCo models: one per tile, each with its halo
(:mod:`rfp_twin.models.mjcf.tiles`).

Each tile is an ordinary :class:`TwinModel` of a sub-layout (its owned robots, its halo
robots and the obstacles they can reach; every robot keeps its own calibration columns, so
it stands exactly where it stands in the whole-array model). Its contact bits are then
changed so that a tile sees each contact once:

- an owned robot's collision geoms keep their bits and also accept the halo's:
  ``conaffinity |= conaffinity << HALO_SHIFT``;
- a halo robot's collision geoms move to the halo bits (``contype << HALO_SHIFT``) and
  accept nothing (``conaffinity = 0``): halo pieces meet owned pieces (under the same
  beta/alpha rules as the whole model), never each other nor the obstacles (their own
  tile has those contacts).

The body-level bits MuJoCo's broadphase reads are recomputed from the geoms.

Units: as :mod:`rfp_twin.models.mjcf` (mm, degrees at the API). Robot indices are the
whole layout's (0..n-1); a tile's local robots are in layout order.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from rfp_twin.models.geometry import RobotGeometry, geometry_for_spec
from rfp_twin.models.layout import Layout
from rfp_twin.models.mjcf.build import build_model
from rfp_twin.models.mjcf.options import ModelOptions
from rfp_twin.models.mjcf.tiles import TILE_ROBOTS, TilePlan, plan_tiles
from rfp_twin.models.mjcf.twin_model import ModelInputs, TwinModel
from rfp_twin.models.robot import RobotSpec

#: Halo contact bits are the owned bits shifted left by this much.
HALO_SHIFT = 2

#: ``progress(stage, done, total)`` of a tiled build: stage "tiles" (tiles built of all).
TiledProgress = Callable[[str, int, int], None]


@dataclass
class Tile:
    """One tile's model and where its robots sit in the whole array.

    twin : TwinModel of the tile's sub-layout
    robots : (r,) int64 whole-array robot index of each local robot (local order)
    owned : (r,) bool, True for the robots this tile owns (False: halo)
    """

    twin: TwinModel
    robots: np.ndarray
    owned: np.ndarray

    @property
    def n_owned(self) -> int:
        return int(np.count_nonzero(self.owned))


@dataclass
class TiledTwin(ModelInputs):
    """The whole array as tiles (see the module docstring).

    tiles : list of Tile; plan : TilePlan
    spec, layout, geometry, options, base_z_mm : what it was built from (:class:`ModelInputs`)
    """

    tiles: list[Tile]
    plan: TilePlan

    @property
    def n_robots(self) -> int:
        return self.layout.n_robots

    @property
    def robot_ids(self) -> np.ndarray:
        return np.asarray(self.layout.robot_ids, dtype=np.int64)

    def gather(self, per_tile: list[np.ndarray]) -> np.ndarray:
        """The whole-array (n, ...) array from per-tile local arrays (r_t, ...): each
        robot's row from the tile that owns it."""
        first = np.asarray(per_tile[0])
        out = np.empty((self.n_robots, *first.shape[1:]), dtype=first.dtype)
        for tile, arr in zip(self.tiles, per_tile):
            out[tile.robots[tile.owned]] = np.asarray(arr)[tile.owned]
        return out


def model_tiles(twin: TwinModel | TiledTwin) -> list[Tile]:
    """The MuJoCo models of a twin as tiles: a tiled twin's own, or one tile that owns
    every robot of a :class:`TwinModel` (callers then treat both alike)."""
    if isinstance(twin, TiledTwin):
        return twin.tiles
    n = twin.n_robots
    return [Tile(twin, np.arange(n), np.ones(n, dtype=bool))]


def sub_layout(layout: Layout, rows: np.ndarray, name: str) -> Layout:
    """The layout's rows ``rows`` (sorted layout row indices) with all their columns."""
    return Layout(ids=layout.ids[rows], xy=layout.xy[rows], kinds=layout.kinds[rows], name=name,
                  extra={k: v[rows] for k, v in layout.extra.items()})


def mark_halo(twin: TwinModel, owned: np.ndarray) -> None:
    """Change ``twin.model``'s contact bits in place so that the robots where ``owned``
    (r,) is False are a halo (see the module docstring)."""
    m = twin.model
    idx = twin.index
    contype = np.asarray(m.geom_contype).copy()
    conaff = np.asarray(m.geom_conaffinity).copy()
    robot = idx.geom_robot
    is_robot = robot >= 0
    halo = np.zeros(m.ngeom, dtype=bool)
    halo[is_robot] = ~owned[robot[is_robot]]
    own = is_robot & ~halo
    conaff[own] |= conaff[own] << HALO_SHIFT
    contype[halo] = contype[halo] << HALO_SHIFT
    conaff[halo] = 0
    m.geom_contype[:] = contype
    m.geom_conaffinity[:] = conaff
    body = np.asarray(m.geom_bodyid)
    btype = np.zeros(m.nbody, dtype=np.int64)
    baff = np.zeros(m.nbody, dtype=np.int64)
    np.bitwise_or.at(btype, body, contype.astype(np.int64))
    np.bitwise_or.at(baff, body, conaff.astype(np.int64))
    m.body_contype[:] = btype
    m.body_conaffinity[:] = baff


def build_tiled(spec: RobotSpec, layout: Layout, geometry: RobotGeometry | None = None,
                options: ModelOptions | None = None, max_robots: int = TILE_ROBOTS,
                progress: TiledProgress | None = None) -> TiledTwin:
    """Build the tiled twin of ``layout``: :func:`plan_tiles`, then one
    :func:`build_model` per tile with its halo marked (:func:`mark_halo`).
    ``progress("tiles", done, total)`` after each tile."""
    geometry = geometry if geometry is not None else geometry_for_spec(spec)
    options = options if options is not None else ModelOptions()
    # tiles only simulate: no robot visual meshes (renderers draw tiled twins from models
    # of their own, twin/render/merged.py and tile_closeup.py)
    sim_options = replace(options, robot_visuals=False)
    plan = plan_tiles(layout, geometry, spec, max_robots)
    tiles = []
    for t in range(plan.n_tiles):
        if progress is not None:
            progress("tiles", t, plan.n_tiles)
        rows = plan.rows(layout, t)
        sub = sub_layout(layout, rows, f"{layout.name}#tile{t}")
        twin = build_model(spec, sub, geometry, sim_options)
        robots = np.sort(np.concatenate([plan.owned[t], plan.halo[t]])).astype(np.int64)
        owned = np.isin(robots, plan.owned[t])
        mark_halo(twin, owned)
        twin.mjspec = None          # ~20 MB a tile: a tile model is never exported or rebuilt
        tiles.append(Tile(twin, robots, owned))
    if progress is not None:
        progress("tiles", plan.n_tiles, plan.n_tiles)
    base_z = geometry.params.focal_z_mm - geometry.params.fiber_z_mm
    return TiledTwin(tiles, plan, spec=spec, layout=layout, geometry=geometry, options=options,
                     base_z_mm=base_z)
