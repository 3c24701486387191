"""Tests of rfp_twin.models.coverage: areas reached by the fibers, against geometry."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

from rfp_twin.models.coverage import FOCAL_PLANE, measure_coverage, write_coverage_png
from rfp_twin.models.errors import LayoutError
from rfp_twin.models.layout import Layout, layout_by_name
from rfp_twin.models.robot import load_spec

SDSS = load_spec("sdss-v")                                   # annulus 7.6 .. 22.4 mm


def _robots(xy, **extra) -> Layout:
    xy = np.asarray(xy, dtype=float)
    return Layout(np.arange(len(xy)), xy, ["robot"] * len(xy), "test", extra)


def _lens(a: float, b: float, d: float) -> float:
    """Area of the intersection of two disks of radii a, b with centres d apart."""
    if d >= a + b:
        return 0.0
    if d <= abs(a - b):
        return math.pi * min(a, b) ** 2
    alpha = math.acos((d * d + a * a - b * b) / (2 * d * a))
    beta = math.acos((d * d + b * b - a * a) / (2 * d * b))
    return (a * a * (alpha - math.sin(2 * alpha) / 2) + b * b * (beta - math.sin(2 * beta) / 2))


def _annuli_overlap(r: float, big: float, d: float) -> float:
    """Area common to two annuli r..big whose centres are d apart (inclusion-exclusion)."""
    return _lens(big, big, d) - 2 * _lens(r, big, d) + _lens(r, r, d)


def test_one_robot_covers_its_annulus():
    cov = measure_coverage(_robots([[3.3, -1.7]]), SDSS, spacing_mm=0.05)
    exact = math.pi * (22.4 ** 2 - 7.6 ** 2)
    assert cov.area_mm2["1"] == pytest.approx(exact, rel=1e-3)
    assert cov.area_mm2["2"] == 0.0
    assert cov.fraction is None and cov.focal_plane_area_mm2 == 0.0  # no hull of 1 base
    assert cov.to_dict()["fraction"] is None


@pytest.mark.parametrize("d", [5.0, 12.0, 22.4, 30.0, 40.0])
def test_two_robots_overlap_as_two_annuli_do(d):
    cov = measure_coverage(_robots([[0.0, 0.0], [d, 0.0]]), SDSS, spacing_mm=0.04)
    both = _annuli_overlap(7.6, 22.4, d)
    one = math.pi * (22.4 ** 2 - 7.6 ** 2)
    assert cov.area_mm2["2"] == pytest.approx(both, rel=2e-3, abs=1.0)
    assert cov.area_mm2["1"] == pytest.approx(2 * one - both, rel=1e-3)
    assert cov.area_mm2["3"] == 0.0


def test_per_robot_alpha_column_changes_the_annulus():
    lay = _robots([[0.0, 0.0]], alpha_len_mm=np.array(["15.0"]))   # annulus 0 .. 30 mm
    cov = measure_coverage(lay, SDSS, spacing_mm=0.1)
    assert cov.area_mm2["1"] == pytest.approx(math.pi * 30.0 ** 2, rel=1e-3)


def test_hex7_sdss_v_is_covered_almost_everywhere():
    cov = measure_coverage(Layout.hex_grid(1, 22.4), SDSS, spacing_mm=0.2)
    hexagon = 3 * math.sqrt(3) / 2 * 22.4 ** 2                 # hull of the 6 outer bases
    assert cov.focal_plane == FOCAL_PLANE
    assert cov.focal_plane_area_mm2 == pytest.approx(hexagon, rel=5e-3)
    assert cov.fraction["1"] > 0.999
    assert cov.fraction["2"] > 0.99
    assert 0.5 < cov.fraction["3"] < 1.0
    assert sum(cov.multiplicity.values()) == pytest.approx(1.0)
    assert cov.fraction["3"] == pytest.approx(cov.multiplicity["3"] + cov.multiplicity["4+"])


def test_a_hole_in_the_array_shows_in_the_fraction():
    """Short arms leave gaps between the robots: the measured fraction equals a Monte
    Carlo estimate made with a k-d tree, inside the hull."""
    spec = SDSS.with_overrides(alpha_length_mm=4.0, beta_length_mm=6.0)  # 2 .. 10 mm, pitch 22.4
    lay = Layout.hex_grid(2, 22.4)
    cov = measure_coverage(lay, spec, spacing_mm=0.1)
    rng = np.random.default_rng(0)
    pts = rng.uniform(-2 * 22.4, 2 * 22.4, size=(200_000, 2))
    hexagon_apothem = 2 * 22.4 * math.sqrt(3) / 2                 # hull = hexagon, flat sides at +-y
    inside = np.all(np.abs(pts @ np.array([[np.cos(a), np.sin(a)] for a in
                                           np.radians([90, 30, -30])]).T) <= hexagon_apothem, axis=1)
    nearest, _ = cKDTree(lay.robot_xy).query(pts[inside])      # bases 22.4 mm apart: only
    expected = np.mean((nearest >= 2.0) & (nearest <= 10.0))   # the nearest can reach
    assert cov.fraction["1"] == pytest.approx(expected, abs=0.01)
    assert cov.fraction["1"] < 0.7


def test_raft_instrumented_areas():
    spec = load_spec("raft-6p2")
    lay = layout_by_name("raft:3", 6.2)
    cov = measure_coverage(lay, spec, spacing_mm=0.05)
    assert [r.raft for r in cov.rafts] == [0, 1, 2]
    assert all(r.n_robots == 63 for r in cov.rafts)
    tri = 74.0 ** 2 * math.sqrt(3) / 4
    # the raft's union of 3.6 mm disks, estimated independently by Monte Carlo
    xy = lay.robot_xy[lay.extra["raft"] == "0"]
    rng = np.random.default_rng(1)
    lo, hi = xy.min(axis=0) - 3.6, xy.max(axis=0) + 3.6
    pts = rng.uniform(lo, hi, size=(400_000, 2))
    d, _ = cKDTree(xy).query(pts)
    union = np.mean(d <= 3.6) * np.prod(hi - lo)
    for r in cov.rafts:                                          # all rafts alike
        assert r.triangle_area_mm2 == pytest.approx(tri)
        assert r.area_mm2 == pytest.approx(union, rel=5e-3)
        assert r.fraction == pytest.approx(r.area_mm2 / tri)
        assert 0.85 < r.fraction < 0.95
    assert json.loads(json.dumps(cov.to_dict()))["rafts"][0]["n_robots"] == 63


def test_tiles_do_not_change_the_result(monkeypatch):
    lay = layout_by_name("raft:2", 6.2)
    spec = load_spec("raft-6p2")
    one = measure_coverage(lay, spec, spacing_mm=0.2)
    import rfp_twin.models.coverage.measure as measure

    monkeypatch.setattr(measure, "TILE", 37)
    seen = []
    many = measure_coverage(lay, spec, spacing_mm=0.2, progress=lambda d, t: seen.append((d, t)))
    assert len(seen) > 4 and seen[-1][0] == seen[-1][1]
    assert many.area_mm2 == one.area_mm2 and many.fraction == one.fraction
    assert [r.area_mm2 for r in many.rafts] == [r.area_mm2 for r in one.rafts]
    np.testing.assert_array_equal(many.map.image, one.map.image)


@pytest.mark.parametrize("spacing", [0.0, -1.0, math.nan, 1e-6, "x"])
def test_bad_spacing_names_the_field(spacing):
    with pytest.raises(LayoutError) as info:
        measure_coverage(Layout.hex_grid(1, 22.4), SDSS, spacing_mm=spacing)
    msg = str(info.value)
    assert "'spacing_mm'" in msg and "> 0" in msg and "\n" not in msg


def test_map_png_is_written_atomically(tmp_path):
    cov = measure_coverage(Layout.hex_grid(1, 22.4), SDSS, spacing_mm=0.5)
    path = write_coverage_png(cov, tmp_path / "map.png")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert [p.name for p in tmp_path.iterdir()] == ["map.png"]      # no temp file left
    image = cov.map.image
    assert image.max() >= 4 and image.min() == 0
    x0, x1, y0, y1 = cov.map.extent
    assert x0 < -44.8 and x1 > 44.8 and y0 < -41 and y1 > 41
