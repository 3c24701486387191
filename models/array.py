"""ArrayGeometry: a layout of robots of one spec at one collision buffer, as flat arrays.

This is what the numba kernels consume: robot base positions, per-robot buffers and
collision segment ends, the Eq. 4 neighbour graph as CSR, and robot-fiducial pairs.
Indices are robot indices (0..n_robots-1 in layout order), not robot ids.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from models.errors import SpecError
from models.geometry2d import fiducial_distances, pair_distances
from models.layout import Layout
from models.robot import RobotSpec

#: Sayres 2021 Sect. 4.1 studies buffers 1.5-3.5 mm; anything in (0, pitch/2) is allowed.
MIN_BUFFER_MM = 0.0


@dataclass(frozen=True)
class ArrayGeometry:
    """Flat arrays describing one array at one buffer.

    Attributes
    ----------
    spec : RobotSpec
    layout : Layout
    buffer_mm : float, sigma_cb for every robot
    base_xy : (n, 2) float64 mm; robot_ids : (n,) int64
    buffer, seg_end : (n,) float64 mm
    nbr_ptr, nbr_idx : CSR adjacency (Eq. 4); nbr_dist : base distance per entry, mm
    pairs : (p, 2) int64, each neighbour pair once (i < j)
    fid_xy : (m, 2) mm; fiducial_ids : (m,); fid_ptr, fid_idx : CSR robot -> fiducials
    robot_fid_pairs : (q, 2) int64 (robot index, fiducial index)
    """

    spec: RobotSpec
    layout: Layout
    buffer_mm: float
    base_xy: np.ndarray = field(init=False, repr=False)
    robot_ids: np.ndarray = field(init=False, repr=False)
    buffer: np.ndarray = field(init=False, repr=False)
    seg_end: np.ndarray = field(init=False, repr=False)
    nbr_ptr: np.ndarray = field(init=False, repr=False)
    nbr_idx: np.ndarray = field(init=False, repr=False)
    nbr_dist: np.ndarray = field(init=False, repr=False)
    pairs: np.ndarray = field(init=False, repr=False)
    fid_xy: np.ndarray = field(init=False, repr=False)
    fiducial_ids: np.ndarray = field(init=False, repr=False)
    fid_ptr: np.ndarray = field(init=False, repr=False)
    fid_idx: np.ndarray = field(init=False, repr=False)
    robot_fid_pairs: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        b = float(self.buffer_mm)
        if not np.isfinite(b) or b <= MIN_BUFFER_MM or b >= self.spec.pitch_mm / 2:
            raise SpecError(f"field 'buffer_mm' = {self.buffer_mm!r}; allowed: "
                            f"({MIN_BUFFER_MM}, {self.spec.pitch_mm / 2}) mm")
        put = lambda k, v: object.__setattr__(self, k, v)  # noqa: E731 (frozen dataclass)
        lay = self.layout
        n = lay.n_robots
        put("base_xy", np.ascontiguousarray(lay.robot_xy, dtype=np.float64))
        put("robot_ids", np.asarray(lay.robot_ids, dtype=np.int64))
        put("buffer", np.full(n, b))
        put("seg_end", np.full(n, self.spec.segment_end(b)))
        reach = self.spec.neighbour_reach_mm(b)
        ptr, idx = lay.neighbour_csr(reach)
        put("nbr_ptr", np.asarray(ptr, dtype=np.int64))
        put("nbr_idx", np.asarray(idx, dtype=np.int64))
        owner = np.repeat(np.arange(n), np.diff(self.nbr_ptr))
        put("nbr_dist", np.hypot(*(self.base_xy[owner] - self.base_xy[self.nbr_idx]).T).copy())
        mask = owner < self.nbr_idx
        put("pairs", np.column_stack([owner[mask], self.nbr_idx[mask]]).astype(np.int64))
        put("fid_xy", np.ascontiguousarray(lay.fiducial_xy, dtype=np.float64).reshape(-1, 2))
        put("fiducial_ids", np.asarray(lay.fiducial_ids, dtype=np.int64))
        fid_reach = self.spec.collision_reach_mm(b) + self.spec.fiducial_buffer_mm
        fptr, fidx = lay.robot_fiducial_csr(fid_reach)
        put("fid_ptr", np.asarray(fptr, dtype=np.int64))
        put("fid_idx", np.asarray(fidx, dtype=np.int64))
        fowner = np.repeat(np.arange(n), np.diff(self.fid_ptr))
        put("robot_fid_pairs", np.column_stack([fowner, self.fid_idx]).astype(np.int64).reshape(-1, 2))

    @property
    def n_robots(self) -> int:
        return int(self.base_xy.shape[0])

    @property
    def fiducial_buffer(self) -> float:
        return float(self.spec.fiducial_buffer_mm)

    def pair_clearance(self, angles: np.ndarray) -> np.ndarray:
        """Eq. 3 clearance D_ij - (sigma_i + sigma_j) of every neighbour pair, mm. (p,)"""
        d = pair_distances(self.base_xy, np.ascontiguousarray(angles, dtype=np.float64), self.pairs,
                           self.spec.alpha_length_mm, self.spec.segment_start_mm, self.seg_end)
        return d - self.buffer[self.pairs[:, 0]] - self.buffer[self.pairs[:, 1]]

    def fiducial_clearance(self, angles: np.ndarray) -> np.ndarray:
        """Clearance of every (robot, fiducial) pair, mm. (q,)"""
        if self.robot_fid_pairs.shape[0] == 0:
            return np.zeros(0)
        d = fiducial_distances(self.base_xy, np.ascontiguousarray(angles, dtype=np.float64),
                               self.robot_fid_pairs, self.fid_xy, self.spec.alpha_length_mm,
                               self.spec.segment_start_mm, self.seg_end)
        return d - self.buffer[self.robot_fid_pairs[:, 0]] - self.fiducial_buffer
