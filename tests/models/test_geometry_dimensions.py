"""Tests of rfp_twin.models.geometry.dimensions: SDSS-V defaults, derived heights, spec-scaled defaults."""
from __future__ import annotations

import math

import pytest

from rfp_twin.models.geometry import SDSS_V_DEFAULTS, default_params, geometry_for_spec
from rfp_twin.models.robot import load_spec, load_tables


def test_the_preset_table_matches_the_code_defaults():
    table = load_tables("sdss-v")["geometry"]
    for key, value in table.items():
        if key == "fibers":
            assert [(f["name"], f["x"], f["y"]) for f in value] == list(SDSS_V_DEFAULTS["fibers"])
        else:
            assert value == SDSS_V_DEFAULTS[key], key


def test_defaults_follow_the_spec_when_there_is_no_table():
    spec = load_spec("sdss-v").with_overrides(source="<memory>", beta_length_mm=12.0, pitch_mm=18.0)
    g = geometry_for_spec(spec)
    assert g.params.beta_tip_mm == pytest.approx(13.2)
    assert not g.alpha_arms_can_touch()
    assert g.beta_envelope_mm(0.0, 12.0) <= 1.5 + 1e-9


def test_default_params_move_the_tip_with_the_beta_arm_and_shrink_with_the_pitch():
    spec = load_spec("sdss-v").with_overrides(beta_length_mm=12.0, pitch_mm=18.0)
    d = default_params(spec)
    assert d["beta_tip_mm"] == pytest.approx(16.2 - 3.0)
    assert d["ferrule_x_mm"] == pytest.approx(14.64 - 3.0)
    assert [x for _, x, _ in d["fibers"]] == pytest.approx([14.314 - 3.0, 14.965 - 3.0, 14.965 - 3.0])
    assert d["alpha_housing_radius_mm"] == pytest.approx(9.0 - 7.4 - 0.3)   # half pitch - l_alpha
    assert d["body_radius_mm"] == 5.0 and SDSS_V_DEFAULTS["beta_tip_mm"] == 16.2  # not mutated


def test_derived_heights(sdss):
    p = sdss.params
    assert p.alpha_top_mm == pytest.approx(0.3 + 4.0)
    assert p.fiber_z_mm == pytest.approx(5.8 + 2.0)
    assert p.head_centre_mm == pytest.approx(16.2 - math.sqrt(1.5 ** 2 - 0.3 ** 2))
