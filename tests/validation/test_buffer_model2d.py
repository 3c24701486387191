"""Tests of the 2D model distance and required buffer (validation/buffer/model2d.py)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from rfp_twin.models.robot import load_spec
from tests.validation.conftest import SPEC
from rfp_twin.validation.buffer import pair_segment_distances
from rfp_twin.validation.buffer.model2d import required_buffer
from rfp_twin.validation.numerics import segment_distance_np


def test_pair_segment_distances_match_the_2d_checker_segments():
    rng = np.random.default_rng(0)
    ang = rng.uniform(0, 360, (500, 4))
    off = np.array([22.4 * math.cos(1.0), 22.4 * math.sin(1.0)])
    a = np.deg2rad(ang)
    la, s1 = SPEC.alpha_length_mm, SPEC.segment_end(2.5)
    e0 = la * np.column_stack([np.cos(a[:, 0]), np.sin(a[:, 0])])
    e1 = off + la * np.column_stack([np.cos(a[:, 2]), np.sin(a[:, 2])])
    u0 = np.column_stack([np.cos(a[:, 0] + a[:, 1]), np.sin(a[:, 0] + a[:, 1])])
    u1 = np.column_stack([np.cos(a[:, 2] + a[:, 3]), np.sin(a[:, 2] + a[:, 3])])
    ref = segment_distance_np(e0, e0 + s1 * u0, e1, e1 + s1 * u1)
    np.testing.assert_allclose(pair_segment_distances(SPEC, off, ang), ref, atol=1e-9)


def test_required_buffer_sits_on_the_2d_boundary_for_a_buffer_dependent_segment():
    prod = load_spec("sdss-v-production")
    ang = np.random.default_rng(1).uniform(0, 360, (300, 4))
    req = required_buffer(prod, (22.4, 0.0), ang, 22.4)
    inside = req < 22.4
    assert inside.sum() > 50
    for b, c in zip(req[inside][:40], ang[inside][:40]):
        d = pair_segment_distances(prod, (22.4, 0.0), c[None], float(b))[0]
        assert d == pytest.approx(2 * b, abs=1e-6)
    np.testing.assert_allclose(required_buffer(SPEC, (22.4, 0.0), ang, 22.4),
                               np.minimum(pair_segment_distances(SPEC, (22.4, 0.0), ang) / 2, 22.4))
