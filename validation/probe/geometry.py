"""The probe arms' bodies as the validation package sees them (its own kinematics).

The linkage of Sabater et al. 2018 (Fig. 5) in vector form: J3 on the crank circle about
J1, J4 on the rocker circle about J2 = (d12, 0), the long tube from J3 through J4 to the
tip ``d3tip`` from J3. Five capsules per arm (crank, rocker, collimator cabinet, long
tube, pick-off head) from the spec's dimensions, in the bench frame (field centre at the
origin). Shared by the 2D check (:mod:`~rfp_twin.validation.probe.check`) and the 3D
check (:mod:`~rfp_twin.validation.probe.check3d`); imports nothing of ``planners``.
Units: mm, deg, s.
"""
from __future__ import annotations

import numpy as np

#: Names of the five bodies of an arm, in the order of :func:`capsule_ends`.
BODY_NAMES = ("crank", "rocker", "cabinet", "tube", "head")


def arm_frames(spec) -> np.ndarray:
    """(n, 4) base x, y and heading cos, sin of each arm (x axis towards the centre)."""
    polar = np.radians(spec.first_arm_deg + 360.0 / spec.n_arms * np.arange(spec.n_arms))
    return np.column_stack([spec.bench_radius_mm * np.cos(polar),
                            spec.bench_radius_mm * np.sin(polar),
                            -np.cos(polar), -np.sin(polar)])


def arm_joints(spec, q_deg: np.ndarray):
    """J3, J4, the tube direction and d34 of poses ``q_deg`` (..., 2), arm frame."""
    t1 = np.radians(q_deg[..., 0])
    t2 = np.radians(q_deg[..., 1])
    j3 = np.stack([spec.d13_mm * np.cos(t1), spec.d13_mm * np.sin(t1)], -1)
    j4 = np.stack([spec.d12_mm - spec.d24_mm * np.cos(t2), spec.d24_mm * np.sin(t2)], -1)
    v = j4 - j3
    d34 = np.linalg.norm(v, axis=-1)
    return j3, j4, v / d34[..., None], d34


def capsule_ends(spec, q_deg: np.ndarray, frames: np.ndarray):
    """Ends (..., n, 5, 2, 2) and radii (5,) of the capsules of poses ``q_deg`` (..., n, 2)
    in the world; ``frames`` (n, 4)."""
    j3, j4, u, _ = arm_joints(spec, q_deg)
    tip = j3 + spec.d3tip_mm * u
    head0 = tip - spec.head_length_mm * u
    j1 = np.zeros_like(j3)
    j2 = np.broadcast_to(np.array([spec.d12_mm, 0.0]), j3.shape)
    ends = np.stack([np.stack([j1, j3], -2), np.stack([j2, j4], -2),
                     np.stack([j3 - spec.tube_rear_mm * u, j3 + spec.ds1_mm * u], -2),
                     np.stack([j3, head0], -2), np.stack([head0, tip], -2)], -3)
    c, s = frames[:, 2], frames[:, 3]
    x = frames[:, 0][:, None, None] + c[:, None, None] * ends[..., 0] - s[:, None, None] * ends[..., 1]
    y = frames[:, 1][:, None, None] + s[:, None, None] * ends[..., 0] + c[:, None, None] * ends[..., 1]
    radii = np.array([spec.link_radius_mm, spec.link_radius_mm, spec.cabinet_radius_mm,
                      spec.tube_radius_mm, spec.head_radius_mm])
    return np.stack([x, y], -1), radii


def sample_poses(breakpoints: dict, n_arms: int, t: np.ndarray) -> np.ndarray:
    """(len(t), n_arms, 2) deg: each arm's breakpoints {arm: (times, configs)}
    linearly interpolated at times ``t`` s, held before the first and after the last."""
    out = np.empty((t.size, n_arms, 2))
    for i in range(n_arms):
        times, q = breakpoints[i]
        for k in range(2):
            out[:, i, k] = np.interp(t, times, q[:, k])
    return out
