"""The poses a recording logs, from the twin's MuJoCo kinematics: one model, or a tiled
twin's tiles (each robot from the tile that owns it, each obstacle once).

Shapes: T samples, n robots (layout order), k traced fibers, k3 fibers of the geometry.
Quaternions (w, x, y, z); positions mm, world frame unless said.
"""
from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from rfp_twin.models.mjcf import TwinModel
from rfp_twin.models.mjcf.tiled_twin import model_tiles


@dataclass
class LinkPoses:
    """Robot link poses over the samples and the robots' static frames.

    base_pos (n, 3), base_quat (n, 4) : each robot frame in the world
    rel_alpha, rel_beta (T, n, 4) : alpha in the robot frame, beta in alpha's
    t_alpha, t_beta (n, 3) : constant offsets of alpha / beta from their parent frames
    tips (T, n, k, 3) : traced fiber tips (NaN where a robot does not carry the fiber)
    fiber_local (n, k3, 3) : every fiber in the beta frame (NaN where not carried); has_fiber (n, k3) bool
    """

    base_pos: np.ndarray
    base_quat: np.ndarray
    rel_alpha: np.ndarray
    rel_beta: np.ndarray
    t_alpha: np.ndarray
    t_beta: np.ndarray
    tips: np.ndarray
    fiber_local: np.ndarray
    has_fiber: np.ndarray


def quat_conj(q: np.ndarray) -> np.ndarray:
    """Conjugate of (..., 4) quaternions (w, x, y, z)."""
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product of (..., 4) quaternions (w, x, y, z), broadcast."""
    aw, ax, ay, az = np.moveaxis(a, -1, 0)
    bw, bx, by, bz = np.moveaxis(b, -1, 0)
    return np.stack([aw * bw - ax * bx - ay * by - az * bz,
                     aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw], axis=-1)


def model_poses(twin: TwinModel, angles: np.ndarray, trace_cols: list[int]) -> LinkPoses:
    """:class:`LinkPoses` of one MuJoCo model at ``angles`` (T, n, 2) deg."""
    m, idx = twin.model, twin.index
    d = mujoco.MjData(m)
    T, n = angles.shape[:2]
    q_alpha = np.empty((T, n, 4))
    q_beta = np.empty((T, n, 4))
    tips = np.empty((T, n, len(trace_cols), 3))
    qadr = idx.qpos_adr.ravel()
    sites = idx.fiber_site[:, trace_cols]
    for k in range(T):
        d.qpos[qadr] = np.radians(angles[k]).ravel()
        mujoco.mj_kinematics(m, d)
        q_alpha[k] = d.xquat[idx.alpha_body]
        q_beta[k] = d.xquat[idx.beta_body]
        tips[k] = d.site_xpos[sites]
    tips[:, ~(sites >= 0)] = np.nan
    q_base = d.xquat[idx.base_body].copy()
    fiber_local = np.asarray(m.site_pos)[idx.fiber_site].copy()
    fiber_local[idx.fiber_site < 0] = np.nan
    return LinkPoses(
        base_pos=d.xpos[idx.base_body].copy(), base_quat=q_base,
        rel_alpha=quat_mul(quat_conj(q_base)[None], q_alpha),
        rel_beta=quat_mul(quat_conj(q_alpha), q_beta),
        t_alpha=np.asarray(m.body_pos)[idx.alpha_body].copy(),
        t_beta=np.asarray(m.body_pos)[idx.beta_body].copy(), tips=tips,
        fiber_local=fiber_local, has_fiber=idx.fiber_site >= 0)


#: LinkPoses fields indexed by time first.
TIME_MAJOR = ("rel_alpha", "rel_beta", "tips")


def _rows(p: LinkPoses, rows: np.ndarray) -> LinkPoses:
    """The robots ``rows`` of ``p``."""
    return LinkPoses(**{f: (getattr(p, f)[:, rows] if f in TIME_MAJOR else getattr(p, f)[rows])
                        for f in LinkPoses.__dataclass_fields__})


def iter_link_poses(twin, angles: np.ndarray, trace_cols: list[int]):
    """Yield ``(robots, LinkPoses)`` part by part at ``angles`` (T, n, 2) deg: all robots
    of a :class:`TwinModel` at once, or each tile's own robots of a tiled twin (so that
    only one tile's poses are held at a time). ``robots`` (r,) are layout robot indices."""
    for t in model_tiles(twin):
        local = model_poses(t.twin, angles[:, t.robots], trace_cols)
        yield t.robots[t.owned], local if t.owned.all() else _rows(local, np.flatnonzero(t.owned))


def link_poses(twin, angles: np.ndarray, trace_cols: list[int]) -> LinkPoses:
    """:class:`LinkPoses` of every robot of a :class:`TwinModel` or a tiled twin at
    ``angles`` (T, n, 2) deg, in layout order."""
    parts = list(iter_link_poses(twin, angles, trace_cols))
    order = np.argsort(np.concatenate([r for r, _ in parts]))
    out = {}
    for f in LinkPoses.__dataclass_fields__:
        axis = 1 if f in TIME_MAJOR else 0
        out[f] = np.take(np.concatenate([getattr(p, f) for _, p in parts], axis=axis), order,
                         axis=axis)
    return LinkPoses(**out)


def model_parts(twin):
    """(model, data at rest, index) of each MuJoCo model of the twin (one, or one per tile),
    for the static parts (obstacles, plate)."""
    out = []
    for tw in (t.twin for t in model_tiles(twin)):
        d = mujoco.MjData(tw.model)
        mujoco.mj_kinematics(tw.model, d)
        out.append((tw.model, d, tw.index))
    return out
