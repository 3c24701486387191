"""Tests of models.geometry: the 3D robot, its envelope, and user CAD meshes.

Facts: kaiju-anchor.md (beta axis to flat tip 16.2 mm, tip 0.6 mm wide, post radius
0.5 mm, fibers at (14.314, 0), (14.965, -0.376), (14.965, 0.376)); Sayres 2021 (beta arm
half-width 1.5 mm is the physical envelope; alpha arms cannot collide at 22.4 mm pitch).
"""
from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh

from models.errors import SpecError
from models.geometry import (LINKS, SDSS_V_DEFAULTS, beta_outline, build_geometry,
                             geometry_for_spec, load_cad_mesh, load_geometry, params_from_tables,
                             slab_pieces)
from models.robot import load_spec, load_tables, sdss_production_segment_end


@pytest.fixture(scope="module")
def sdss():
    return load_geometry("sdss-v")


# -- the procedural SDSS-V robot ------------------------------------------------------
def test_every_link_is_watertight_and_collision_pieces_are_convex(sdss):
    assert set(sdss.links) == set(LINKS)
    for link in sdss.links.values():
        assert link.visual.is_watertight and link.visual.volume > 0
        for piece in link.collision:
            assert piece.is_watertight and piece.is_convex and piece.volume > 0


def test_beta_arm_has_the_published_dimensions(sdss):
    bar = sdss.links["beta"].collision[0]
    lo, hi = bar.bounds
    assert hi[0] == pytest.approx(16.2)               # flat tip, kaiju-anchor
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


def test_beta_collision_pieces_stay_inside_the_planner_envelope(sdss):
    """Every vertex within 1.5 mm of the 0..14.73 mm segment, hence (convexity) every
    point: a plan checked at buffer >= 1.5 mm keeps the 3D arms apart."""
    assert sdss.params.head_centre_mm == pytest.approx(16.2 - math.sqrt(1.5**2 - 0.3**2))
    assert sdss.beta_envelope_mm(0.0, 14.731) <= 1.5 + 1e-9
    assert sdss.beta_envelope_mm(0.0, 15.0) <= 1.5 + 1e-9          # paper segment
    assert sdss.beta_envelope_mm(0.0, sdss_production_segment_end(1.5)) <= 1.5 + 1e-9
    assert sdss.beta_envelope_mm(0.0, 14.0) > 1.5                 # the measure is tight


def test_ferrule_hangs_below_the_bar_but_above_the_alpha_arms(sdss):
    posed = sdss.robot_meshes(10.0, 170.0)
    beta_low = posed["beta"].bounds[0, 2]
    assert beta_low == pytest.approx(sdss.params.alpha_top_mm)     # post meets the alpha arm
    ferrule = sdss.links["beta"].collision[2].copy()
    ferrule.apply_transform(sdss.link_transform("beta", 10.0, 170.0))
    assert ferrule.bounds[0, 2] > posed["alpha"].bounds[1, 2]
    assert ferrule.bounds[0, 2] < sdss.params.beta_z_mm


def test_alpha_arms_cannot_touch_at_the_sdss_pitch(sdss):
    assert sdss.alpha_reach_mm() < 22.4 / 2
    assert not sdss.alpha_arms_can_touch()
    assert sdss.alpha_arms_can_touch(pitch_mm=2 * sdss.alpha_reach_mm() - 0.1)
    a = sdss.robot_meshes(0.0, 170.0)["alpha"]                      # pointing at each other
    b = sdss.robot_meshes(180.0, 170.0)["alpha"]
    b.apply_translation([22.4, 0.0, 0.0])
    assert a.bounds[1, 0] < b.bounds[0, 0]


