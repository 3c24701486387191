"""ArrayGeometry: a layout of robots of one spec at one collision buffer, as flat arrays.

This is what the numba kernels consume: robot base positions, each robot's own alpha
length, collision segment (start, end) and buffer, the Eq. 4 neighbour graph as CSR, the
obstacles (fiducials as points, guide-camera edges as segments, each with its buffer) and
robot-obstacle pairs. Indices are robot indices (0..n_robots-1 in layout order), not
robot ids. Per-robot values come from the layout's optional columns
(:mod:`rfp_twin.models.layout.columns`) and default to the spec's.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from rfp_twin.models.errors import SpecError
from rfp_twin.models.geometry2d import fiducial_distances, pair_distances
from rfp_twin.models.layout import Layout
from rfp_twin.models.layout.columns import (obstacle_arrays, robot_collision_arrays,
                                            robot_joint_limits)
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
    def _robot_arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        return robot_collision_arrays(self.spec, self.layout, float(self.buffer_mm))

    @property
    def buffer(self) -> np.ndarray:
        """(n,) float64 collision buffer of each robot, mm: the run's ``buffer_mm`` plus
        the layout's ``buffer_add_mm`` of that robot (0 where blank)."""
        return self._robot_arrays[3]

    @property
    def alpha_len(self) -> np.ndarray:
        """(n,) float64 alpha arm length of each robot (alpha axis to beta axis), mm."""
        return self._robot_arrays[0]

    @property
    def seg_start(self) -> np.ndarray:
        """(n,) float64 start of each robot's beta collision segment, mm from its beta axis."""
        return self._robot_arrays[1]

    @property
    def seg_end(self) -> np.ndarray:
        """(n,) float64 end of each robot's beta collision segment, mm (the spec's end at
        its own buffer, extended by its metrology fiber's offset; see
        :func:`rfp_twin.models.layout.columns.robot_collision_arrays`)."""
        return self._robot_arrays[2]

    @cached_property
    def limits(self) -> np.ndarray:
        """(n, 4) float64 each robot's travel range in model angles (alpha_lo, alpha_hi,
        beta_lo, beta_hi), deg: the spec's, shifted by the robot's encoder offsets
        (:func:`rfp_twin.models.layout.columns.robot_joint_limits`)."""
        return robot_joint_limits(self.spec, self.layout)

    @cached_property
    def uniform(self) -> bool:
        """True when every robot has the spec's geometry and the run's buffer."""
        return bool(np.all(self.alpha_len == self.spec.alpha_length_mm)
                    and np.all(self.seg_start == self.spec.segment_start_mm)
                    and np.all(self.seg_end == self.spec.segment_end(float(self.buffer_mm)))
                    and np.all(self.buffer == self.buffer_mm))

    @cached_property
    def collision_reach(self) -> float:
        """Largest base-to-collision-body distance of any robot, buffer included, mm."""
        return float(np.max(self.alpha_len + np.maximum(self.seg_end, self.seg_start)
                            + self.buffer)) if self.n_robots else 0.0

    # -- robot neighbours (Eq. 4) --------------------------------------------------
    @cached_property
    def _nbr_csr(self) -> tuple[np.ndarray, np.ndarray]:
        reach = self.spec.neighbour_reach_mm(float(self.buffer_mm))
        if not self.uniform:
            reach = max(reach, 2.0 * self.collision_reach)
        ptr, idx = self.layout.neighbour_csr(reach)
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
        """(m, 2) float64 obstacle centres (a fiducial) or first ends (a segment), mm."""
        return np.ascontiguousarray(self.layout.fiducial_xy, dtype=np.float64).reshape(-1, 2)

    @cached_property
    def _obstacles(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return obstacle_arrays(self.spec, self.layout)

    @property
    def fid_end_xy(self) -> np.ndarray:
        """(m, 2) float64 second end of each obstacle, mm (== ``fid_xy`` for a point)."""
        return self._obstacles[1]

    @property
    def fid_buffer(self) -> np.ndarray:
        """(m,) float64 keep-out radius of each obstacle, mm (spec ``fiducial_buffer_mm``
        where the layout's ``obstacle_buffer_mm`` is blank)."""
        return self._obstacles[2]

    @cached_property
    def fiducial_ids(self) -> np.ndarray:
        """(m,) int64 fiducial ids, layout order."""
        return np.asarray(self.layout.fiducial_ids, dtype=np.int64)

    @cached_property
    def _fid_csr(self) -> tuple[np.ndarray, np.ndarray]:
        b = float(self.buffer_mm)
        reach = self.spec.collision_reach_mm(b) + self.spec.fiducial_buffer_mm
        if not self.uniform or self.fid_buffer.size and (
                np.any(self.fid_buffer != self.spec.fiducial_buffer_mm)
                or np.any(self.fid_end_xy != self.fid_xy)):
            reach = max(reach, self.collision_reach + float(self.fid_buffer.max(initial=0.0)))
            return obstacles_within(self.base_xy, self.fid_xy, self.fid_end_xy,
                                     reach + self.fid_buffer - self.spec.fiducial_buffer_mm)
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
        """Eq. 3 clearance D_ij - (sigma_i + sigma_j) of every neighbour pair, mm. (p,)

        ``angles`` (n, 2) deg; each robot's own alpha length, segment and buffer."""
        d = pair_distances(self.base_xy, np.ascontiguousarray(angles, dtype=np.float64), self.pairs,
                           self.alpha_len, self.seg_start, self.seg_end)
        return d - self.buffer[self.pairs[:, 0]] - self.buffer[self.pairs[:, 1]]

    def fiducial_clearance(self, angles: np.ndarray) -> np.ndarray:
        """Clearance D_if - (sigma_i + fid_buffer_f) of every (robot, obstacle) pair, mm. (q,)

        ``D_if``: distance from robot i's beta segment to obstacle f (a point, or the
        segment ``fid_xy[f]``-``fid_end_xy[f]``)."""
        if self.robot_fid_pairs.shape[0] == 0:
            return np.zeros(0)
        d = fiducial_distances(self.base_xy, np.ascontiguousarray(angles, dtype=np.float64),
                               self.robot_fid_pairs, self.fid_xy, self.alpha_len,
                               self.seg_start, self.seg_end, self.fid_end_xy)
        return (d - self.buffer[self.robot_fid_pairs[:, 0]]
                - self.fid_buffer[self.robot_fid_pairs[:, 1]])

def obstacles_within(base: np.ndarray, a: np.ndarray, b: np.ndarray,
                      reach: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """CSR (ptr (n + 1,), idx) of the obstacles (segments ``a``-``b``, (m, 2) mm) whose
    distance to each robot base (n, 2) is within that obstacle's ``reach`` (m,) mm."""
    u = b - a
    den = np.maximum(np.einsum("ij,ij->i", u, u), 1e-300)
    rel = base[:, None, :] - a[None, :, :]
    t = np.clip(np.einsum("nmk,mk->nm", rel, u) / den, 0.0, 1.0)
    d = np.hypot(*(rel - t[..., None] * u[None]).transpose(2, 0, 1))
    near = d <= reach[None, :] + 1e-9
    ptr = np.concatenate([[0], np.cumsum(near.sum(axis=1))]).astype(np.int64)
    return ptr, np.nonzero(near)[1].astype(np.int64)


def _csr_rows(ptr: np.ndarray) -> np.ndarray:
    """Row index of every entry of a CSR with row pointers ``ptr`` (n + 1,)."""
    return np.repeat(np.arange(len(ptr) - 1), np.diff(ptr))
