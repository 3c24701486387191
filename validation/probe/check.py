"""Independent dense 2D check of a probe-arm plan (MIRADAS, Sabater et al. 2018).

Given each arm's breakpoints (times s, (theta1, theta2) deg, linearly interpolated, held
after the last), the check samples every arm every ``dt_s`` and verifies:

* no two arms touch: for every pair of arms, every pair of their five capsules (crank,
  rocker, collimator cabinet, long tube, pick-off head) is more than the two radii plus
  ``2 * buffer_mm`` apart (``buffer_mm`` = 0: the bodies themselves);
* no arm enters its ZoA (Eq. 4: ``ds1 < d34 < ds2``) or leaves its joint ranges, at
  every sample and at every breakpoint;
* no joint is faster than its maximum speed;
* the start-stop cycles of each arm: interior breakpoints where an arm arrives moving
  and its velocity changes (straight joint-space segments, Sect. 3.2.1), at most
  ``max_start_stop``.

This module has its own kinematics (the linkage in vector form: the tip is ``d3tip``
from J3 along J3 -> J4) and uses the validation package's own segment distance; it reads
the arm's dimensions from the spec and imports nothing of the planners. Units: mm, deg,
s.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numba import njit

from rfp_twin.models.errors import TrajectoryError
from rfp_twin.validation.numerics import segment_distance
from rfp_twin.validation.probe.geometry import arm_frames, arm_joints, capsule_ends, sample_poses
from rfp_twin.validation.probe.sampling import ProbeSampling, plan_arrays, sample_count, time_chunks

#: Samples per chunk of the dense check (bounds memory).
CHUNK = 2048
#: Tolerance of the speed and joint-range checks (deg/s, deg).
TOL = 1e-6


@dataclass
class ProbeCheckReport(ProbeSampling):
    """Verdict of :func:`check_probe_plan`.

    Attributes
    ----------
    ok : bool, no contact, no ZoA / range / speed violation, cycles within the limit
    min_gap_mm : float, smallest capsule gap over all samples (distance - radii - 2 buffer)
    worst : (t s, arm a, arm b, body a, body b) of that gap
    contacts : list of (t, arm a, arm b) samples with a gap <= 0 (first 20)
    zoa : list of (arm, t) samples in the ZoA or out of range (first 20)
    too_fast : list of (arm, joint, speed deg/s) (first 20)
    start_stop : {arm: cycles}
    buffer_mm, dt_s, n_samples, duration_s : what was checked (:class:`ProbeSampling`)
    """

    ok: bool
    min_gap_mm: float
    worst: tuple
    contacts: list = field(default_factory=list)
    zoa: list = field(default_factory=list)
    too_fast: list = field(default_factory=list)
    start_stop: dict = field(default_factory=dict)


@njit(cache=True)
def _min_gaps(ends, radii, pad):
    """Per sample, the smallest capsule gap between two arms and (arm a, arm b, body a,
    body b) of it: ``ends`` (T, n, 5, 4) world ``(x0, y0, x1, y1)``, ``radii`` (5,)."""
    n_t, n = ends.shape[0], ends.shape[1]
    gap = np.full(n_t, np.inf)
    who = np.full((n_t, 4), -1, dtype=np.int64)
    for k in range(n_t):
        for a in range(n):
            for b in range(a + 1, n):
                for i in range(5):
                    p = ends[k, a, i]
                    for j in range(5):
                        q = ends[k, b, j]
                        g = segment_distance(p[0], p[1], p[2], p[3], q[0], q[1], q[2], q[3]) \
                            - radii[i] - radii[j] - pad
                        if g < gap[k]:
                            gap[k] = g
                            who[k, 0], who[k, 1], who[k, 2], who[k, 3] = a, b, i, j
    return gap, who


def start_stop_cycles(times: np.ndarray, q: np.ndarray, tol: float = 1e-9) -> int:
    """Interior breakpoints where the arm arrives moving and its velocity changes."""
    dt = np.diff(times)
    keep = dt > tol
    vel = np.diff(q, axis=0)[keep] / dt[keep][:, None]
    n = 0
    for k in range(1, len(vel)):
        moving = np.any(np.abs(vel[k - 1]) > tol)
        if moving and np.any(np.abs(vel[k] - vel[k - 1]) > 1e-6 * (1 + np.abs(vel[k - 1]).max())):
            n += 1
    return n


def check_probe_plan(spec, breakpoints: dict, *, buffer_mm: float = 0.0, dt_s: float = 0.01,
                     max_start_stop: int | None = None) -> ProbeCheckReport:
    """Check a plan of ``spec.n_arms`` probe arms densely (see the module docstring).

    Parameters
    ----------
    spec : ProbeArmSpec (dimensions, joint ranges, speeds, bench)
    breakpoints : {arm: (times (k,) s increasing, configs (k, 2) deg)}, every arm
    buffer_mm : safety buffer of each arm (0: the bodies themselves)
    dt_s : sample spacing, s
    max_start_stop : cycles allowed per arm (None: not checked)
    """
    n = spec.n_arms
    bp = plan_arrays(breakpoints, n)
    for i, (times, q) in bp.items():
        if times.ndim != 1 or q.shape != (times.size, 2) or times.size == 0 or \
                np.any(np.diff(times) < 0) or not np.all(np.isfinite(q)):
            raise TrajectoryError(f"arm {i}: breakpoints of shape {times.shape} / {q.shape}; "
                                  "allowed: times (k,) non-decreasing, configs (k, 2) finite deg")
    t_end, n_t = sample_count(bp, dt_s)
    frames = arm_frames(spec)
    pad = 2.0 * buffer_mm
    best = (np.inf, (0.0, -1, -1, -1, -1))
    contacts, zoa, too_fast = [], [], []
    lim = np.array([spec.theta1_limits_deg, spec.theta2_limits_deg])
    for t in time_chunks(n_t, dt_s, CHUNK):
        q = sample_poses(bp, n, t)                                    # (T, n, 2)
        _bad_poses(spec, q, lim, t, zoa)
        ends, radii = capsule_ends(spec, q, frames)                 # (T, n, 5, 2, 2)
        gap, who = _min_gaps(np.ascontiguousarray(ends.reshape(len(t), n, 5, 4)), radii, pad)
        k = int(np.argmin(gap))
        if gap[k] < best[0]:
            best = (float(gap[k]), (float(t[k]), *(int(w) for w in who[k])))
        for k in np.flatnonzero(gap <= 0.0)[:max(0, 20 - len(contacts))]:
            contacts.append((float(t[k]), int(who[k, 0]), int(who[k, 1])))
    for i, (times, q) in bp.items():
        _bad_poses(spec, q[:, None, :], lim, times, zoa, arm=i)
        dt = np.diff(times)
        moving = dt > 1e-12
        if moving.any():
            speed = np.abs(np.diff(q, axis=0)[moving]) / dt[moving][:, None]
            for j in range(2):
                if speed[:, j].max() > spec.max_speed_deg_s[j] + TOL and len(too_fast) < 20:
                    too_fast.append((i, j, float(speed[:, j].max())))
    cycles = {i: start_stop_cycles(*bp[i]) for i in range(n)}
    ok = best[0] > 0.0 and not zoa and not too_fast and (
        max_start_stop is None or max(cycles.values()) <= max_start_stop)
    return ProbeCheckReport(ok, best[0], best[1], contacts, zoa, too_fast, cycles,
                            buffer_mm=buffer_mm, dt_s=dt_s, n_samples=n_t, duration_s=t_end)


def _bad_poses(spec, q: np.ndarray, lim: np.ndarray, t: np.ndarray, out: list,
               arm: int | None = None) -> None:
    """Append (arm, t) of poses ``q`` (T, n, 2) in the ZoA or out of range (first 20)."""
    _, _, _, d34 = arm_joints(spec, q)
    bad = (d34 <= spec.ds1_mm) | (d34 >= spec.ds2_mm)
    bad |= np.any((q < lim[:, 0] - TOL) | (q > lim[:, 1] + TOL), axis=-1)
    for tk, a in np.argwhere(bad)[:max(0, 20 - len(out))]:
        out.append((int(a) if arm is None else arm, float(t[tk])))
