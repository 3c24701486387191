"""Neighbour lists of a layout (Sayres 2021 Eq. 4): which bases are close enough to touch.

Units: millimetres. Two robots can collide only if their bases are within
``reach = 2 (l_alpha + l_beta + buffer)``; a robot and a fiducial within the robot's
reach plus the fiducial's keep-out radius. Results are in robot indices (into
``robot_xy``) and fiducial indices (into ``fiducial_xy``): pairs ``(p, 2)`` int64 or
CSR ``(ptr (n_robots + 1,), idx)`` int64. Distances ``<= reach`` count.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from rfp_twin.models.layout.checks import check_reach

#: Tolerance added to neighbour reaches so that ``distance == reach`` counts, mm.
REACH_TOL_MM = 1e-9


def csr_from_lists(lists, n_rows: int) -> tuple[np.ndarray, np.ndarray]:
    """CSR ``(ptr (n_rows+1,), idx)`` int64 from one index list per row (sorted here)."""
    lengths = np.fromiter((len(x) for x in lists), dtype=np.int64, count=n_rows)
    ptr = np.zeros(n_rows + 1, dtype=np.int64)
    np.cumsum(lengths, out=ptr[1:])
    idx = np.fromiter((j for x in lists for j in sorted(x)), dtype=np.int64, count=int(ptr[-1]))
    return ptr, idx


class LayoutNeighbours:
    """Neighbour queries of :class:`rfp_twin.models.layout.Layout` (a mixin: uses its
    ``robot_xy``, ``fiducial_xy``, ``n_robots`` and ``n_fiducials``)."""

    robot_xy: np.ndarray
    fiducial_xy: np.ndarray
    n_robots: int
    n_fiducials: int

    def neighbour_pairs(self, reach_mm: float) -> np.ndarray:
        """Robot pairs whose bases are within ``reach_mm`` mm.

        Parameters
        ----------
        reach_mm : float
            Base distance within which two robots can touch, mm; Sayres 2021 Eq. 4 uses
            ``2 (l_alpha + l_beta + buffer)``. Distances ``<= reach_mm`` count.

        Returns
        -------
        (n_pairs, 2) int64
            Robot indices ``(i, j)``, ``i < j``, sorted by ``i`` then ``j``.
        """
        reach = check_reach(reach_mm)
        if self.n_robots < 2:
            return np.empty((0, 2), dtype=np.int64)
        pairs = cKDTree(self.robot_xy).query_pairs(r=reach + REACH_TOL_MM, output_type="ndarray")
        pairs = np.sort(pairs.astype(np.int64).reshape(-1, 2), axis=1)
        return pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]

    def neighbour_csr(self, reach_mm: float) -> tuple[np.ndarray, np.ndarray]:
        """Symmetric robot adjacency within ``reach_mm`` mm, CSR.

        Returns
        -------
        ptr : (n_robots + 1,) int64
        idx : (2 * n_pairs,) int64
            Neighbours of robot ``i`` are ``idx[ptr[i]:ptr[i + 1]]`` (robot indices,
            ascending, ``i`` itself excluded).
        """
        pairs = self.neighbour_pairs(reach_mm)
        rows = np.concatenate([pairs[:, 0], pairs[:, 1]])
        cols = np.concatenate([pairs[:, 1], pairs[:, 0]])
        order = np.lexsort((cols, rows))
        ptr = np.zeros(self.n_robots + 1, dtype=np.int64)
        np.cumsum(np.bincount(rows, minlength=self.n_robots), out=ptr[1:])
        return ptr, cols[order].astype(np.int64)

    def robot_fiducial_csr(self, reach_mm: float) -> tuple[np.ndarray, np.ndarray]:
        """Fiducials within ``reach_mm`` mm of each robot base, CSR.

        Returns
        -------
        ptr : (n_robots + 1,) int64
        idx : (n_links,) int64
            Fiducial indices (into ``fiducial_xy``) near robot ``i`` are
            ``idx[ptr[i]:ptr[i + 1]]``, ascending.
        """
        reach = check_reach(reach_mm)
        if self.n_robots == 0 or self.n_fiducials == 0:
            return np.zeros(self.n_robots + 1, dtype=np.int64), np.empty(0, dtype=np.int64)
        lists = cKDTree(self.fiducial_xy).query_ball_point(self.robot_xy, r=reach + REACH_TOL_MM)
        return csr_from_lists(lists, self.n_robots)
