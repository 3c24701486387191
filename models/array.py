"""ArrayGeometry: a layout of robots of one spec at one collision buffer, as flat arrays.

This is what the numba kernels consume: robot base positions, per-robot buffers and
collision segment ends, the Eq. 4 neighbour graph as CSR, and robot-fiducial pairs.
Indices are robot indices (0..n_robots-1 in layout order), not robot ids.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from rfp_twin.models.errors import SpecError
from rfp_twin.models.geometry2d import fiducial_distances, pair_distances
from rfp_twin.models.layout import Layout
from rfp_twin.models.robot import RobotSpec

#: Sayres 2021 Sect. 4.1 studies buffers 1.5-3.5 mm; anything in (0, pitch/2) is allowed.
MIN_BUFFER_MM = 0.0


@dataclass(frozen=True)
class ArrayGeometry:
    """Flat arrays describing one array at one buffer (n robots, m fiducials).

    Attributes
    ----------
    spec : RobotSpec
    layout : Layout
    buffer_mm : float, sigma_cb for every robot

    The arrays below are computed on first use and then kept (read them, do not write).
    """

    spec: RobotSpec
    layout: Layout
    buffer_mm: float

    def __post_init__(self) -> None:
        b = float(self.buffer_mm)
        if not np.isfinite(b) or b <= MIN_BUFFER_MM or b >= self.spec.pitch_mm / 2:
            raise SpecError(f"field 'buffer_mm' = {self.buffer_mm!r}; allowed: "
                            f"({MIN_BUFFER_MM}, {self.spec.pitch_mm / 2}) mm")

    # -- robots ----------------------------------------------------------------
    @cached_property
    def base_xy(self) -> np.ndarray:
        """(n, 2) float64 robot base centres, mm."""
        return np.ascontiguousarray(self.layout.robot_xy, dtype=np.float64)

    @cached_property
    def robot_ids(self) -> np.ndarray:
        """(n,) int64 robot ids, layout order."""
        return np.asarray(self.layout.robot_ids, dtype=np.int64)

    @cached_property
    def buffer(self) -> np.ndarray:
        """(n,) float64 collision buffer of each robot, mm."""
        return np.full(self.n_robots, float(self.buffer_mm))

    @cached_property
    def seg_end(self) -> np.ndarray:
        """(n,) float64 end of each robot's beta collision segment, mm."""
        return np.full(self.n_robots, self.spec.segment_end(float(self.buffer_mm)))

    # -- robot neighbours (Eq. 4) --------------------------------------------------
    @cached_property
    def _nbr_csr(self) -> tuple[np.ndarray, np.ndarray]:
        ptr, idx = self.layout.neighbour_csr(self.spec.neighbour_reach_mm(float(self.buffer_mm)))
        return np.asarray(ptr, dtype=np.int64), np.asarray(idx, dtype=np.int64)

    @property
    def nbr_ptr(self) -> np.ndarray:
        """(n + 1,) int64 CSR row pointers of the neighbour graph."""
        return self._nbr_csr[0]

    @property
    def nbr_idx(self) -> np.ndarray:
        """(2 p,) int64 neighbours of robot ``i``: ``nbr_idx[nbr_ptr[i]:nbr_ptr[i + 1]]``."""
        return self._nbr_csr[1]

    @cached_property
    def nbr_dist(self) -> np.ndarray:
        """(2 p,) float64 base distance of each ``nbr_idx`` entry to its robot, mm."""
        owner = _csr_rows(self.nbr_ptr)
        return np.hypot(*(self.base_xy[owner] - self.base_xy[self.nbr_idx]).T).copy()

    @cached_property
    def pairs(self) -> np.ndarray:
        """(p, 2) int64 each neighbour pair once, ``i < j``."""
        owner = _csr_rows(self.nbr_ptr)
        mask = owner < self.nbr_idx
        return np.column_stack([owner[mask], self.nbr_idx[mask]]).astype(np.int64)

    # -- fiducials -----------------------------------------------------------------
    @cached_property
    def fid_xy(self) -> np.ndarray:
        """(m, 2) float64 fiducial centres, mm."""
        return np.ascontiguousarray(self.layout.fiducial_xy, dtype=np.float64).reshape(-1, 2)

    @cached_property
    def fiducial_ids(self) -> np.ndarray:
        """(m,) int64 fiducial ids, layout order."""
        return np.asarray(self.layout.fiducial_ids, dtype=np.int64)

    @cached_property
    def _fid_csr(self) -> tuple[np.ndarray, np.ndarray]:
        b = float(self.buffer_mm)
        reach = self.spec.collision_reach_mm(b) + self.spec.fiducial_buffer_mm
        ptr, idx = self.layout.robot_fiducial_csr(reach)
        return np.asarray(ptr, dtype=np.int64), np.asarray(idx, dtype=np.int64)

    @property
    def fid_ptr(self) -> np.ndarray:
        """(n + 1,) int64 CSR row pointers, robot -> nearby fiducials."""
        return self._fid_csr[0]

    @property
    def fid_idx(self) -> np.ndarray:
        """Fiducial indices near robot ``i``: ``fid_idx[fid_ptr[i]:fid_ptr[i + 1]]``."""
        return self._fid_csr[1]

    @cached_property
    def robot_fid_pairs(self) -> np.ndarray:
        """(q, 2) int64 (robot index, fiducial index) pairs that can touch."""
        return np.column_stack([_csr_rows(self.fid_ptr), self.fid_idx]).astype(np.int64).reshape(-1, 2)

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


def _csr_rows(ptr: np.ndarray) -> np.ndarray:
    """Row index of every entry of a CSR with row pointers ``ptr`` (n + 1,)."""
    return np.repeat(np.arange(len(ptr) - 1), np.diff(ptr))
