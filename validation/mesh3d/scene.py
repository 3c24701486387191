"""The objects of a 3D check and their candidate link pairs (mm, mm/s).

Objects are the robots of the trajectory (in trajectory order) followed by the
obstacles of the layout (fiducial posts and guide-camera walls). Links ``A`` of object
``i`` and ``B`` of object ``j`` (``i != j``) can touch only if their z intervals come
within ``min_gap_mm`` and ``|b_i - b_j| <= reach_A + reach_B + min_gap_mm``
(:meth:`LinkModels.can_touch`). A robot's own links are never paired (they are joined by
the joints), nor are two obstacles (they never move). Link pairs of one object pair form a
*group*: a row of the report.

Per-robot geometry (:func:`rfp_twin.validation.mesh3d.links.placement`; nominal layouts
skip all of this and give the kernels exactly the arrays they always had). Each object
has its own alpha arm and base height. The kernels bound distances of *upright* links
(rotations about z), so every link pair is posed in one frame: a robot pair's in the frame
of its first robot (which is then exact; a beta arm of the first against the wider, lower
alpha or body of the second: in the second's frame), a robot-obstacle pair's in the world
frame (the obstacle is exact). The other robot is an extra *virtual* object, posed upright at its
base ``c`` in that frame (pivoting on its axis at :attr:`Scene.pivot_z`). With ``A =
R_frame^T R_robot - I`` (the relative rotation less the identity), a point posed at ``p``
truly is at ``p + A (p - c)``: horizontally within ``s_xy = |A_xy,xy| rho + |A_xy,z| w``
(``rho``, ``w``: the link's reach and height around the pivot; spectral norms of the
blocks), vertically at ``A_z,xy . (p - c)_xy`` (the kernels' height plane, exact for each
posed piece) within ``|A_zz| w``. Neighbouring robots of a curved wok are tilted alike, so
these are hundredths of a mm. FCL computes exact distances with the true world transforms
(:meth:`Scene.world_frames`). Candidate link pairs bound the plane by ``|A_z,xy| rho``.
"""
from __future__ import annotations

import math

import numpy as np

from rfp_twin.models.geometry import LINKS
from rfp_twin.models.layout import Layout
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.validation.mesh3d.bounds import BETA
from rfp_twin.validation.mesh3d.links import (FIDUCIAL_KINDS, ROBOT_KINDS, WALL_Z_MARGIN_MM,
                                              LinkModels, Placement, link_frames, placement,
                                              wall_mesh)
from rfp_twin.validation.numerics import (REACH_TOL_MM, pairs_within, peak_and_travel,
                                          robot_bases, segment_distance_np)

#: Added to each nonzero slack against rounding, mm.
SLACK_EPS_MM = 1e-9


