"""Tests of two robots in many configurations (validation/mesh3d/pair.py)."""
from __future__ import annotations

import math

import numpy as np
import trimesh

from rfp_twin.models.geometry import load_geometry
from tests.validation.conftest import SPEC, sdss_models
from rfp_twin.validation.mesh3d import LinkModels, RobotPair
from rfp_twin.validation.numerics import segment_distance_np

MODELS = sdss_models()


def test_fcl_distance_of_capsule_meshes_matches_the_analytic_distance(tmp_path):
    # the beta link replaced by a capsule mesh (axis x in [0, 15] at z = 1, radius 1.2):
    # two robots' capsules at one height are 2D segment distance - 2 r apart
    r, n = 1.2, 32
    cap = trimesh.creation.capsule(height=15.0, radius=r, count=[n, n])
    cap.apply_transform(trimesh.transformations.rotation_matrix(math.pi / 2, [0, 1, 0]))
    cap.apply_translation([7.5 - cap.bounds.mean(axis=0)[0], 0.0, 1.0])
    cap.export(tmp_path / "capsule.stl")
    toml = tmp_path / "capsule.toml"
    toml.write_text('extends = "sdss-v"\n[geometry.meshes]\nbeta = "capsule.stl"\n')
    geom = load_geometry(toml)
    pair = RobotPair(LinkModels.from_geometry(geom), (22.4, 0.0))
    rng = np.random.default_rng(11)
    ang = rng.uniform(0, 360, (400, 4))
    la = SPEC.alpha_length_mm
    a0, b0, a1, b1 = np.deg2rad(ang).T
    e0 = np.column_stack([la * np.cos(a0), la * np.sin(a0)])
    e1 = np.column_stack([22.4 + la * np.cos(a1), la * np.sin(a1)])
    f0 = e0 + 15.0 * np.column_stack([np.cos(a0 + b0), np.sin(a0 + b0)])
    f1 = e1 + 15.0 * np.column_stack([np.cos(a1 + b1), np.sin(a1 + b1)])
    analytic = segment_distance_np(e0, f0, e1, f1) - 2 * r
    near = (analytic > 0.05) & (analytic < 4.0)
    assert near.sum() > 20
    d, links = pair.distances(ang[near], with_links=True)
    assert all(lk == ("beta", "beta") for lk in links)
    # inscribed tessellation: never closer than the true surfaces, at most two sagittas
    # farther (STL and the CAD slabs store float32 vertices: 1e-5 mm)
    sagitta = r * (1 - math.cos(math.pi / n)) * 2
    assert np.all(d >= analytic[near] - 1e-5)
    assert np.all(d <= analytic[near] + 2 * sagitta + 1e-5)


def test_bounds_are_exact_on_the_procedural_prisms_and_below_fcl():
    pair = RobotPair(MODELS, (22.4, 0.0))
    ang = np.random.default_rng(2).uniform(0, 360, (300, 4))
    lb = pair.bounds(ang)
    d = pair.distances(ang)
    assert np.all(lb <= d + 1e-9)
    np.testing.assert_allclose(lb, d, atol=1e-7)
    np.testing.assert_array_equal(pair.collides(ang), d <= 0.0)
