"""Tests of the link models (validation/mesh3d/links.py): poses, capsules, z intervals."""
from __future__ import annotations

import math

import numpy as np
import pytest

from rfp_twin.models.geometry import LINKS
from tests.validation.conftest import sdss_geometry, sdss_models
from rfp_twin.validation.mesh3d import fit_capsule, link_pose
from rfp_twin.validation.numerics import segment_distance_np

GEOM = sdss_geometry()
MODELS = sdss_models()


def test_link_pose_is_the_geometry_transform():
    rng = np.random.default_rng(3)
    for name in ("body", "alpha", "beta", "fiducial"):
        k = LINKS.index(name)
        for a, b in rng.uniform(-400, 400, (5, 2)):
            pose = link_pose(MODELS, k, (3.0, -2.0), a, b)
            t = GEOM.link_transform(name, a, b)
            c, s = math.cos(pose[0]), math.sin(pose[0])
            np.testing.assert_allclose([[c, -s], [s, c]], t[:2, :2], atol=1e-12)
            np.testing.assert_allclose(pose[1:], t[:3, 3] + [3.0, -2.0, 0.0], atol=1e-12)


def test_capsules_and_z_intervals_enclose_every_piece():
    for k, name in enumerate(LINKS):
        oz = MODELS.offset_z[k]
        for j, piece in enumerate(GEOM.links[name].collision):
            u = MODELS.kind_ptr[k] + j
            x0, y0, x1, y1, r = MODELS.cap[u, :5]
            v = piece.vertices
            d = segment_distance_np(v[:, :2], v[:, :2], np.array([x0, y0]), np.array([x1, y1]))
            assert np.all(d <= r + 1e-9)
            assert MODELS.zlim[u, 0] <= v[:, 2].min() + oz + 1e-12
            assert MODELS.zlim[u, 1] >= v[:, 2].max() + oz - 1e-12


def test_fit_capsule_is_tight_on_a_stadium():
    t = np.linspace(0, 2 * np.pi, 200, endpoint=False)
    pts = np.vstack([np.column_stack([0.5 * np.cos(t) - 3, 0.5 * np.sin(t)]),
                     np.column_stack([0.5 * np.cos(t) + 3, 0.5 * np.sin(t)])])
    seg, r = fit_capsule(pts)
    assert r == pytest.approx(0.5, abs=1e-3)
    assert np.hypot(*(seg[1] - seg[0])) == pytest.approx(6.0, abs=0.02)
