"""Splitting a large array into tiles that MuJoCo can build and step: who owns which robot,
and which neighbours each tile must also carry (its halo).

Why tiles
---------
One MuJoCo model of the whole array stops scaling past a few thousand robots: the compile
is O(n^2) (``mj_setConst`` works on dense per-body Jacobians: 22 s at 12,852 robots), the
collision broadphase sweeps every geom of the model (a step costs 0.5 ms at 504 robots but
1.5 ms at 1,008), and above 46,341 bodies the collision driver cannot run at all
(:mod:`rfp_twin.models.mjcf.memory`). A tiled twin builds one small model per tile instead.

A tile owns a compact patch of robots (recursive halving of the robot bases along the
longer side until a patch has at most ``max_robots``). It also carries, as its *halo*,
every robot of the other tiles whose parts can touch one of its own (bases within
``2 * contact_reach_mm``, the pairs :meth:`TwinModel.neighbour_pairs` lists) and every
obstacle within reach of its own robots. The simulator moves a halo robot along with the
tile that owns it, so each owned robot meets every neighbour it can touch.

Units: mm. Robot indices are layout robot indices (0..n-1); obstacle indices count the
layout's non-robot rows (0..m-1).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from rfp_twin.models.errors import SpecError
from rfp_twin.models.geometry import RobotGeometry
from rfp_twin.models.layout import Layout
from rfp_twin.models.layout.columns import obstacle_arrays, robot_axes, robot_column
from rfp_twin.models.robot import RobotSpec

#: Default largest number of robots a tile owns: the per-robot cost of a MuJoCo step is
#: flat up to ~500 robots and grows beyond (0.49 ms at 504 robots, 1.5 ms at 1,008).
TILE_ROBOTS = 512
#: Arrays above this many robots are simulated in tiles by default (one model below).
TILE_ABOVE_ROBOTS = 2000
#: Width of the strips tiles are cut from, pitches (:func:`split_robots`). MuJoCo's
#: broadphase sweeps the bodies along one axis; in a long tile it picks the long one and
#: each body overlaps far fewer others than in a square tile. ``rfp-twin simulate`` of a
#: raft:204 fold (2 threads, 4 runs each in turn): square tiles 0.41-0.49x real time
#: (median 0.42x), strips of 7 pitches 0.48-0.53x (0.49x), of 10 pitches 0.45-0.60x (0.50x).
STRIP_PITCHES = 10.0


def contact_reach_mm(layout: Layout, geometry: RobotGeometry) -> float:
    """Largest distance from a robot's base axis that any of its moving parts reaches, mm:
    the beta link's reach with the layout's longest alpha arm (``alpha_len_mm``), or the
    alpha link's, plus, for tilted robots, the sideways shift of the fiber height
    (``fiber_z_mm * sin(tilt)``). Two robots whose bases are more than twice this apart
    cannot touch."""
    nominal = float(geometry.link_offset("beta")[0])
    longest = float(np.max(robot_column(layout, "alpha_len_mm", nominal), initial=nominal))
    reach = max(geometry.beta_reach_mm() + max(0.0, longest - nominal), geometry.alpha_reach_mm())
    return reach + tilt_shift_mm(layout, geometry)


def tilt_shift_mm(layout: Layout, geometry: RobotGeometry) -> float:
    """Largest sideways shift of a robot's highest point (the fibers, ``fiber_z_mm`` above
    its base) caused by the tilt of its axis, mm (0 on a flat wok)."""
    if not layout.n_robots:
        return 0.0
    k = robot_axes(layout)
    return float(np.max(np.hypot(k[:, 0], k[:, 1]))) * geometry.params.fiber_z_mm


def alpha_arms_meet(layout: Layout, geometry: RobotGeometry) -> bool:
    """True if two alpha arms of ``layout`` can touch: some pair of bases is within twice
    the alpha link's reach (plus the tilt shift). When False, the model does not test alpha
    pieces against each other (a third of a step's collision time on raft arrays)."""
    reach = geometry.alpha_reach_mm() + tilt_shift_mm(layout, geometry)
    return len(layout.neighbour_pairs(2.0 * reach)) > 0


def split_robots(xy: np.ndarray, max_robots: int, strip_mm: float | None = None
                 ) -> list[np.ndarray]:
    """Patches of at most ``max_robots`` points. ``xy`` (n, 2) mm; returns a list of
    sorted index arrays covering 0..n-1 once each, in a deterministic order.

    Without ``strip_mm``: compact patches, by recursive halving at the median along the
    longer side of each patch's bounding box. With ``strip_mm`` (mm) and more than
    ``max_robots`` points: strips of that width along x, each cut along y into the fewest
    patches of at most ``max_robots`` points, of near-equal size."""
    if isinstance(max_robots, bool) or not isinstance(max_robots, (int, np.integer)) \
            or max_robots < 1:
        raise SpecError(f"field 'tile_robots' = {max_robots!r}; allowed: an integer >= 1")
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    if strip_mm is not None and len(xy) > max_robots:
        if not (np.isfinite(strip_mm) and strip_mm > 0):
            raise SpecError(f"field 'strip_mm' = {strip_mm!r}; allowed: > 0 mm")
        strip = np.floor((xy[:, 0] - xy[:, 0].min()) / strip_mm).astype(np.int64)
        patches = []
        for k in np.unique(strip):
            rows = np.flatnonzero(strip == k)
            rows = rows[np.argsort(xy[rows, 1], kind="stable")]
            for part in np.array_split(rows, -(-rows.size // max_robots)):
                patches.append(np.sort(part))
        return patches
    out: list[np.ndarray] = []
    stack = [np.arange(len(xy))]
    while stack:
        rows = stack.pop()
        if rows.size <= max_robots:
            if rows.size:
                out.append(np.sort(rows))
            continue
        pts = xy[rows]
        axis = int(np.argmax(pts.max(axis=0) - pts.min(axis=0)))
        # the fewest patches this part needs, half of them on each side
        parts = -(-rows.size // max_robots)
        left = rows.size * (parts // 2) // parts
        order = np.argsort(pts[:, axis], kind="stable")
        stack.append(rows[order[left:]])
        stack.append(rows[order[:left]])
    return out


@dataclass(frozen=True)
class TilePlan:
    """Which robots and obstacles each tile models.

    owned : list of (k_t,) int64 robot indices a tile owns (every robot in exactly one)
    halo : list of (h_t,) int64 robot indices of other tiles it carries
    obstacles : list of (o_t,) int64 obstacle indices it carries
    reach_mm : the :func:`contact_reach_mm` used
    """

    owned: list[np.ndarray]
    halo: list[np.ndarray]
    obstacles: list[np.ndarray]
    reach_mm: float

    @property
    def n_tiles(self) -> int:
        return len(self.owned)

    def rows(self, layout: Layout, t: int) -> np.ndarray:
        """Layout row indices of tile ``t``'s robots (owned and halo) and obstacles, in
        layout order."""
        robot_rows = np.flatnonzero(layout.robot_mask)
        other_rows = np.flatnonzero(~layout.robot_mask)
        chosen = np.concatenate([robot_rows[self.owned[t]], robot_rows[self.halo[t]],
                                 other_rows[self.obstacles[t]]])
        return np.sort(chosen)


def plan_tiles(layout: Layout, geometry: RobotGeometry, spec: RobotSpec,
               max_robots: int = TILE_ROBOTS) -> TilePlan:
    """Split ``layout`` into tiles of at most ``max_robots`` owned robots
    (:func:`split_robots`, strips of :data:`STRIP_PITCHES` pitches), each with its halo of
    touching neighbours and the obstacles its robots can reach (a post within ``reach`` of
    an owned base, a wall whose nearest point is)."""
    reach = contact_reach_mm(layout, geometry)
    owned = split_robots(layout.robot_xy, max_robots, STRIP_PITCHES * spec.pitch_mm)
    tile_of = np.empty(layout.n_robots, dtype=np.int64)
    for t, rows in enumerate(owned):
        tile_of[rows] = t
    pairs = layout.neighbour_pairs(2.0 * reach)
    cross = pairs[tile_of[pairs[:, 0]] != tile_of[pairs[:, 1]]]
    halo = []
    for t in range(len(owned)):
        a = cross[tile_of[cross[:, 0]] == t, 1]
        b = cross[tile_of[cross[:, 1]] == t, 0]
        halo.append(np.unique(np.concatenate([a, b])))
    obstacles = _obstacles_near(layout, spec, owned, reach)
    return TilePlan(owned, halo, obstacles, reach)


def _obstacles_near(layout: Layout, spec: RobotSpec, owned: list[np.ndarray],
                    reach: float) -> list[np.ndarray]:
    """Per tile, the obstacles within ``reach`` (plus the obstacle's own radius) of one
    of its owned robot bases (segments: of their nearest point)."""
    if layout.n_fiducials == 0:
        return [np.empty(0, dtype=np.int64) for _ in owned]
    a, b, radius = obstacle_arrays(spec, layout)
    # sample every segment densely enough that a base within reach of it is within
    # reach + step/2 of a sample
    step = max(reach / 4.0, 1e-3)
    samples, which = [], []
    for f in range(len(a)):
        k = int(np.ceil(np.hypot(*(b[f] - a[f])) / step)) + 1
        u = np.linspace(0.0, 1.0, k)[:, None]
        samples.append(a[f] + u * (b[f] - a[f]))
        which.append(np.full(k, f))
    pts, which = np.vstack(samples), np.concatenate(which)
    tree = cKDTree(pts)
    r = reach + float(np.max(radius, initial=0.0)) + step
    out = []
    for rows in owned:
        hits = tree.query_ball_point(layout.robot_xy[rows], r=r)
        found = np.unique(np.concatenate([which[np.asarray(h, dtype=np.int64)] for h in hits]
                                         + [np.empty(0, dtype=np.int64)]))
        out.append(found.astype(np.int64))
    return out
