"""Tests of the P1 prototype beta arm (``beta_shape = "p1"``, preset ``sdss-v-p1``).

Facts (kaiju python/kaiju/betaArm.cpp, commit 479b820): the P1 beta arm is a sphere swept
along a 13-point polyline, one radius per segment (base 3.4372 mm, head 2.61 mm at
z = 30 mm), ending at x = 19.2 - 3.0 - 1.5 = 14.7 mm. Our reading: P1's z = 0 at the beta
frame origin, fibers on the head's axis.
"""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.errors import SpecError
from rfp_twin.models.geometry import (P1_BETA_ARM, P1_HEAD_Z_MM, build_geometry, load_geometry,
                                      p1_reach_mm, params_from_tables)
from rfp_twin.models.robot import load_spec, load_tables


@pytest.fixture(scope="module")
def p1():
    return load_geometry("sdss-v-p1")


def _segment_distance(v: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    d = b - a
    t = np.clip((v - a) @ d / (d @ d), 0.0, 1.0)
    return np.linalg.norm(v - (a + t[:, None] * d), axis=1)


def test_the_table_is_the_published_polyline():
    assert len(P1_BETA_ARM) == 13 and P1_BETA_ARM[-1][2] is None
    assert P1_BETA_ARM[0] == (0.9895, 7.8507, 3.4372)
    assert P1_BETA_ARM[-2] == (10.25, 30.0, 2.61)
    assert P1_BETA_ARM[-1][0] == pytest.approx(19.2 - 3.0 - 1.5)
    assert P1_HEAD_Z_MM == 30.0
    assert p1_reach_mm() == pytest.approx(14.7 + 2.61)


def test_preset_extends_the_paper_robot_and_only_changes_the_beta_shape():
    a, b = load_spec("sdss-v"), load_spec("sdss-v-p1")
    assert b.name == "sdss-v-p1"
    assert b.with_overrides(name="sdss-v", description=a.description, source=a.source) == a
    ga, gb = load_tables("sdss-v")["geometry"], load_tables("sdss-v-p1")["geometry"]
    assert gb.pop("beta_shape") == "p1" and "beta_shape" not in ga and ga == gb


def test_p1_builds_watertight_convex_pieces_one_per_segment(p1):
    assert p1.params.beta_shape == "p1"
    beta = p1.links["beta"]
    assert len(beta.collision) == 12 + 1                      # tube segments + the post
    for link in p1.links.values():
        assert link.visual.is_watertight and link.visual.volume > 0
        for piece in link.collision:
            assert piece.is_watertight and piece.is_convex and piece.volume > 0
    assert len(beta.visual.split(only_watertight=False)) == 1  # one body: tube + post
    pts = np.array([[x, 0.0, z] for x, z, _ in P1_BETA_ARM])
    sag = 1.0 - np.cos(2 * np.pi / p1.params.circle_sections)   # tessellation, share of r
    for k, piece in enumerate(beta.collision[:12]):
        r = P1_BETA_ARM[k][2]
        d = _segment_distance(piece.vertices, pts[k], pts[k + 1])
        assert d.max() <= r + 1e-6 and d.min() >= r - 1e-6    # vertices on the capsule
        lo, hi = piece.bounds
        top, bottom = max(pts[k, 2], pts[k + 1, 2]) + r, min(pts[k, 2], pts[k + 1, 2]) - r
        assert top - sag * r <= hi[2] <= top + 1e-9 and bottom - 1e-9 <= lo[2] <= bottom + sag * r


def test_envelope_and_reach_follow_p1(p1):
    bar = load_geometry("sdss-v")
    assert p1.beta_reach_mm() == pytest.approx(7.4 + 14.7 + 2.61, abs=1e-6)
    assert bar.beta_reach_mm() < p1.beta_reach_mm()
    # the widest part is the base sphere (radius 3.4372 mm around x = 0.9895 mm)
    assert p1.beta_envelope_mm() == pytest.approx(3.4372, abs=1e-3)
    assert p1.beta_envelope_mm() <= 3.4372 + 1e-9
    assert p1.beta_envelope_mm(0.0, 15.0) == pytest.approx(p1.beta_envelope_mm(), abs=1e-9)
    assert p1.params.beta_end_mm == 14.7 and bar.params.beta_end_mm == bar.params.head_centre_mm
    assert bar.beta_envelope_mm() <= 1.5 + 1e-9 < p1.beta_envelope_mm()


def test_fibers_focal_surface_and_fiducials_follow_the_head(p1):
    p = p1.params
    assert p.fiber_height_mm == 30.0
    assert p.fiber_z_mm == pytest.approx(p.beta_z_mm + 30.0)
    assert p1.fiber_positions()["metrology"] == pytest.approx((14.314, 0.0, 30.0))
    assert p1.links["fiducial"].visual.bounds[1, 2] == pytest.approx(p.fiber_z_mm)
    head = p1.robot_meshes(0.0, 0.0)["beta"]
    assert head.bounds[1, 2] == pytest.approx(p.fiber_z_mm + 2.795, abs=1e-6)  # conduit top
    bar = load_geometry("sdss-v").params
    assert bar.beta_shape == "bar" and bar.fiber_z_mm == pytest.approx(5.8 + 2.0)


def test_post_joins_the_alpha_arm_and_the_tube_clears_it(p1):
    posed = p1.robot_meshes(30.0, 150.0)
    assert posed["beta"].bounds[0, 2] == pytest.approx(p1.params.alpha_top_mm)
    tube = p1.links["beta"].collision[:12]
    low = min(m.bounds[0, 2] for m in tube) + p1.params.beta_z_mm
    assert low == pytest.approx(p1.params.beta_z_mm + 7.8507 - 3.4372, abs=0.01)
    assert low > posed["alpha"].bounds[1, 2]


def test_with_params_switches_shape_and_back():
    bar = load_geometry("sdss-v")
    p1 = bar.with_params(beta_shape="p1")
    assert len(p1.links["beta"].collision) == 13
    back = p1.with_params(beta_shape="bar")
    for a, b in zip(back.links["beta"].collision, bar.links["beta"].collision):
        assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.faces, b.faces)


@pytest.mark.parametrize("table, message", [
    ({"beta_shape": "tube"}, "beta_shape"),
    ({"beta_shape": 1}, "beta_shape"),
    ({"beta_shape": "p1", "fibers": [{"name": "far", "x": 18.0, "y": 0.0}]}, "fibers.far"),
    ({"beta_shape": "p1", "fibers": [{"name": "side", "x": 12.0, "y": 2.7}]}, "P1 head"),
])
def test_bad_shape_values_name_the_field(table, message):
    spec = load_spec("sdss-v")
    with pytest.raises(SpecError, match=message):
        build_geometry(spec, params_from_tables({"geometry": table}, spec, "t.toml"))


def test_fibers_in_the_p1_head_but_off_the_bar_are_allowed():
    spec = load_spec("sdss-v")
    table = {"beta_shape": "p1", "fibers": [{"name": "wide", "x": 12.0, "y": 2.0}]}
    g = build_geometry(spec, params_from_tables({"geometry": table}, spec, "t.toml"))
    assert g.fiber_positions()["wide"] == (12.0, 2.0, 30.0)
