"""Sky positions to the focal plane, and mock catalogues (uniform and clustered)."""
from __future__ import annotations

import math
import re

import numpy as np
import pytest
from scipy.spatial import cKDTree

from rfp_twin.models.catalogue import (MAX_MOCK_TARGETS, SKY, TELESCOPES, Disc,
                                       density_per_mm2, mock_catalogue, read_catalogue,
                                       sky_to_focal)
from rfp_twin.models.errors import CatalogueError


def test_plate_scales_and_fields_of_sdss_v():
    apo, lco = TELESCOPES["apo"], TELESCOPES["lco"]
    assert (apo.plate_scale_mm_per_deg, apo.field_radius_deg) == (217.7358, 1.5)
    assert (lco.plate_scale_mm_per_deg, lco.field_radius_deg) == (330.275, 1.1)
    assert apo.field_radius_mm == pytest.approx(326.6037)


def test_gnomonic_projection_about_the_centre():
    s = 217.7358
    x, y = sky_to_focal(np.array([150.0, 150.0, 151.0]), np.array([20.0, 21.0, 20.0]),
                        150.0, 20.0, s)
    assert x[0] == pytest.approx(0.0, abs=1e-12) and y[0] == pytest.approx(0.0, abs=1e-12)
    # one degree north along the meridian: tan(1 deg) in radians, times the scale per radian
    assert x[1] == pytest.approx(0.0, abs=1e-9)
    assert y[1] == pytest.approx(math.tan(math.radians(1.0)) * s * 180 / math.pi, rel=1e-12)
    # one degree of ra at dec 20 is east (+x), about cos(20 deg) degrees of arc
    assert x[2] > 0 and x[2] / s == pytest.approx(math.cos(math.radians(20.0)), rel=2e-3)
    # at the equator the gnomonic xi of a 1-deg offset is tan(1 deg)
    x, y = sky_to_focal(np.array([11.0]), np.array([0.0]), 10.0, 0.0, 1.0)
    assert x[0] == pytest.approx(math.degrees(math.tan(math.radians(1.0))), rel=1e-12)


def test_ra_dec_catalogues_need_a_centre_inside_the_sky(tmp_path):
    p = tmp_path / "sky.csv"
    p.write_text("id,ra_deg,dec_deg\n1,150.0,20.0\n2,150.5,20.2\n")
    cat = read_catalogue(p, field_centre=(150.0, 20.0), plate_scale_mm_per_deg=217.7358)
    assert np.allclose(cat.xy[0], 0.0, atol=1e-9) and cat.xy[1, 1] > 0
    with pytest.raises(CatalogueError, match=r"field 'dec' = 95.0; allowed: \[-90, 90\] deg"):
        read_catalogue(p, field_centre=(150.0, 95.0), plate_scale_mm_per_deg=217.7358)
    with pytest.raises(CatalogueError, match=r"field 'ra' = 360.0"):
        read_catalogue(p, field_centre=(360.0, 0.0), plate_scale_mm_per_deg=217.7358)
    with pytest.raises(CatalogueError, match="need a field centre"):
        read_catalogue(p)
    far = tmp_path / "far.csv"
    far.write_text("id,ra_deg,dec_deg\n1,150.0,20.0\n2,330.0,-20.0\n")
    with pytest.raises(CatalogueError, match=r"far.csv:3: .*90 deg or more"):
        read_catalogue(far, field_centre=(150.0, 20.0), plate_scale_mm_per_deg=217.7358)


def test_densities_per_deg2_and_per_patrol_area():
    assert density_per_mm2(300, "deg2", plate_scale_mm_per_deg=217.7358) == \
        pytest.approx(300 / 217.7358 ** 2)
    assert density_per_mm2(20, "patrol", patrol_area_mm2=40.0) == pytest.approx(0.5)
    for bad in (0.0, -3.0, math.nan, math.inf):
        with pytest.raises(CatalogueError, match="density .*allowed: a finite number > 0"):
            density_per_mm2(bad, "deg2", plate_scale_mm_per_deg=217.7358)
    with pytest.raises(CatalogueError, match="needs a plate scale"):
        density_per_mm2(10, "deg2")
    with pytest.raises(CatalogueError, match="unit 'arcmin2'"):
        density_per_mm2(10, "arcmin2")


def test_uniform_mock_is_seeded_and_has_its_density():
    disc = Disc((0.0, 0.0), TELESCOPES["apo"].field_radius_mm)
    dens = density_per_mm2(1000, "deg2", plate_scale_mm_per_deg=217.7358)
    a = mock_catalogue(np.random.default_rng(3), disc, dens, kind="sky", priority_levels=3)
    b = mock_catalogue(np.random.default_rng(3), disc, dens, kind="sky", priority_levels=3)
    assert np.array_equal(a.xy, b.xy) and np.array_equal(a.priority, b.priority)
    expected = 1000 * TELESCOPES["apo"].field_area_deg2                     # 7069 targets
    assert abs(a.n_targets - expected) < 5 * math.sqrt(expected)
    assert np.all(np.hypot(*a.xy.T) <= disc.radius_mm)
    assert np.all(a.kind == SKY) and set(a.priority.tolist()) == {1.0, 2.0, 3.0}
    assert a.ids.tolist() == list(range(a.n_targets))
    c = mock_catalogue(np.random.default_rng(3), disc, dens, kind="sky", priority=0.001)
    assert np.all(c.priority == 0.001) and np.array_equal(c.xy, a.xy)


def test_clustered_mock_has_the_density_and_is_clumpier_than_uniform():
    disc = Disc((0.0, 0.0), 300.0)
    dens = 0.005
    area = disc.area_mm2
    rng = np.random.default_rng(1)
    counts = [mock_catalogue(rng, disc, dens, process="clustered", children=10,
                             sigma_mm=2.0).n_targets for _ in range(20)]
    # a Thomas process's count has variance ~ mean (1 + children): 20 draws, 5 sigma
    assert abs(np.mean(counts) - dens * area) < 5 * math.sqrt(dens * area * 11 / 20)
    clus = mock_catalogue(np.random.default_rng(2), disc, dens, process="clustered",
                          children=10, sigma_mm=2.0)
    unif = mock_catalogue(np.random.default_rng(2), disc, dens)
    nn = [np.median(cKDTree(c.xy).query(c.xy, k=2)[0][:, 1]) for c in (clus, unif)]
    assert nn[0] < 0.5 * nn[1]


def test_mock_bad_input_says_why():
    disc = Disc((0.0, 0.0), 300.0)
    rng = np.random.default_rng(0)
    with pytest.raises(CatalogueError, match=re.escape(f"at most {MAX_MOCK_TARGETS:.0e} targets")):
        mock_catalogue(rng, disc, 1e3)
    with pytest.raises(CatalogueError, match="allowed: > 0"):
        mock_catalogue(rng, disc, 0.0)
    with pytest.raises(CatalogueError, match="process 'lognormal'"):
        mock_catalogue(rng, disc, 0.01, process="lognormal")
    with pytest.raises(CatalogueError, match="kind 'galaxy'"):
        mock_catalogue(rng, disc, 0.01, kind="galaxy")
    with pytest.raises(CatalogueError, match="sigma_mm"):
        mock_catalogue(rng, disc, 0.01, process="clustered", sigma_mm=0.0)
