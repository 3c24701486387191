"""Tests of rfp_twin.models.geometry.shapes: procedural outlines and meshes.

Facts: SDSS-V coordio/kaiju 1.4.1 (beta axis to flat tip 16.2 mm, tip 0.6 mm wide, post
radius 0.5 mm, fibers at (14.314, 0), (14.965, -0.376), (14.965, 0.376)).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from rfp_twin.models.geometry import alpha_outline, beta_outline, cylinder, prism, union


def test_beta_arm_has_the_published_dimensions(sdss):
    bar = sdss.links["beta"].collision[0]
    lo, hi = bar.bounds
    assert hi[0] == pytest.approx(16.2)               # flat tip (coordio)
    assert lo[0] == pytest.approx(-1.5)               # starts behind the beta axis
    assert hi[1] == pytest.approx(1.5) and lo[1] == pytest.approx(-1.5)  # half-width 1.5
    tip = bar.vertices[np.isclose(bar.vertices[:, 0], 16.2)]
    assert np.abs(tip[:, 1]).max() == pytest.approx(0.3)   # 0.6 mm wide flat tip
    post = sdss.links["beta"].collision[1]
    assert np.hypot(*post.vertices[:, :2].T).max() == pytest.approx(0.5)
    names = [f[0] for f in sdss.params.fibers]
    assert names == ["metrology", "boss", "apogee"]
    fib = sdss.fiber_positions()
    assert fib["metrology"] == pytest.approx((14.314, 0.0, sdss.params.beta_height_mm))
    assert fib["boss"][:2] == pytest.approx((14.965, -0.376))
    assert fib["apogee"][:2] == pytest.approx((14.965, 0.376))


def test_outline_is_convex_and_counter_clockwise(sdss):
    out = beta_outline(sdss.params)
    x, y = out[:, 0], out[:, 1]
    area = 0.5 * np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y)
    assert area > 0
    assert area == pytest.approx(sdss.links["beta"].collision[0].volume / sdss.params.beta_height_mm)
def test_prism_and_cylinder_are_closed_and_exact():
    square = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 3.0], [0.0, 3.0]])
    box = prism(square, -1.0, 1.0)
    assert box.is_watertight and box.volume == pytest.approx(12.0)
    can = cylinder(1.0, 2.0, 0.5, 0.0, 4.0, 64)
    assert can.is_watertight and can.is_convex
    assert can.volume == pytest.approx(0.5 * 64 * 0.25 * math.sin(2 * math.pi / 64) * 4.0)
    assert can.bounds[:, :2].mean(axis=0) == pytest.approx([1.0, 2.0], abs=1e-3)


def test_alpha_outline_holds_hub_and_housing(sdss):
    out = alpha_outline(sdss.params, 7.4)
    assert out[:, 0].min() == pytest.approx(-sdss.params.alpha_hub_radius_mm)
    assert out[:, 0].max() == pytest.approx(7.4 + sdss.params.alpha_housing_radius_mm)


def test_union_of_overlapping_pieces_is_one_watertight_mesh():
    square = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]])
    merged = union([prism(square, 0.0, 1.0), prism(square + 1.0, 0.0, 1.0)])
    assert merged.is_watertight and merged.volume == pytest.approx(7.0)
    single = prism(square, 0.0, 1.0)
    assert union([single]) is not single and union([single]).volume == pytest.approx(4.0)
