"""The obstacle-time set of Sabater et al. 2018 (Sect. 5.1) for probe arms, and its check.

The arms planned so far are sampled once on the collision-check clock (every ``dt_col``
from t = 0): their five capsules in the world frame at each tick, and a bounding circle
per arm and tick for a quick rejection; after its last breakpoint an arm holds its
goal. ``Collision(q, t)`` (Sect. 4.1) for the arm being planned is then
:func:`collides_many`: its capsules at ``q``, against every sampled arm at the tick of
``t``. Two arms touch when a pair of their capsules is at most the sum of the radii plus
both arms' safety buffers apart (``2 * buffer_mm``).

Units: mm, deg, s. Arrays: ``obs`` (n_ticks, n_obs, 5, 5) capsules ``(x0, y0, x1, y1,
r)``, ``circ`` (n_ticks, n_obs, 3) circles ``(x, y, r)``; ``frame`` (4,) ``(x, y, cos,
sin)`` of the planned arm's frame.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from rfp_twin.models.geometry2d import segment_distance
from rfp_twin.models.kinds.probe_kinematics import pose_capsules

@njit(cache=True, inline="always")
def _world_capsules(t1_deg, t2_deg, links, sizes, frame, out):
    """The five capsules of one pose in the world (``out`` (5, 5)) and their bounding
    circle ``(cx, cy, r)``."""
    pose_capsules(t1_deg, t2_deg, links, sizes, out)
    bx, by, c, s = frame[0], frame[1], frame[2], frame[3]
    cx = 0.0
    cy = 0.0
    for b in range(5):
        for e in range(2):
            x, y = out[b, 2 * e], out[b, 2 * e + 1]
            out[b, 2 * e] = bx + c * x - s * y
            out[b, 2 * e + 1] = by + s * x + c * y
            cx += out[b, 2 * e]
            cy += out[b, 2 * e + 1]
    cx /= 10.0
    cy /= 10.0
    rad = 0.0
    for b in range(5):
        for e in range(2):
            d = math.hypot(out[b, 2 * e] - cx, out[b, 2 * e + 1] - cy) + out[b, 4]
            if d > rad:
                rad = d
    return cx, cy, rad


@njit(cache=True)
def sample_world(times, configs, n_ticks, dt_col, links, sizes, frame):
    """One arm's capsules and circle at ticks ``0 .. n_ticks - 1`` of ``dt_col`` s, its
    breakpoints ``times`` (k,) s / ``configs`` (k, 2) deg linearly interpolated and held
    after the last one: ``(caps (n_ticks, 5, 5), circ (n_ticks, 3))``."""
    caps = np.empty((n_ticks, 5, 5))
    circ = np.empty((n_ticks, 3))
    k_n = times.shape[0]
    j = 0
    for i in range(n_ticks):
        t = i * dt_col
        while j < k_n - 2 and times[j + 1] <= t:
            j += 1
        if t <= times[0] or k_n == 1:
            q0, q1 = configs[0, 0], configs[0, 1]
        elif t >= times[k_n - 1]:
            q0, q1 = configs[k_n - 1, 0], configs[k_n - 1, 1]
        else:
            f = (t - times[j]) / (times[j + 1] - times[j])
            q0 = configs[j, 0] + f * (configs[j + 1, 0] - configs[j, 0])
            q1 = configs[j, 1] + f * (configs[j + 1, 1] - configs[j, 1])
        cx, cy, r = _world_capsules(q0, q1, links, sizes, frame, caps[i])
        circ[i, 0], circ[i, 1], circ[i, 2] = cx, cy, r
    return caps, circ


@njit(cache=True, inline="always")
def _pair_min_gap(a, b, pad):
    """Smallest ``distance - r_a - r_b - pad`` over the capsule pairs of two arms."""
    best = np.inf
    for i in range(a.shape[0]):
        for j in range(b.shape[0]):
            d = segment_distance(a[i, 0], a[i, 1], a[i, 2], a[i, 3],
                                 b[j, 0], b[j, 1], b[j, 2], b[j, 3]) - a[i, 4] - b[j, 4] - pad
            if d < best:
                best = d
    return best


@njit(cache=True)
def collides_many(q, t, links, sizes, frame, obs, circ, dt_col, pad):
    """(m,) bool: does the arm at ``q[k]`` (deg) touch a sampled arm at time ``t[k]`` s?

    Touch = some capsule pair at most ``r_a + r_b + pad`` mm apart (``pad`` = both
    safety buffers). Times map to the nearest tick, beyond the last one the last.
    """
    m = q.shape[0]
    n_ticks, n_obs = obs.shape[0], obs.shape[1]
    out = np.zeros(m, dtype=np.bool_)
    own = np.empty((5, 5))
    for k in range(m):
        cx, cy, r = _world_capsules(q[k, 0], q[k, 1], links, sizes, frame, own)
        i = int(t[k] / dt_col + 0.5)
        if i >= n_ticks:
            i = n_ticks - 1
        if i < 0:
            i = 0
        for j in range(n_obs):
            if math.hypot(circ[i, j, 0] - cx, circ[i, j, 1] - cy) > circ[i, j, 2] + r + pad:
                continue
            if _pair_min_gap(own, obs[i, j], pad) <= 0.0:
                out[k] = True
                break
    return out


@njit(cache=True)
def pose_gaps(q, links, sizes, frames, pad):
    """(n, n) smallest capsule gap (``distance - r_a - r_b - pad``, mm) between every two
    arms at poses ``q`` (n, 2) deg in ``frames`` (n, 4); inf on the diagonal."""
    n = q.shape[0]
    caps = np.empty((n, 5, 5))
    for a in range(n):
        _world_capsules(q[a, 0], q[a, 1], links, sizes, frames[a], caps[a])
    out = np.full((n, n), np.inf)
    for a in range(n):
        for b in range(a + 1, n):
            g = _pair_min_gap(caps[a], caps[b], pad)
            out[a, b] = g
            out[b, a] = g
    return out


@njit(cache=True)
def arm_gaps(q, i, links, sizes, frames, pad):
    """(n,) smallest capsule gap (mm, as :func:`pose_gaps`) between arm ``i`` and every
    arm at poses ``q`` (n, 2) deg; inf for ``i`` itself."""
    n = q.shape[0]
    own = np.empty((5, 5))
    other = np.empty((5, 5))
    _world_capsules(q[i, 0], q[i, 1], links, sizes, frames[i], own)
    out = np.full(n, np.inf)
    for b in range(n):
        if b != i:
            _world_capsules(q[b, 0], q[b, 1], links, sizes, frames[b], other)
            out[b] = _pair_min_gap(own, other, pad)
    return out


@njit(cache=True)
def trajectories_touch(caps_a, circ_a, caps_b, circ_b, pad):
    """Do two sampled arms touch at some tick? ``caps_*`` (T, 5, 5), ``circ_*`` (T, 3) as
    :func:`sample_world` returns them (same clock)."""
    for i in range(caps_a.shape[0]):
        if math.hypot(circ_a[i, 0] - circ_b[i, 0], circ_a[i, 1] - circ_b[i, 1]) > \
                circ_a[i, 2] + circ_b[i, 2] + pad:
            continue
        if _pair_min_gap(caps_a[i], caps_b[i], pad) <= 0.0:
            return True
    return False


#: Where an obstacle that has left is put, mm (far from any bench).
FAR_MM = 1.0e9


class ObstacleTime:
    """The arms planned so far, sampled on the ``dt_col`` clock up to ``horizon_s``."""

    def __init__(self, kind, dt_col: float, horizon_s: float) -> None:
        self.kind = kind
        self.dt_col = float(dt_col)
        self.n_ticks = int(math.ceil(horizon_s / dt_col - 1e-9)) + 1
        self.frames = kind.frames()
        self.pad = 2.0 * kind.spec.buffer_mm
        self.obs = np.empty((self.n_ticks, 0, 5, 5))
        self.circ = np.empty((self.n_ticks, 0, 3))
        self.members: list[int] = []

    def sample(self, arm: int, times: np.ndarray, configs: np.ndarray):
        """Arm ``arm`` along breakpoints ``times`` (k,) s, ``configs`` (k, 2) deg on this
        set's clock: ``(caps (n_ticks, 5, 5), circ (n_ticks, 3))``."""
        return sample_world(np.ascontiguousarray(times, dtype=np.float64),
                            np.ascontiguousarray(configs, dtype=np.float64), self.n_ticks,
                            self.dt_col, self.kind.links, self.kind.sizes, self.frames[arm])

    def add(self, arm: int, times: np.ndarray, configs: np.ndarray) -> None:
        """Add arm ``arm`` moving along breakpoints ``times`` (k,) s, ``configs`` (k, 2) deg."""
        self.add_sampled(arm, *self.sample(arm, times, configs))

    def add_until(self, arm: int, q: np.ndarray, until_s: float) -> None:
        """Add arm ``arm`` standing at pose ``q`` (2,) deg up to ``until_s`` s and absent
        after it (an arm not yet planned that is expected to have left by then)."""
        caps, circ = self.sample(arm, np.zeros(1), np.asarray(q, dtype=np.float64)[None, :])
        gone = np.arange(self.n_ticks) * self.dt_col > until_s + 1e-9
        caps[gone] = FAR_MM
        caps[gone, :, 4] = 0.0
        circ[gone] = (FAR_MM, FAR_MM, 0.0)
        self.add_sampled(arm, caps, circ)

    def add_sampled(self, arm: int, caps: np.ndarray, circ: np.ndarray) -> None:
        """Add arm ``arm`` already sampled by :meth:`sample`."""
        self.obs = np.ascontiguousarray(np.concatenate([self.obs, caps[:, None]], axis=1))
        self.circ = np.ascontiguousarray(np.concatenate([self.circ, circ[:, None]], axis=1))
        self.members.append(arm)

    def collides(self, arm: int, q: np.ndarray, t: np.ndarray) -> np.ndarray:
        """(m,) bool: arm ``arm`` at ``q`` (m, 2) deg, times ``t`` (m,) s, against the set."""
        q = np.ascontiguousarray(q, dtype=np.float64)
        if not self.members:
            return np.zeros(len(q), dtype=bool)
        return collides_many(q, np.ascontiguousarray(t, dtype=np.float64), self.kind.links,
                             self.kind.sizes, self.frames[arm], self.obs, self.circ,
                             self.dt_col, self.pad)
