"""Tests of the side-by-side calibration (estimate bar, P1 prototype, 2D capsule model) and
of the metrology spread (validation/buffer/comparison*.py, metrology.py, pairs.py).

Facts used: the P1 prototype beta arm (kaiju, 2019) is a tube whose base sphere has a
radius of 3.4372 mm, so its planar envelope around the 2D segment is 3.4372 mm against
the estimate bar's 1.5 mm; the SDSS-V calibrations (APO, LCO) measure 500 robots each.
Runs are kept small (P1 with 12 facets per circle instead of 32: the same tube, coarser).
"""
from __future__ import annotations

import json
import math

import fcl
import numpy as np
import pytest

from rfp_twin.models.errors import SpecError
from rfp_twin.models.geometry import load_geometry
from rfp_twin.validation.buffer import (MetrologySpread, calibrate_buffer, compare_buffers,
                                        perturbed_configurations, write_comparison)
from rfp_twin.validation.buffer.model2d import required_buffer
from rfp_twin.validation.buffer.montecarlo import ErrorBuffer
from rfp_twin.validation.buffer.pairs import CapsulePairs, MeshPairs
from rfp_twin.validation.buffer.sampling import uniform_configurations
from rfp_twin.validation.mesh3d import RobotPair
from tests.validation.conftest import SMALL, SPEC, sdss_geometry, sdss_models

TINY = dict(n_samples=1024, n_draws=8, n_scatter=20, mc_rounds=2, mc_starts=1, seed=3)
LA = SPEC.alpha_length_mm


@pytest.fixture(scope="module")
def p1():
    return load_geometry("sdss-v-p1", SPEC).with_params(circle_sections=12)


@pytest.fixture(scope="module")
def comp(p1):
    return compare_buffers(SPEC, [("estimate bar: sdss-v", sdss_geometry()),
                                  ("P1 prototype: sdss-v-p1", p1)],
                           capsule_radius_mm=1.5, instrument="sdss-v-apo", **TINY)


@pytest.fixture(scope="module")
def spread_runs():
    return {inst: calibrate_buffer(SPEC, sdss_geometry(), instrument=inst, **SMALL)
            for inst in ("sdss-v-apo", "sdss-v-lco")}


# -- P1 against the bar --------------------------------------------------------------------
def test_p1_smallest_safe_buffer_differs_from_the_bar_and_is_a_verified_contact(comp, p1):
    bar, tube, capsule = comp.columns
    assert bar.envelope_mm == pytest.approx(1.5) and tube.envelope_mm == pytest.approx(3.4372)
    assert bar.safe_buffer_mm <= 1.5 + 1e-9
    assert tube.safe_buffer_mm > bar.safe_buffer_mm + 0.9          # a much fatter arm
    assert tube.safe_buffer_mm <= tube.envelope_mm + 1e-9          # only beta arms touch
    w = tube.worst
    assert w["links"] == "beta-beta" and w["d3_mm"] == 0.0
    ang = np.array([[w["alpha_a"], w["beta_a"], w["alpha_b"], w["beta_b"]]])
    off = 22.4 * np.array([math.cos(math.radians(w["direction_deg"])),
                           math.sin(math.radians(w["direction_deg"]))])
    assert MeshPairs(p1, off[None]).classify(ang, np.array([0]))[0]  # FCL: they touch
    assert required_buffer(SPEC, off, ang, 22.4)[0] == pytest.approx(tube.safe_buffer_mm)
    assert capsule.safe_buffer_mm == pytest.approx(1.5, abs=1e-3)   # b* = r by construction
    assert capsule.n_fcl_calls == 0 and tube.n_fcl_calls > 0


def test_the_capsule_column_wastes_nothing_below_its_radius(comp):
    capsule = comp.columns[2]
    b = np.asarray(capsule.buffers_mm)
    waste = np.asarray(capsule.wasted_fraction)
    assert np.all(waste[b <= 1.5 - 1e-9] == 0.0) and np.all(waste[b > 1.6] > 0.0)
    # the 2D-forbidden share depends on the 2D model and samples alone: equal in every column
    assert comp.columns[0].forbidden_fraction == capsule.forbidden_fraction