def test_link_transforms_follow_the_kinematics(sdss):
    for alpha, beta in [(0.0, 0.0), (90.0, 0.0), (30.0, 45.0)]:
        tip = sdss.link_transform("beta", alpha, beta) @ np.array([16.2, 0.0, 0.0, 1.0])
        a, ab = math.radians(alpha), math.radians(alpha + beta)
        assert tip[:2] == pytest.approx([7.4 * math.cos(a) + 16.2 * math.cos(ab),
                                         7.4 * math.sin(a) + 16.2 * math.sin(ab)])
        assert tip[2] == pytest.approx(sdss.params.beta_z_mm)
    assert sdss.params.fiber_z_mm == pytest.approx(sdss.params.beta_z_mm + sdss.params.beta_height_mm)


def test_link_meshes_for_a_validator_are_the_collision_pieces(sdss):
    meshes = sdss.link_meshes("collision")
    beta = meshes["beta"]
    assert len(beta.vertices) == sum(len(p.vertices) for p in sdss.links["beta"].collision)
    assert set(sdss.link_meshes("visual")) == set(LINKS)
    with pytest.raises(SpecError, match="allowed: collision, visual"):
        sdss.link_meshes("wire")


def test_the_preset_table_matches_the_code_defaults():
    table = load_tables("sdss-v")["geometry"]
    for key, value in table.items():
        if key == "fibers":
            assert [(f["name"], f["x"], f["y"]) for f in value] == list(SDSS_V_DEFAULTS["fibers"])
        else:
            assert value == SDSS_V_DEFAULTS[key], key


def test_production_and_desi_presets_build():
    prod = load_geometry("sdss-v-production")
    assert prod.params == load_geometry("sdss-v").params
    desi = load_geometry("desi")
    assert desi.beta_envelope_mm(0.0, 3.0) <= 1.0 + 1e-9             # inside the 1 mm buffer
    assert not desi.alpha_arms_can_touch()


def test_defaults_follow_the_spec_when_there_is_no_table():
    spec = load_spec("sdss-v").with_overrides(source="<memory>", beta_length_mm=12.0, pitch_mm=18.0)
    g = geometry_for_spec(spec)
    assert g.params.beta_tip_mm == pytest.approx(13.2)
    assert not g.alpha_arms_can_touch()
    assert g.beta_envelope_mm(0.0, 12.0) <= 1.5 + 1e-9


def test_bad_geometry_values_name_the_field():
    spec = load_spec("sdss-v")
    cases = [({"beta_half_width_mm": -1.0}, "beta_half_width_mm"),
             ({"beta_tip_half_width_mm": 2.0}, "beta_tip_half_width_mm"),
             ({"beta_z_mm": 1.0}, "beta_z_mm"),
             ({"ferrule_drop_mm": 3.0}, "ferrule_drop_mm"),
             ({"ferrule_x_mm": 16.0}, "ferrule_radius_mm"),
             ({"bogus_mm": 1.0}, "unknown field"),
             ({"circle_sections": 2}, "circle_sections"),
             ({"fibers": [{"name": "a", "x": 1.0}]}, "fibers"),
             ({"fibers": [{"name": "a", "x": 30.0, "y": 0.0}]}, "fibers.a"),
             ({"meshes": {"gamma": "x.stl"}}, "allowed links")]
    for table, message in cases:
        with pytest.raises(SpecError, match=message):
            build_geometry(spec, params_from_tables({"geometry": table}, spec, "t.toml"))


# -- user CAD meshes --------------------------------------------------------------------
def _beta_cad() -> trimesh.Trimesh:
    """A CAD-like beta arm: the bar plus a notch-free block, origin on the beta axis."""
    bar = trimesh.creation.box(extents=(17.0, 3.0, 2.0))
    bar.apply_translation([16.2 - 8.5, 0.0, 1.0])
    return bar


def _write_toml(tmp_path, meshes: dict, extra: str = "") -> str:
    text = "extends = \"sdss-v\"\n[geometry.meshes]\n" + "".join(
        f'{k} = "{v}"\n' for k, v in meshes.items()) + extra
    path = tmp_path / "robot.toml"
    path.write_text(text)
    return str(path)