class Scene:
    """Objects (robots of the trajectory + obstacles), candidate link pairs, kernels' inputs.

    Attributes
    ----------
    robot_ids, fiducial_ids : int64 arrays (``fiducial_ids``: every obstacle of the layout)
    n_robots, n_fiducials : int
    models : LinkModels
        The link models of the check: the given ones, plus one kind per wall.
    place : float or tuple
        The kernels' alpha-arm argument (:mod:`rfp_twin.validation.mesh3d.bounds`): the
        models' alpha arm on nominal layouts, else ``(obj_la, obj_z, lp_slack)``.
    placed : bool
        True when the layout has per-robot geometry or walls (``place`` is a tuple).
    obj_rob : (n_obj,) int64
        Robot index of each object, ``-1`` for an obstacle.
    obj_x, obj_y : (n_obj,) float64
        Bases, mm (in the frame of the object's groups; world for the real objects).
    obj_real : (n_obj,) int64
        The real object (robot index, or ``n_robots`` + obstacle index) of each object.
    lp_oa, lp_ka, lp_ob, lp_kb, lp_group : (n_link_pairs,) int64
        Per link pair: object and link kind of each side, and its group.
    groups : (n_groups, 2) int64
        The (real) object pair of each group.
    rad_alpha, rad_beta : (K,) float64
        Speed radii for the kernels: the models', with the longest alpha arm of the check
        (times the largest ``1 + |g|`` of a height plane, see
        :mod:`rfp_twin.validation.mesh3d.bounds`).
    real_base, real_rot, real_la : per real object (placed scenes): frame origin (3,) mm,
        axis rotation (3, 3), alpha arm mm; ``pivot_z`` mm, where posed robots pivot.
    """

    def __init__(self, traj: Trajectory, layout: Layout, models: LinkModels, min_gap: float):
        ids, base = robot_bases(traj, layout)
        self.robot_ids = ids
        self.fiducial_ids = np.asarray(layout.fiducial_ids, dtype=np.int64)
        self.n_robots, self.n_fiducials = len(ids), len(self.fiducial_ids)
        pl = placement(layout, models)
        self.placed = pl is not None
        if pl is None:
            self._nominal(base, layout, models, min_gap)
        else:
            self._placed(layout.robot_indices(ids) if len(ids) else np.empty(0, np.int64),
                         pl, models, min_gap)

    # -- nominal layouts: the kernels' inputs as they always were ----------------------------
    def _nominal(self, base, layout: Layout, models: LinkModels, min_gap: float) -> None:
        n_r = len(base)
        fid_xy = np.asarray(layout.fiducial_xy, dtype=np.float64).reshape(-1, 2)
        n_f = len(fid_xy)
        self.models, self.place = models, models.l_alpha
        self.rad_alpha, self.rad_beta = models.rad_alpha, models.rad_beta
        self.obj_rob = np.concatenate([np.arange(n_r), np.full(n_f, -1)]).astype(np.int64)
        self.obj_real = np.arange(n_r + n_f, dtype=np.int64)
        self.obj_dla = np.zeros(n_r + n_f)
        xy = np.vstack([base, fid_xy]) if n_r + n_f else np.empty((0, 2))
        self.obj_x = np.ascontiguousarray(xy[:, 0])
        self.obj_y = np.ascontiguousarray(xy[:, 1])
        pairs = pairs_within(xy, 2.0 * float(models.reach.max()) + min_gap)
        # robot-robot and robot-fiducial pairs only (fiducials never move); the link
        # pairs by the placed scenes' rule (:meth:`_rows`) with flat bases, nominal
        # alpha arms and no slack
        pairs = pairs[pairs[:, 0] < n_r].astype(np.int64).reshape(-1, 2)
        n = len(xy)
        self._o = {"base": np.column_stack([xy, np.zeros(n)]), "la": np.full(n, models.l_alpha),
                   "slack": np.zeros((n, len(models.reach), 3))}
        rr = pairs[:, 1] < n_r
        i, j = pairs[rr].T
        fi, fj = pairs[~rr].T
        self._set_row_parts([self._rows(i, j, i, ROBOT_KINDS, j, ROBOT_KINDS, min_gap),
                             self._rows(fi, fj, fi, ROBOT_KINDS, fj, FIDUCIAL_KINDS, min_gap)])
        del self._o

    def _set_row_parts(self, parts: list) -> np.ndarray:
        """:meth:`_set_pairs` from :meth:`_rows` parts: one group per pair of real objects
        (in increasing order), its link pairs together. Returns their slacks (r, 3)."""
        gi, gj, oa, ka, ob, kb, sl = (np.concatenate([q[c] for q in parts]) for c in range(7))
        keys, inv = np.unique(np.column_stack([gi, gj]).astype(np.int64).reshape(-1, 2),
                              axis=0, return_inverse=True)
        inv = inv.reshape(-1)
        order = np.argsort(inv, kind="stable")
        self._set_pairs(np.column_stack([oa, ka, ob, kb, inv])[order], keys)
        return sl[order]

    def _set_pairs(self, rows, groups) -> None:
        arr = np.asarray(rows, dtype=np.int64).reshape(-1, 5)
        self.lp_oa, self.lp_ka, self.lp_ob, self.lp_kb, self.lp_group = (
            np.ascontiguousarray(arr[:, c]) for c in range(5))
        self.groups = np.asarray(groups, dtype=np.int64).reshape(-1, 2)
        self.n_link_pairs = len(arr)

    # -- per-robot geometry ------------------------------------------------------------------
    def _placed(self, ridx: np.ndarray, pl: Placement, models: LinkModels, min_gap: float) -> None:
        n_r, n_f = len(ridx), len(pl.obs_a)
        walls = np.flatnonzero(pl.wall)
        zb = models.zrange[BETA]
        wz = (zb[0] - WALL_Z_MARGIN_MM, zb[1] + WALL_Z_MARGIN_MM)
        hw = float(models.geometry.params.fiducial_radius_mm)
        m = self.models = models.with_walls([wall_mesh(pl.obs_a[f], pl.obs_b[f], hw, wz)
                                             for f in walls])
        obs_kind = np.full(n_f, FIDUCIAL_KINDS[0], dtype=np.int64)
        obs_kind[walls] = len(LINKS) + np.arange(len(walls))
        # real objects: robots (each in its own frame), obstacles (world)
        self.real_base = np.vstack([pl.base[ridx], np.column_stack([pl.obs_a, pl.obs_z])]
                                   ).reshape(-1, 3)
        self.real_rot = np.concatenate([pl.rot[ridx], np.tile(np.eye(3), (n_f, 1, 1))]
                                       ).reshape(-1, 3, 3)
        self.real_la = np.concatenate([pl.alpha_len[ridx], np.zeros(n_f)])
        self.pivot_z = float(zb.mean())
        n = n_r + n_f
        self._o = {"base": self.real_base.copy(), "la": self.real_la.copy(),
                   "rob": np.concatenate([np.arange(n_r), np.full(n_f, -1)]).astype(np.int64),
                   "real": np.arange(n, dtype=np.int64), "slack": np.zeros((n, len(m.reach), 3)),
                   "g": np.zeros((n, 2))}
        tilted = np.asarray(pl.tilted[ridx], dtype=bool)
        world = np.arange(n_r, dtype=np.int64)          # each robot posed in the world frame
        world[tilted] = self._posed(np.flatnonzero(tilted), np.full(int(tilted.sum()), -1))
        parts = [self._robot_pairs(n_r, obs_kind, tilted, world, min_gap),
                 self._wall_pairs(n_r, walls, obs_kind, pl, world, min_gap)]
        slack = self._set_row_parts(parts)
        o = self._o
        self.obj_x = np.ascontiguousarray(o["base"][:, 0])
        self.obj_y = np.ascontiguousarray(o["base"][:, 1])
        self.obj_rob, self.obj_real = o["rob"], o["real"]
        self.obj_dla = np.where(self.obj_rob >= 0, o["la"] - m.l_alpha, 0.0)
        g = o["g"]
        z0 = o["base"][:, 2] - (g[:, 0] * o["base"][:, 0] + g[:, 1] * o["base"][:, 1])
        self.place = (np.ascontiguousarray(o["la"]), np.ascontiguousarray(z0),
                      np.ascontiguousarray(slack[:, [0, 2]], dtype=np.float64),
                      np.ascontiguousarray(g))
        # a bound with a height plane of slope |g| moves at most (1 + |g|) times as fast
        self.obj_speed_scale = 1.0 + np.hypot(g[:, 0], g[:, 1])
        scale = float(self.obj_speed_scale.max(initial=1.0))
        self.rad_alpha = m.rad_alpha.copy()
        self.rad_alpha[BETA] += max(0.0, float(self.obj_dla.max(initial=0.0)))
        self.rad_alpha = self.rad_alpha * scale
        self.rad_beta = m.rad_beta * scale
        del self._o

    def _robot_pairs(self, n_r, obs_kind, tilted, world, min_gap) -> tuple:
        """Link pairs of a robot with a robot (frame of the first) or with a fiducial post
        (world frame): arrays (i, j, oa, ka, ob, kb, slack) of :meth:`_rows`."""
        m = self.models
        real = np.concatenate([np.arange(n_r), np.flatnonzero(obs_kind < len(LINKS)) + n_r])
        cut = 2.0 * (float(m.reach[:len(LINKS)].max()) + self._longer(n_r)) + min_gap
        if tilted.any():
            # bases far apart in the world can be closer in a tilted pair frame: widen
            phi = self._max_tilt(n_r)
            span = float(np.ptp(self.real_base[:, 2]))
            cut = (cut + 2.0 * self._slack_bound(n_r) + span + 1.0) / max(1.0 - 2.0 * phi, 0.5)
        pairs = real[pairs_within(self.real_base[real, :2], cut)].reshape(-1, 2)
        pairs = pairs[pairs[:, 0] < n_r]
        rr = pairs[:, 1] < n_r
        i, j = pairs[rr, 0], pairs[rr, 1]
        # a robot pair in the frame of robot i (j posed there), except a beta arm of i
        # against the wider, lower links of j (alpha, body): frame of j (i posed there)
        ob = j.copy()
        own = tilted[i]
        ob[own] = self._posed(j[own], i[own])
        ob[~own & tilted[j]] = world[j[~own & tilted[j]]]
        oa = i.copy()
        own = tilted[j]
        oa[own] = self._posed(i[own], j[own])
        oa[~own & tilted[i]] = world[i[~own & tilted[i]]]
        in_i = self._rows(i, j, i, ROBOT_KINDS, ob, ROBOT_KINDS, min_gap)
        in_j = self._rows(i, j, oa, ROBOT_KINDS, j, ROBOT_KINDS, min_gap)

        def frame_j(rows):
            return (rows[3] == BETA) & (rows[5] != BETA)

        out = [tuple(c[~frame_j(in_i)] for c in in_i), tuple(c[frame_j(in_j)] for c in in_j)]
        i, j = pairs[~rr, 0], pairs[~rr, 1]
        out.append(self._rows(i, j, world[i], ROBOT_KINDS, j, FIDUCIAL_KINDS, min_gap))
        return tuple(np.concatenate([q[c] for q in out]) for c in range(7))

    def _wall_pairs(self, n_r, walls, obs_kind, pl, world, min_gap) -> tuple:
        """Link pairs of a robot's beta arm with a wall (world frame; a wall's points are
        within ``sqrt(2) * half_width`` of its segment): arrays as :meth:`_robot_pairs`."""
        m = self.models
        r_wall = math.sqrt(2.0) * float(m.geometry.params.fiducial_radius_mm)
        reach = m.reach[BETA] + (self.real_la[:n_r] - m.l_alpha)
        far = 2.0 * self._slack_bound(n_r) + 1.0
        xy = self.real_base[:n_r, :2]
        out = [self._rows(*(np.zeros(0, np.int64),) * 3, (BETA,), np.zeros(0, np.int64),
                          (FIDUCIAL_KINDS[0],), min_gap)]
        for f in walls:
            a = np.broadcast_to(pl.obs_a[f], xy.shape)
            b = np.broadcast_to(pl.obs_b[f], xy.shape)
            i = np.flatnonzero(segment_distance_np(xy, xy, a, b)
                               <= reach + r_wall + min_gap + far)
            oa = world[i]
            p = self._o["base"][oa, :2]
            dist = segment_distance_np(p, p, a[:len(p)], b[:len(p)])
            j = np.full(len(i), n_r + int(f), dtype=np.int64)
            out.append(self._rows(i, j, oa, (BETA,), j, (int(obs_kind[f]),), min_gap, dist,
                                  r_wall))
        return tuple(np.concatenate([q[c] for q in out]) for c in range(7))

    def _longer(self, n_r) -> float:
        """How much longer than the models' the longest alpha arm of the robots is, mm."""
        return max(0.0, float((self.real_la[:n_r] - self.models.l_alpha).max(initial=0.0)))

    def _max_tilt(self, n_r) -> float:
        """Largest tilt angle of the robots, rad."""
        if not n_r:
            return 0.0
        return float(np.arccos(np.clip(self.real_rot[:n_r, 2, 2], -1.0, 1.0)).max())

    def _slack_bound(self, n_r) -> float:
        """An upper bound of any one slack of the check, mm (relative rotations of at most
        twice the largest tilt)."""
        m = self.models
        w = float(np.abs(m.zrange[:len(LINKS)] - self.pivot_z).max())
        return 2.0 * self._max_tilt(n_r) * (float(m.reach[:len(LINKS)].max())
                                            + self._longer(n_r) + w)

    def _posed(self, r: np.ndarray, frame: np.ndarray) -> np.ndarray:
        """New virtual objects (their indices): robots ``r`` (k,) posed upright in the frames
        of robots ``frame`` (k,) (``-1``: the world), pivoting at :attr:`pivot_z` on their
        axes; their slacks per link kind (:meth:`_slacks`)."""
        r = np.asarray(r, dtype=np.int64)
        frame = np.asarray(frame, dtype=np.int64)
        if not len(r):
            return np.zeros(0, dtype=np.int64)
        rot_f = np.where((frame >= 0)[:, None, None], self.real_rot[np.maximum(frame, 0)],
                         np.eye(3))
        rel = np.einsum("kji,kjl->kil", rot_f, self.real_rot[r])
        base = self.real_base[r]
        f = frame >= 0
        if f.any():
            fb = self.real_base[frame[f]]
            base = base.copy()
            base[f] = fb + np.einsum("kji,kj->ki", rot_f[f], base[f] - fb)
        c = base + (rel - np.eye(3))[:, :, 2] * self.pivot_z
        o = self._o
        start = len(o["la"])
        o["base"] = np.vstack([o["base"], c])
        o["la"] = np.concatenate([o["la"], self.real_la[r]])
        o["rob"] = np.concatenate([o["rob"], r])
        o["real"] = np.concatenate([o["real"], r])
        o["slack"] = np.concatenate([o["slack"], self._slacks(rel, self.real_la[r])])
        o["g"] = np.vstack([o["g"], rel[:, 2, :2]])
        return start + np.arange(len(r), dtype=np.int64)

    def _slacks(self, rel: np.ndarray, la: np.ndarray) -> np.ndarray:
        """(k, K, 3) slacks ``(s_xy, s_z, s_zz)`` mm per link kind of robots with alpha arms
        ``la`` (k,) posed upright in frames rotated by ``rel`` (k, 3, 3) from their own:
        horizontal; vertical in all (for candidates); vertical beyond the height plane."""
        m = self.models
        a = rel - np.eye(3)
        rho = m.reach[None, :] + np.multiply.outer(la - m.l_alpha, np.arange(len(m.reach)) == BETA)
        w = np.abs(m.zrange - self.pivot_z).max(axis=1)
        n_hh = np.linalg.norm(a[:, :2, :2], ord=2, axis=(1, 2))[:, None]
        n_hz = np.linalg.norm(a[:, :2, 2], axis=1)[:, None]
        n_zh = np.linalg.norm(a[:, 2, :2], axis=1)[:, None]
        n_zz = np.abs(a[:, 2, 2])[:, None]
        return np.stack([n_hh * rho + n_hz * w, n_zh * rho + n_zz * w,
                         np.broadcast_to(n_zz * w, rho.shape)], axis=-1)

    def _rows(self, i, j, oa, kinds_a, ob, kinds_b, min_gap: float, dist=None,
              reach_b: float | None = None) -> tuple:
        """The link pairs ``kinds_a x kinds_b`` that can touch of the groups (real objects
        ``i``, ``j`` (G,), posed as objects ``oa``, ``ob`` (G,)): arrays (i, j, oa, ka, ob,
        kb, slack (r, 3): :meth:`_slacks` of both sides). For a wall, ``dist`` (G,) from ``oa``'s base to its segment and
        ``reach_b`` its points' distance from it replace the base distance and its reach."""
        m, o = self.models, self._o
        ka, kb = np.asarray(kinds_a, dtype=np.int64), np.asarray(kinds_b, dtype=np.int64)
        oa, ob = np.asarray(oa, dtype=np.int64), np.asarray(ob, dtype=np.int64)
        sl = o["slack"][oa][:, ka][:, :, None, :] + o["slack"][ob][:, kb][:, None, :, :]
        sl = sl + np.where(sl > 0.0, SLACK_EPS_MM, 0.0)
        za = m.zrange[ka][None] + o["base"][oa, 2][:, None, None]
        zb = m.zrange[kb][None] + o["base"][ob, 2][:, None, None]
        dz = np.maximum(0.0, np.maximum(za[:, :, None, 0] - zb[:, None, :, 1],
                                        zb[:, None, :, 0] - za[:, :, None, 1])) - sl[..., 1]
        is_beta = lambda k: (k == BETA).astype(np.float64)  # noqa: E731
        ra = m.reach[ka][None] + np.multiply.outer(o["la"][oa] - m.l_alpha, is_beta(ka))
        rb = m.reach[kb][None] + np.multiply.outer(o["la"][ob] - m.l_alpha, is_beta(kb)) \
            if reach_b is None else np.full((len(ob), len(kb)), float(reach_b))
        d = np.hypot(*(o["base"][oa, :2] - o["base"][ob, :2]).T) if dist is None \
            else np.asarray(dist, dtype=np.float64)
        ok = (dz <= min_gap + REACH_TOL_MM) & (d[:, None, None] <= ra[:, :, None] + rb[:, None, :]
                                               + min_gap + sl[..., 0] + REACH_TOL_MM)
        g, x, y = np.nonzero(ok)
        return (np.asarray(i)[g], np.asarray(j)[g], oa[g], ka[x], ob[g], kb[y],
                sl[g, x, y].reshape(-1, 3))

    # -- reporting and exact distances -------------------------------------------------------
    def pair_ids(self, g: int) -> tuple[str, int, int]:
        """``(kind, robot id, other id)`` of group ``g`` (kind ``robot`` / ``fiducial``: any
        obstacle, a fiducial post or a guide-camera wall)."""
        i, j = (int(x) for x in self.groups[g])
        if j < self.n_robots:
            return "robot", int(self.robot_ids[i]), int(self.robot_ids[j])
        return "fiducial", int(self.robot_ids[i]), int(self.fiducial_ids[j - self.n_robots])

    def world_frames(self, objs, kinds, alpha_rad, beta_rad) -> tuple[np.ndarray, np.ndarray]:
        """True world transforms ``(R (n, 3, 3), t (n, 3))`` of links ``kinds`` (n,) of
        objects ``objs`` (n,) at joint angles (n,) rad (:func:`link_frames`; placed
        scenes only: z relative to the nominal robot frame)."""
        real = self.obj_real[np.asarray(objs, dtype=np.int64)]
        return link_frames(self.models, kinds, self.real_base[real], self.real_rot[real],
                           self.real_la[real], alpha_rad, beta_rad)

    def link_speeds(self, models: LinkModels, alpha_csr, beta_csr,
                    span: float) -> tuple[np.ndarray, np.ndarray]:
        """Per object and link kind, the largest and the mean point speed, (n_obj, K) mm/s.

        ``alpha_csr`` / ``beta_csr``: ``(ptr, times, rate)`` of
        :func:`rfp_twin.validation.numerics.axis_csr`; the mean uses the travel over ``span`` s.
        Obstacles do not move (rows of zeros). ``models``' radii, with each robot's own
        alpha arm on the beta link.
        """
        n_obj, n_r = len(self.obj_rob), self.n_robots
        vglob = np.zeros((n_obj, len(models.reach)))
        vmean = np.zeros((n_obj, len(models.reach)))
        a_max, a_trav = peak_and_travel(*alpha_csr)
        b_max, b_trav = peak_and_travel(*beta_csr)
        if not self.placed:
            vglob[:n_r] = (np.multiply.outer(a_max[:n_r], models.rad_alpha)
                           + np.multiply.outer(b_max[:n_r], models.rad_beta))
            if span > 0:
                vmean[:n_r] = (np.multiply.outer(a_trav[:n_r], models.rad_alpha) / span
                               + np.multiply.outer(b_trav[:n_r], models.rad_beta) / span)
            return vglob, vmean
        rows = np.flatnonzero(self.obj_rob >= 0)
        r = self.obj_rob[rows]
        scale = self.obj_speed_scale[rows, None]
        rad_a = (models.rad_alpha[None, :] + np.multiply.outer(
            self.obj_dla[rows], np.arange(len(models.reach)) == BETA)) * scale
        rad_b = models.rad_beta[None, :] * scale
        vglob[rows] = a_max[r, None] * rad_a + b_max[r, None] * rad_b
        if span > 0:
            vmean[rows] = (a_trav[r, None] * rad_a + b_trav[r, None] * rad_b) / span
        return vglob, vmean