def test_comparison_report_has_the_three_columns(comp, tmp_path):
    paths = write_comparison(comp, tmp_path / "cmp", command="rfp-twin calibrate-buffer")
    md = paths["markdown"].read_text()
    labels = ["estimate bar: sdss-v", "P1 prototype: sdss-v-p1", "2D capsule model, radius 1.5 mm"]
    head = next(ln for ln in md.splitlines() if ln.startswith("| quantity |"))
    assert head == "| quantity | " + " | ".join(labels) + " |"
    row = next(ln for ln in md.splitlines() if ln.startswith("| (a) b*"))
    assert row.split(" | ")[1:] == [f"{c.safe_buffer_mm:.4f}" for c in comp.columns[:2]] + \
        [f"{comp.columns[2].safe_buffer_mm:.4f} |"]
    for needle in ("(c) b_0.99, angular errors only", "(d) b_0.99, angular errors + sdss-v-apo",
                   "| 2.50 |", "sdss-v-apo"):
        assert needle in md
    data = json.loads(paths["json"].read_text())
    assert [c["geometry"] for c in data["columns"]] == labels
    assert all(c["instrument"] == "sdss-v-apo" for c in data["columns"])
    assert len(paths["columns"]) == 3
    for folder in paths["columns"]:
        assert "## (d) Metrology spread of sdss-v-apo" in (folder / "buffer_calibration.md").read_text()
    for f in paths["figures"]:
        assert f.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "P1 prototype: sdss-v-p1:" in comp.table()


# -- metrology spread ------------------------------------------------------------------------
def test_spread_leaves_the_angular_results_alone_and_raises_b_p(cal, spread_runs):
    """Same seed and draws: parts (a)-(c) are those of the run without an instrument; the
    spread adds to the buffer (strictly on APO)."""
    for inst, s in spread_runs.items():
        assert s.instrument == inst and s.metrology["n_robots"] == 500
        assert s.safe_buffer_mm == cal.safe_buffer_mm and s.mc_buffer_mm == cal.mc_buffer_mm
        assert s.mc_samples_mm == cal.mc_samples_mm and s.wasted_fraction == cal.wasted_fraction
        assert s.spread_buffer_mm >= s.mc_buffer_mm
        assert s.spread_change_mm == pytest.approx(s.spread_buffer_mm - s.mc_buffer_mm)
        assert len(s.spread_samples_mm) == SMALL["n_draws"]
        assert f"metrology spread of {inst}" in s.table()
    assert spread_runs["sdss-v-apo"].spread_buffer_mm > cal.mc_buffer_mm + 0.01
    assert math.isnan(cal.spread_buffer_mm) and cal.instrument == ""


def test_metrology_spread_reads_the_calibration():
    from rfp_twin.models.instrument import calibration_folder, read_calibration

    s = MetrologySpread.from_instrument("sdss-v-apo", 7.4)
    c = read_calibration(calibration_folder("sdss-v-apo"))
    assert s.n_robots == c.n_robots == 500
    np.testing.assert_allclose(s.deviations[:, 0], c.alpha_len - 7.4)
    np.testing.assert_allclose(s.deviations[:, 1], c.fibers[:, 0, 0] - 14.314)
    np.testing.assert_allclose(s.deviations[:, 2:], c.base_offset)
    d = s.draw(np.random.default_rng(0), 2000)
    assert d.shape == (2000, 2, 4) and not np.any(np.all(d[:, 0] == d[:, 1], axis=1))
    assert 0.05 < s.summary()["dy"]["std"] < 0.2 and s.max_displacement_mm() > 0.3
    with pytest.raises(SpecError, match="instrument"):
        MetrologySpread.from_instrument("sdss-v-mars", 7.4)


