"""Tests of the buffer calibration (validation/buffer/calibrate.py).

The SDSS-V preset's beta arm is a 1.5 mm half-wide bar with straight sides along the
2D segment [0, 15] mm and a rounded rear end centred on the beta axis, so two bars touch
exactly when their 2D segment distance reaches 3.0 mm with the sides parallel: the
smallest safe buffer is 1.5 mm, the mesh's envelope.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from rfp_twin.models.errors import SpecError
from tests.validation.conftest import SMALL, SPEC, sdss_geometry, sdss_models
from rfp_twin.validation.buffer import calibrate_buffer, pair_segment_distances
from rfp_twin.validation.mesh3d import RobotPair

GEOM = sdss_geometry()


def test_smallest_safe_buffer_is_the_bar_half_width_and_verified(cal):
    assert cal.envelope_mm == pytest.approx(1.5)
    assert 1.49 <= cal.safe_buffer_mm <= cal.envelope_mm + 1e-9
    w = cal.worst
    assert w["links"] == "beta-beta" and w["d3_mm"] == 0.0
    ang = np.array([[w["alpha_a"], w["beta_a"], w["alpha_b"], w["beta_b"]]])
    off = 22.4 * np.array([math.cos(math.radians(w["direction_deg"])),
                           math.sin(math.radians(w["direction_deg"]))])
    assert RobotPair(sdss_models(), off).collides(ang)[0]
    assert pair_segment_distances(SPEC, off, ang)[0] == pytest.approx(2 * cal.safe_buffer_mm)
    assert cal.safe_buffer_mm >= cal.safe_buffer_uniform_mm


def test_wasted_space_table(cal):
    b = np.asarray(cal.buffers_mm)
    forb = np.asarray(cal.forbidden_fraction)
    waste = np.asarray(cal.wasted_fraction)
    assert np.all(np.diff(forb) >= 0)                 # a larger buffer forbids more
    assert np.all((waste >= 0) & (waste <= 1))
    assert np.all(waste[b < 1.3] < 0.01)              # below b*, forbidden = colliding
    assert cal.wasted_at(2.5) > 0.2                   # 2.5 mm forbids much 3D-safe space
    assert 0 < cal.colliding_fraction < forb[-1]


def test_angular_error_share_is_positive_and_below_the_analytic_bound(cal):
    # a commanded configuration moves each 2D segment point by at most
    # l_alpha ea + 15 (ea + eb): the paper's sigma_eps is an upper bound of the share
    assert cal.paper_sigma_eps_mm == pytest.approx(0.974, abs=1e-3)
    assert 0.1 < cal.mc_share_mm <= cal.corner_share_mm + 1e-9
    assert cal.corner_share_mm <= cal.paper_sigma_eps_mm + 1e-9
    assert cal.mc_buffer_mm == pytest.approx(cal.safe_buffer_mm + cal.mc_share_mm)


def test_no_angular_error_needs_no_extra_buffer_and_same_seed_same_result():
    kw = dict(SMALL, n_samples=1024, n_draws=5, n_scatter=20)
    a = calibrate_buffer(SPEC, GEOM, angular_error_deg=(0.0, 0.0), **kw)
    # every draw is the error-free problem again (each with its own local search)
    assert a.mc_share_mm == pytest.approx(0.0, abs=1e-4)
    assert a.corner_share_mm == pytest.approx(0.0, abs=1e-4)
    b = calibrate_buffer(SPEC, GEOM, angular_error_deg=(0.0, 0.0), **kw)
    assert a.safe_buffer_mm == b.safe_buffer_mm and a.worst == b.worst
    assert a.wasted_fraction == b.wasted_fraction


def test_a_wider_user_arm_needs_a_wider_buffer():
    wide = GEOM.with_params(beta_half_width_mm=2.0, beta_rear_mm=2.0)
    c = calibrate_buffer(SPEC, wide, **dict(SMALL, n_draws=5, n_scatter=20))
    assert c.envelope_mm == pytest.approx(2.0)
    assert 1.97 <= c.safe_buffer_mm <= 2.0 + 1e-9


def test_a_housing_that_reaches_the_neighbour_cannot_be_covered_by_the_2d_buffer():
    # alpha arms of reach 11.6 > 22.4 / 2 touch whatever the beta arms do: the 2D model
    # (beta segments only) would need a buffer far above any sensible value
    big = GEOM.with_params(alpha_housing_radius_mm=4.2)
    c = calibrate_buffer(SPEC, big, **dict(SMALL, n_draws=5, n_scatter=20))
    assert c.worst["links"] == "alpha-alpha"
    assert c.safe_buffer_mm > 3.5 > c.spec_buffer_mm


@pytest.mark.parametrize("kw,field", [({"probability": 0.0}, "probability"),
                                      ({"n_samples": 10}, "n_samples"),
                                      ({"angular_error_deg": (1.0, -1.0)}, "angular_error_deg"),
                                      ({"buffers_mm": ()}, "buffers_mm")])
def test_bad_settings_name_the_field(kw, field):
    with pytest.raises(SpecError, match=field):
        calibrate_buffer(SPEC, GEOM, **kw)
