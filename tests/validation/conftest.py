"""Shared builders for the validation tests (SDSS-V preset, mm, deg, s).

Geometry used throughout: robot 0 at the origin, robot 1 at (22.4, 0) parked at alpha =
beta = 180, so its beta arm lies along +x from its beta axis at (15, 0) (2D collision
segment [(15, 0), (30, 0)] at buffer 2.5 mm). Robot 0 holds alpha = 0 and turns its beta
arm to angle ``b``: its centre line passes the point (15, 0) at ``7.6 sin b`` (``b <=
90`` deg).
"""
from __future__ import annotations

import functools
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from rfp_twin.models.layout import Layout
from rfp_twin.models.robot import load_spec
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.validation.numerics import segment_distance_np

ROOT = Path(__file__).resolve().parents[2]
SPEC = load_spec("sdss-v")
#: Robot 1's base, mm.
PITCH = 22.4


def pair_layout(fiducial: bool = False) -> Layout:
    """Robots 0 and 1; with ``fiducial``, fiducial 7 at (0, 20)."""
    if fiducial:
        return Layout([0, 1, 7], [[0.0, 0.0], [PITCH, 0.0], [0.0, 20.0]],
                      ["robot", "robot", "fiducial"], name="pair+fid")
    return Layout([0, 1], [[0.0, 0.0], [PITCH, 0.0]], ["robot", "robot"], name="pair")


def swing(beta_times, beta_angles, duration) -> Trajectory:
    """Robot 0 moves its beta arm (alpha 0); robot 1 is parked at (180, 180)."""
    return Trajectory.from_breakpoints(
        [0, 1], [[0.0, duration], [0.0, duration]], [[0.0, 0.0], [180.0, 180.0]],
        [beta_times, [0.0, duration]], [beta_angles, [180.0, 180.0]])


def static(angles, ids=(0, 1)) -> Trajectory:
    """Every robot holds its (alpha, beta) for one second."""
    angles = np.asarray(angles, float).reshape(-1, 2)
    return Trajectory.from_breakpoints(
        list(ids), [[0.0, 1.0]] * len(ids), [[a, a] for a in angles[:, 0]],
        [[0.0, 1.0]] * len(ids), [[b, b] for b in angles[:, 1]])


def brute_distances(traj: Trajectory, layout: Layout, times, a: int, b: int | None = None,
                    point=None, buffer_mm: float = 2.5) -> np.ndarray:
    """2D segment distance of robot index a to robot index b (or to a point) at times,
    from :meth:`Trajectory.sample` and numpy alone."""
    ang = np.deg2rad(traj.sample(times))
    s0, s1 = SPEC.segment_start_mm, SPEC.segment_end(buffer_mm)
    base = layout.robot_xy

    def seg(k):
        al, be = ang[:, k, 0], ang[:, k, 1]
        elbow = base[k] + SPEC.alpha_length_mm * np.stack([np.cos(al), np.sin(al)], -1)
        u = np.stack([np.cos(al + be), np.sin(al + be)], -1)
        return elbow + s0 * u, elbow + s1 * u

    p0, p1 = seg(a)
    if b is None:
        q = np.broadcast_to(np.asarray(point, float), p0.shape)
        return segment_distance_np(p0, p1, q, q)
    q0, q1 = seg(b)
    return segment_distance_np(p0, p1, q0, q1)


@functools.lru_cache(maxsize=None)
def sdss_geometry():
    """The SDSS-V preset's meshes (built once)."""
    from rfp_twin.models.geometry import geometry_for_spec

    return geometry_for_spec(SPEC)


@functools.lru_cache(maxsize=None)
def sdss_models():
    """:class:`rfp_twin.validation.mesh3d.LinkModels` of the SDSS-V meshes (built once)."""
    from rfp_twin.validation.mesh3d import LinkModels

    return LinkModels.from_geometry(sdss_geometry())


_WHOLE_BVH: dict = {}


def whole_link_distance(geom, base_a, ang_a, link_a, base_b, ang_b, link_b) -> float:
    """Reference: FCL distance of the whole (concatenated) collision meshes of two posed
    links (bases mm, angles (alpha, beta) deg), built here independently of mesh3d's
    per-piece models and pruning (surface distance, 0 when they cross)."""
    import fcl

    def obj(base, ang, name):
        key = (id(geom), name)
        if key not in _WHOLE_BVH:
            mesh = geom.links[name].collision_mesh
            bvh = fcl.BVHModel()
            bvh.beginModel(len(mesh.vertices), len(mesh.faces))
            bvh.addSubModel(mesh.vertices, mesh.faces.astype(np.int32))
            bvh.endModel()
            _WHOLE_BVH[key] = bvh
        t = geom.link_transform(name, *ang)
        return fcl.CollisionObject(_WHOLE_BVH[key],
                                   fcl.Transform(t[:3, :3], t[:3, 3] + [*base, 0.0]))

    return max(0.0, fcl.distance(obj(base_a, ang_a, link_a), obj(base_b, ang_b, link_b)))


def python_lines(code: str) -> list[str]:
    """Output lines of ``code`` run in a fresh interpreter on this checkout (nothing
    imported beforehand)."""
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True,
                         text=True, env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"},
                         check=True, timeout=120)
    return out.stdout.strip().splitlines()


#: A small calibration run (seconds, not minutes).
SMALL = dict(n_samples=4096, n_draws=40, n_scatter=200, mc_rounds=6, seed=3)


@pytest.fixture(scope="session")
def cal():
    """One small buffer calibration of the SDSS-V preset, shared by the buffer tests."""
    from rfp_twin.validation.buffer import calibrate_buffer

    return calibrate_buffer(SPEC, sdss_geometry(), **SMALL)
