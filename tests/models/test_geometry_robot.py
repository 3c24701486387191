"""Tests of rfp_twin.models.geometry.robot_geometry: the assembled 3D robot, its frames and envelope.

Facts: Sayres 2021 Sect. 3.3 (beta arm half-width 1.5 mm is the physical envelope; alpha
arms cannot collide at 22.4 mm pitch); SDSS-V coordio/kaiju 1.4.1 (production segment end).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from rfp_twin.models.errors import SpecError
from rfp_twin.models.geometry import LINKS, geometry_for_spec, load_geometry
from rfp_twin.models.robot import load_spec, sdss_production_segment_end


def test_every_link_is_watertight_and_collision_pieces_are_convex(sdss):
    assert set(sdss.links) == set(LINKS)
    for link in sdss.links.values():
        assert link.visual.is_watertight and link.visual.volume > 0
        for piece in link.collision:
            assert piece.is_watertight and piece.is_convex and piece.volume > 0


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


def test_production_and_desi_presets_build():
    prod = load_geometry("sdss-v-production")
    assert prod.params == load_geometry("sdss-v").params
    desi = load_geometry("desi")
    assert desi.beta_envelope_mm(0.0, 3.0) <= 1.0 + 1e-9             # inside the 1 mm buffer
    assert not desi.alpha_arms_can_touch()


def test_geometry_for_spec_reads_the_table_of_the_spec_file(tmp_path):
    path = tmp_path / "wide.toml"
    path.write_text('extends = "sdss-v"\n[geometry]\nbeta_half_width_mm = 1.8\n')
    spec = load_spec(path)
    assert geometry_for_spec(spec).params.beta_half_width_mm == 1.8      # from the file
    assert geometry_for_spec(load_spec("sdss-v")).params.beta_half_width_mm == 1.5
    memory = spec.with_overrides(source="<memory>")
    assert geometry_for_spec(memory).params.beta_half_width_mm == 1.5    # defaults


def test_with_params_rebuilds_the_meshes(sdss):
    wider = sdss.with_params(beta_half_width_mm=2.0)
    assert wider.beta_envelope_mm(0.0, 15.0) == pytest.approx(2.0, abs=1e-6)
    assert sdss.beta_envelope_mm(0.0, 15.0) <= 1.5 + 1e-9
    with pytest.raises(SpecError, match=r"beta_tip_half_width_mm.*< beta_half_width_mm \(0\.2\)"):
        sdss.with_params(beta_half_width_mm=0.2)                         # narrower than the flat tip
