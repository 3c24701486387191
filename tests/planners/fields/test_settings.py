"""Parameters of the potential-field planners and their resolved distances: planners/fields/settings.py."""
from __future__ import annotations

import pytest

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.errors import SpecError
from rfp_twin.models.layout import Layout
from rfp_twin.planners.fields import ApfSettings, apf_target_margin_mm
from tests.planners.fields.cases import DESI, SDSS, desi_geom


@pytest.mark.parametrize("kwargs, field, allowed", [
    ({"model": "capsule"}, "model", "tip | segment"),
    ({"lambda1": 0.0}, "lambda1", "(0, 1000]"),
    ({"lambda2": -1.0}, "lambda2", "(0, 1000]"),
    ({"lambda3": 1.0}, "lambda3", "[0, lambda1 = 1.0)"),
    ({"gain": float("nan")}, "gain", "(0, 1000] 1/s"),
    ({"d_mm": 3.0, "D_mm": 2.0}, "D_mm", "(3.0, 100] mm (D > d)"),
    ({"dt_s": 0.5}, "dt_s", "(0, 0.1] s"),
    ({"tol_mm": 0.0}, "tol_mm", "(0, 10] mm"),
    ({"speed_deg_s": (30.0,)}, "speed_deg_s", "(alpha, beta) deg/s"),
    ({"singular_band_deg": 60.0}, "singular_band_deg", "[0, 45] deg"),
    ({"max_points": 1}, "max_points", "an integer >= 2"),
])
def test_settings_errors_name_field_and_range(kwargs, field, allowed):
    with pytest.raises(SpecError) as exc:
        ApfSettings(**kwargs)
    msg = str(exc.value)
    assert f"field '{field}'" in msg and allowed in msg


def test_resolved_distances_tip_and_segment():
    geom = desi_geom(7)
    d, D, d_f, D_f, margin = ApfSettings().distances(geom)
    assert (d, D, margin) == (2.0, 4.0, 0.0)
    assert d_f == pytest.approx(1.0 + DESI.fiducial_buffer_mm) and D_f == pytest.approx(d_f + 2.0)
    sg = ArrayGeometry(SDSS, Layout.hex_grid_positions(7, SDSS.pitch_mm), 2.5)
    d, D, _, _, margin = ApfSettings(model="segment").distances(sg)
    # margin covers one Euler step of two arms at 30 deg/s (~0.2 mm) plus simplification
    assert 0.15 < margin < 0.3 and d == pytest.approx(5.0 + margin) and D == pytest.approx(d + 2.0)
    assert apf_target_margin_mm(sg, ApfSettings(model="segment")) == pytest.approx(margin)
    assert apf_target_margin_mm(geom, ApfSettings()) == 0.0


def test_explicit_distances_and_speeds_override_the_defaults():
    sg = ArrayGeometry(SDSS, Layout.hex_grid_positions(7, SDSS.pitch_mm), 2.5)
    s = ApfSettings(model="segment", margin_mm=0.5, speed_deg_s=(10.0, 20.0))
    d, D, d_f, D_f, margin = s.distances(sg)
    assert (margin, d, D) == (0.5, 5.5, 7.5)
    assert d_f == pytest.approx(2.5 + SDSS.fiducial_buffer_mm + 0.5) and D_f == pytest.approx(d_f + 2.0)
    assert s.speeds_deg_s(sg) == (10.0, 20.0)
    assert ApfSettings().speeds_deg_s(sg) == tuple(SDSS.max_speed_deg_s)
    # a slower Euler step shrinks the margin that covers the motion between samples
    assert ApfSettings(model="segment", dt_s=0.005).distances(sg)[4] < \
        ApfSettings(model="segment").distances(sg)[4]