def test_perturbed_configuration_puts_the_beta_arms_where_the_nominal_ones_are():
    """Independent check with FCL on the posed beta meshes: the perturbed robots (alpha arm,
    beta shift, base offset) at the mapped configuration have their beta arms exactly as
    far apart as the nominal robots at the original one."""
    geom = sdss_geometry()
    mesh = geom.links["beta"].collision_mesh
    z = float(geom.link_transform("beta")[2, 3])
    off = np.array([22.4, 0.0])
    pair = RobotPair(sdss_models(), off)
    ang = uniform_configurations(SPEC, 4096, seed=5)
    near = ang[(pair.bounds(ang) > 0.05) & (pair.bounds(ang) < 1.0)][:12]
    dev = np.array([[0.08, -0.05, 0.3, -0.2], [-0.1, 0.07, -0.25, 0.35]])
    act, ok = perturbed_configurations(near, dev, LA, off)
    assert ok.all() and np.max(np.abs(act - near)) > 0.1            # it did move

    def posed(base, a, b, dv):
        th = math.radians(a + b)
        t = (base + dv[2:] + (LA + dv[0]) * np.array([math.cos(math.radians(a)),
                                                      math.sin(math.radians(a))])
             + dv[1] * np.array([math.cos(th), math.sin(th)]))
        rot = np.array([[math.cos(th), -math.sin(th), 0], [math.sin(th), math.cos(th), 0],
                        [0, 0, 1.0]])
        bvh = fcl.BVHModel()
        bvh.beginModel(len(mesh.vertices), len(mesh.faces))
        bvh.addSubModel(mesh.vertices, mesh.faces.astype(np.int32))
        bvh.endModel()
        return fcl.CollisionObject(bvh, fcl.Transform(rot, [t[0], t[1], z]))

    def beta_distance(c, dv):
        return fcl.distance(posed(np.zeros(2), c[0], c[1], dv[0]), posed(off, c[2], c[3], dv[1]),
                            fcl.DistanceRequest(), fcl.DistanceResult())

    for k in range(len(near)):
        nominal = beta_distance(near[k], np.zeros((2, 4)))
        assert beta_distance(act[k], dev) == pytest.approx(nominal, abs=1e-6)
        assert beta_distance(near[k], dev) != pytest.approx(nominal, abs=1e-3)  # unmapped: off


@pytest.mark.parametrize("k", [0, 1, 2, 3])
def test_each_deviation_moves_the_capsule_buffer_by_half_its_size(k):
    """The capsule robot (r = 1.5) with robot B's alpha arm, beta shift or base offset off
    by 0.4 mm: the 2D model needs 1.5 + 0.4 / 2 mm (the contact can face the deviation)."""
    off = np.array([[22.4, 0.0]])
    pairs = CapsulePairs(SPEC, 1.5, off)
    ang = uniform_configurations(SPEC, 16384, seed=1)
    dirs = np.zeros(len(ang), dtype=np.int64)
    col = pairs.classify(ang, dirs)

    def required(a, d):
        return required_buffer(SPEC, off[d], a, 22.4)

    dev = np.zeros((2, 4))
    dev[1, k] = -0.4 if k >= 2 else 0.4
    b_of = ErrorBuffer(required, pairs.classify, ang[col], dirs[col], np.random.default_rng(0),
                       actual=lambda a, d, m: perturbed_configurations(a, m, LA, off[d]))
    free = b_of(np.zeros(4), 8, 60)[0]
    moved = b_of(np.zeros(4), 8, 60, dev)[0]
    assert free == pytest.approx(1.5, abs=0.01)
    assert moved == pytest.approx(1.7, abs=0.02)


def test_spread_needs_robots_that_touch_only_with_their_beta_arms():
    assert MeshPairs(sdss_geometry(), np.array([[22.4, 0.0]])).other_contacts(1.2) == []
    big = sdss_geometry().with_params(alpha_housing_radius_mm=4.2)   # alpha arms reach 11.6
    assert "alpha-alpha" in MeshPairs(big, np.array([[22.4, 0.0]])).other_contacts(1.2)
    with pytest.raises(SpecError, match="instrument.*alpha-alpha"):
        calibrate_buffer(SPEC, big, instrument="sdss-v-apo", **TINY)


def test_cli_compare_runs_and_bad_combinations_are_one_line_errors(tmp_path):
    import typer
    from typer.testing import CliRunner

    from rfp_twin.twin.cli.validate import EXIT_BAD_INPUT, register

    app = typer.Typer()
    register(app)
    run = lambda *a: CliRunner().invoke(app, ["calibrate-buffer", *map(str, a)])  # noqa: E731
    for args, word in ((["sdss-v", "--out", tmp_path / "x"], "--compare"),
                       (["--compare", "sdss-v", "--geometry", "sdss-v", "--out", tmp_path / "x"],
                        "--geometry"),
                       (["--instrument", "nowhere", "--out", tmp_path / "x", "--samples", "256"],
                        "instrument")):
        r = run(*args)
        assert r.exit_code == EXIT_BAD_INPUT and word in r.output, r.output
    out = tmp_path / "cmp"
    r = run("--preset", "sdss-v", "--compare", "sdss-v", "--out", out, "--samples", "256",
            "--draws", "2", "--seed", "1")
    assert r.exit_code == 0, r.output
    data = json.loads((out / "comparison.json").read_text())
    assert [c["geometry"] for c in data["columns"]] == [
        "estimate bar: sdss-v", "2D capsule model, radius 1.5 mm"]
    assert data["instrument"] == "" and (out / "buffer_comparison.md").is_file()
