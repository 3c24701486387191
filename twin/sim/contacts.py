"""Contact accounting: which robots touch each other (or a fiducial) during a simulation.

At every physics step with contacts the simulator hands MuJoCo's contact list to a
:class:`ContactRecorder`, which keeps the robot-robot and robot-fiducial rows (one per
contact point per step) and, at the end, gives a :class:`ContactLog`.

Units: times in simulated seconds, depths and positions in mm (world frame). Robot and
fiducial ids are the layout's ids; k is the number of contact rows.
"""
from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from rfp_twin.models.mjcf import ModelIndex


@dataclass
class ContactLog:
    """Contacts seen at physics steps (one row per contact point per step).

    time_s (k,) s, robot_a (k,) int64 robot ids, robot_b (k,) int64 robot ids or -1 for a
    fiducial, fiducial (k,) int64 fiducial ids or -1, depth_mm (k,) penetration, mm,
    pos_mm (k, 3) world contact point, mm. In a robot-robot row robot_a < robot_b.
    """

    time_s: np.ndarray
    robot_a: np.ndarray
    robot_b: np.ndarray
    fiducial: np.ndarray
    depth_mm: np.ndarray
    pos_mm: np.ndarray

    @classmethod
    def empty(cls) -> ContactLog:
        z = np.empty(0, dtype=np.int64)
        return cls(np.empty(0), z, z.copy(), z.copy(), np.empty(0), np.empty((0, 3)))

    def __len__(self) -> int:
        return int(self.time_s.size)

    @property
    def robot_robot(self) -> np.ndarray:
        """(k,) bool: rows between two robots."""
        return self.robot_b >= 0

    def pairs(self) -> list[dict]:
        """One summary per touching pair: robots (or robot + fiducial), first and last
        time (s), largest depth (mm), number of contact rows."""
        out = []
        if len(self) == 0:
            return out
        key = np.column_stack([self.robot_a, self.robot_b, self.fiducial])
        uniq, inv = np.unique(key, axis=0, return_inverse=True)
        inv = inv.ravel()
        for k, (a, b, f) in enumerate(uniq):
            rows = inv == k
            item = {"robot_a": int(a), "first_s": float(self.time_s[rows].min()),
                    "last_s": float(self.time_s[rows].max()),
                    "max_depth_mm": float(self.depth_mm[rows].max()), "rows": int(rows.sum())}
            if b >= 0:
                item["robot_b"] = int(b)
            else:
                item["fiducial"] = int(f)
            out.append(item)
        return out


class ContactRecorder:
    """Collects the robot-robot and robot-fiducial rows of MuJoCo's contact lists.

    Parameters
    ----------
    index : the model's :class:`rfp_twin.models.mjcf.ModelIndex` (geom -> robot / fiducial index,
        robot and fiducial ids)
    owned : (n,) bool, optional: for a tile of a tiled twin
        (:mod:`rfp_twin.models.mjcf.tiled_twin`), the robots it owns. A row is kept only
        where the robot with the lower id is owned (a contact across two tiles is seen by
        both; the tile owning the lower id keeps it).
    """

    def __init__(self, index: ModelIndex, owned: np.ndarray | None = None) -> None:
        self._geom_robot, self._geom_fid = index.geom_robot, index.geom_fiducial
        self._robot_ids, self._fid_ids = index.robot_ids, index.fiducial_ids
        self._owned = None if owned is None else np.asarray(owned, dtype=bool)
        self._rows: list[tuple] = []

    def add(self, d: mujoco.MjData, t: float) -> None:
        """Keep the rows of ``d``'s current contact list, stamped ``t`` s."""
        c = d.contact
        g = np.asarray(c.geom).reshape(-1, 2)
        geom_robot, geom_fid = self._geom_robot, self._geom_fid
        ra, rb = geom_robot[g[:, 0]], geom_robot[g[:, 1]]
        fa, fb = geom_fid[g[:, 0]], geom_fid[g[:, 1]]
        rr = (ra >= 0) & (rb >= 0) & (ra != rb)
        rf = ((ra >= 0) & (fb >= 0)) | ((rb >= 0) & (fa >= 0))
        keep = rr | rf
        if self._owned is not None:
            ids = self._robot_ids
            first = np.where(rr & (ids[np.maximum(rb, 0)] < ids[np.maximum(ra, 0)]), rb,
                             np.where(ra >= 0, ra, rb))
            keep &= self._owned[np.maximum(first, 0)]
        if not keep.any():
            return
        robot_ids, fid_ids = self._robot_ids, self._fid_ids
        robot = np.where(ra >= 0, ra, rb)[keep]
        other = np.where(rr, np.where(ra >= 0, rb, ra), -1)[keep]
        fid = np.where(rf, np.maximum(fa, fb), -1)[keep]
        a_id = robot_ids[robot]
        b_id = np.where(other >= 0, robot_ids[np.maximum(other, 0)], -1)
        lo = np.where(b_id >= 0, np.minimum(a_id, b_id), a_id)
        hi = np.where(b_id >= 0, np.maximum(a_id, b_id), -1)
        f_id = np.where(fid >= 0, fid_ids[np.maximum(fid, 0)] if fid_ids.size else -1, -1)
        depth = np.maximum(-np.asarray(c.dist)[keep], 0.0)
        self._rows.append((np.full(lo.size, t), lo, hi, f_id, depth,
                           np.asarray(c.pos).reshape(-1, 3)[keep]))

    def log(self) -> ContactLog:
        """Every row kept so far, in order."""
        if not self._rows:
            return ContactLog.empty()
        cols = list(zip(*self._rows))
        return ContactLog(np.concatenate(cols[0]), np.concatenate(cols[1]).astype(np.int64),
                          np.concatenate(cols[2]).astype(np.int64),
                          np.concatenate(cols[3]).astype(np.int64), np.concatenate(cols[4]),
                          np.vstack(cols[5]))