def test_cad_beta_mesh_replaces_the_link(tmp_path):
    _beta_cad().export(tmp_path / "beta.stl")
    g = load_geometry(_write_toml(tmp_path, {"beta": "beta.stl"}))  # relative to the TOML
    beta = g.links["beta"]
    assert beta.source.endswith("beta.stl")
    assert beta.visual.bounds[1, 0] == pytest.approx(16.2)
    assert all(p.is_convex for p in beta.collision)
    assert g.beta_envelope_mm(0.0, 14.73) > 1.5                      # square corners stick out


def test_cad_concave_link_is_cut_into_convex_slabs():
    # an L-shaped plate: concave, but convex within each x slab
    a = trimesh.creation.box(extents=(10.0, 2.0, 1.0))
    a.apply_translation([5.0, 0.0, 0.5])
    b = trimesh.creation.box(extents=(2.0, 6.0, 1.0))
    b.apply_translation([9.0, 3.0, 0.5])
    shape = trimesh.boolean.union([a, b], engine="manifold")
    pieces = slab_pieces(shape, 5)
    assert len(pieces) == 5
    assert all(p.is_convex for p in pieces)
    assert sum(p.volume for p in pieces) == pytest.approx(shape.volume, rel=1e-6)
    assert shape.convex_hull.volume > 1.2 * shape.volume             # one hull would not do


def test_bad_cad_meshes_get_clear_errors(tmp_path):
    with pytest.raises(SpecError, match="file not found"):
        load_cad_mesh(tmp_path / "nope.stl", "meshes.beta", 17.0)
    (tmp_path / "arm.ply").write_text("ply\n")
    with pytest.raises(SpecError, match=r"allowed: \.stl, \.obj"):
        load_cad_mesh(tmp_path / "arm.ply", "meshes.beta", 17.0)
    open_box = _beta_cad()
    open_box.update_faces(np.arange(len(open_box.faces)) > 1)         # drop one side
    open_box.export(tmp_path / "open.stl")
    with pytest.raises(SpecError, match="not watertight"):
        load_cad_mesh(tmp_path / "open.stl", "meshes.beta", 17.0)
    metres = _beta_cad()
    metres.apply_scale(1e-3)
    metres.export(tmp_path / "metres.obj")
    with pytest.raises(SpecError, match="metres"):
        load_cad_mesh(tmp_path / "metres.obj", "meshes.beta", 17.0)
    off_axis = _beta_cad()
    off_axis.apply_translation([30.0, 0.0, 0.0])
    off_axis.export(tmp_path / "off.stl")
    with pytest.raises(SpecError, match="not on the joint axis"):
        load_cad_mesh(tmp_path / "off.stl", "meshes.beta", 17.0)
    (tmp_path / "junk.stl").write_bytes(b"\x00" * 10)
    with pytest.raises(SpecError, match="meshes.beta"):
        load_cad_mesh(tmp_path / "junk.stl", "meshes.beta", 17.0)


def test_missing_cad_file_in_a_toml_names_the_field(tmp_path):
    with pytest.raises(SpecError, match=r"meshes\.alpha.*file not found"):
        load_geometry(_write_toml(tmp_path, {"alpha": "missing.stl"}))


def test_given_collision_pieces_are_used(tmp_path):
    _beta_cad().export(tmp_path / "beta.stl")
    piece = trimesh.creation.box(extents=(16.0, 3.0, 2.0))
    piece.apply_translation([8.0, 0.0, 1.0])
    piece.export(tmp_path / "piece.stl")
    g = load_geometry(_write_toml(tmp_path, {"beta": "beta.stl"},
                                  '[geometry.collision]\nbeta = ["piece.stl"]\n'))
    assert len(g.links["beta"].collision) == 1
    assert g.links["beta"].collision[0].bounds[1, 0] == pytest.approx(16.0)


def test_outline_is_convex_and_counter_clockwise(sdss):
    out = beta_outline(sdss.params)
    x, y = out[:, 0], out[:, 1]
    area = 0.5 * np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y)
    assert area > 0
    assert area == pytest.approx(sdss.links["beta"].collision[0].volume / sdss.params.beta_height_mm)
