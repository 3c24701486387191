"""The objects of a 3D check and their candidate link pairs (mm, mm/s).

Objects are the robots of the trajectory (in trajectory order) followed by the
fiducials of the layout. Links ``A`` of object ``i`` and ``B`` of object ``j`` (``i !=
j``) can touch only if their z intervals come within ``min_gap_mm`` and ``|b_i - b_j|
<= reach_A + reach_B + min_gap_mm`` (:meth:`LinkModels.can_touch`). A robot's own links
are never paired (they are joined by the joints), nor are two fiducials (they never
move). Link pairs of one object pair form a *group*: a row of the report.
"""
from __future__ import annotations

import numpy as np

from rfp_twin.models.layout import Layout
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.validation.mesh3d.links import FIDUCIAL_KINDS, ROBOT_KINDS, LinkModels
from rfp_twin.validation.numerics import pairs_within, peak_and_travel, robot_bases


class Scene:
    """Objects (robots of the trajectory + fiducials), candidate link pairs, kernels' inputs.

    Attributes
    ----------
    robot_ids, fiducial_ids : int64 arrays
    n_robots, n_fiducials : int
    obj_rob : (n_obj,) int64
        Robot index of each object, ``-1`` for a fiducial.
    obj_x, obj_y : (n_obj,) float64
        Bases, mm.
    lp_oa, lp_ka, lp_ob, lp_kb, lp_group : (n_link_pairs,) int64
        Per link pair: object and link kind of each side, and its group.
    groups : (n_groups, 2) int64
        The object pair of each group.
    """

    def __init__(self, traj: Trajectory, layout: Layout, models: LinkModels, min_gap: float):
        ids, base = robot_bases(traj, layout)
        n_r = len(ids)
        fid_xy = np.asarray(layout.fiducial_xy, dtype=np.float64).reshape(-1, 2)
        n_f = len(fid_xy)
        self.robot_ids = ids
        self.fiducial_ids = np.asarray(layout.fiducial_ids, dtype=np.int64)
        self.n_robots, self.n_fiducials = n_r, n_f
        self.obj_rob = np.concatenate([np.arange(n_r), np.full(n_f, -1)]).astype(np.int64)
        xy = np.vstack([base, fid_xy]) if n_r + n_f else np.empty((0, 2))
        self.obj_x = np.ascontiguousarray(xy[:, 0])
        self.obj_y = np.ascontiguousarray(xy[:, 1])
        kinds_of = [ROBOT_KINDS] * n_r + [FIDUCIAL_KINDS] * n_f
        pairs = pairs_within(xy, 2.0 * float(models.reach.max()) + min_gap)
        # robot-robot and robot-fiducial pairs only (fiducials never move)
        pairs = pairs[pairs[:, 0] < n_r]
        rows, groups = [], []
        for i, j in pairs:
            d = float(np.hypot(xy[i, 0] - xy[j, 0], xy[i, 1] - xy[j, 1]))
            kinds = models.link_pairs(kinds_of[i], kinds_of[j], d, min_gap)
            if kinds:
                rows += [(i, ka, j, kb, len(groups)) for ka, kb in kinds]
                groups.append((int(i), int(j)))
        arr = np.asarray(rows, dtype=np.int64).reshape(-1, 5)
        self.lp_oa, self.lp_ka, self.lp_ob, self.lp_kb, self.lp_group = (
            np.ascontiguousarray(arr[:, c]) for c in range(5))
        self.groups = np.asarray(groups, dtype=np.int64).reshape(-1, 2)
        self.n_link_pairs = len(arr)

    def pair_ids(self, g: int) -> tuple[str, int, int]:
        """``(kind, robot id, other id)`` of group ``g`` (kind ``robot`` / ``fiducial``)."""
        i, j = (int(x) for x in self.groups[g])
        if j < self.n_robots:
            return "robot", int(self.robot_ids[i]), int(self.robot_ids[j])
        return "fiducial", int(self.robot_ids[i]), int(self.fiducial_ids[j - self.n_robots])

    def link_speeds(self, models: LinkModels, alpha_csr, beta_csr,
                    span: float) -> tuple[np.ndarray, np.ndarray]:
        """Per object and link kind, the largest and the mean point speed, (n_obj, 4) mm/s.

        ``alpha_csr`` / ``beta_csr``: ``(ptr, times, rate)`` of
        :func:`rfp_twin.validation.numerics.axis_csr`; the mean uses the travel over ``span`` s.
        Fiducials do not move (rows of zeros).
        """
        n_obj, n_r = len(self.obj_rob), self.n_robots
        vglob = np.zeros((n_obj, len(models.reach)))
        vmean = np.zeros((n_obj, len(models.reach)))
        a_max, a_trav = peak_and_travel(*alpha_csr)
        b_max, b_trav = peak_and_travel(*beta_csr)
        vglob[:n_r] = (np.multiply.outer(a_max[:n_r], models.rad_alpha)
                       + np.multiply.outer(b_max[:n_r], models.rad_beta))
        if span > 0:
            vmean[:n_r] = (np.multiply.outer(a_trav[:n_r], models.rad_alpha) / span
                           + np.multiply.outer(b_trav[:n_r], models.rad_beta) / span)
        return vglob, vmean
