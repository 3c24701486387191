"""Tests of the whole 3D check (validation/mesh3d/check.py) on hand-built trajectories.

Robot 1 is parked at alpha = beta = 180 (tests/validation/conftest.py): its beta bar
lies along +x from its beta axis at (15, 0), the rear end a half-disk of radius 1.5
centred there. Robot 0 holds alpha = 0 and turns its beta arm to angle ``b``: the two
bars (half-width 1.5, same height) are ``7.6 sin b - 3`` apart and touch for ``b <=
asin(3 / 7.6) = 23.25`` deg.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from rfp_twin.models.errors import SpecError, TrajectoryError, UnknownRobotError
from rfp_twin.models.geometry import load_geometry
from rfp_twin.models.trajectory import Trajectory
from tests.validation.conftest import (SPEC, pair_layout, sdss_geometry, sdss_models, static,
                                       swing, whole_link_distance)
from rfp_twin.validation.checker2d import check_trajectory
from rfp_twin.validation.mesh3d import validate_trajectory

GEOM = sdss_geometry()
MODELS = sdss_models()
B_TOUCH = math.degrees(math.asin(3.0 / 7.6))      # 23.25 deg


# -- hand-built trajectories -------------------------------------------------------------
def test_a_contact_lasting_a_quarter_millisecond_is_caught():
    # beta 90 -> 20 -> 90 deg in 5 ms: bars overlap while b <= 23.25 deg, 0.23 ms
    traj = swing([0.0, 0.1, 0.1025, 0.105, 0.2], [90.0, 90.0, 20.0, 90.0, 90.0], 0.2)
    rate = 70.0 / 0.0025
    t_in = 0.1 + (90.0 - B_TOUCH) / rate
    t_out = 0.105 - (90.0 - B_TOUCH) / rate
    assert 2e-4 < t_out - t_in < 3e-4
    # a plain 10 ms sampling sees nothing
    grid = np.arange(0.0, 0.2001, 0.01)
    beta = traj.sample(grid)[:, 0, 1]
    assert np.all(7.6 * np.sin(np.radians(beta)) - 3.0 > 0.3)

    rep = validate_trajectory(traj, SPEC, pair_layout(), GEOM, resolution_s=1e-5)
    assert not rep.ok
    assert len(rep.collisions) == 1
    c = rep.collisions[0]
    assert (c.kind, c.robot_a, c.link_a, c.other, c.link_b) == ("robot", 0, "beta", 1, "beta")
    assert not c.conservative and c.min_distance_mm == 0.0
    # the mesh is a polygon inscribed in the outline: contact a little later / earlier
    assert t_in - 1e-5 <= c.t_start <= t_in + 5e-5
    assert t_out - 5e-5 <= c.t_end <= t_out + 1e-5
    assert rep.pairs[0].min_distance_mm == 0.0


def test_2d_safe_but_3d_colliding_beta_housing_is_caught():
    # a beta-motor housing of radius 4.2 mm: 7.4 + 4.2 = 11.6 > 22.4 / 2, so two alpha
    # arms pointing at each other touch while the beta arms point away (2D-clear)
    geom = GEOM.with_params(alpha_housing_radius_mm=4.2)
    traj = static([[0.0, 180.0], [180.0, 180.0]])
    assert check_trajectory(traj, SPEC, pair_layout(), 2.5).ok
    rep = validate_trajectory(traj, SPEC, pair_layout(), geom)
    assert not rep.ok
    assert {(c.link_a, c.link_b) for c in rep.collisions} == {("alpha", "alpha")}
    # the preset housing (3.2 mm) stays clear, with the analytic gap 22.4 - 2 * 10.6 = 1.2
    rep = validate_trajectory(traj, SPEC, pair_layout(), GEOM)
    assert rep.ok


def test_2d_safe_but_3d_colliding_user_mesh_is_caught(tmp_path):
    # a user's beta arm 4.4 mm wide (CAD file) against a 2D buffer of 2.0 mm
    wide = GEOM.with_params(beta_half_width_mm=2.2, beta_rear_mm=2.2).links["beta"].visual
    wide.export(tmp_path / "wide_beta.stl")
    toml = tmp_path / "wide.toml"
    toml.write_text('extends = "sdss-v"\n[geometry.meshes]\nbeta = "wide_beta.stl"\n')
    geom = load_geometry(toml)
    b = math.degrees(math.asin(4.2 / 7.6))            # 2D segment distance 4.2 > 2 * 2.0
    traj = static([[0.0, b], [180.0, 180.0]])
    assert check_trajectory(traj, SPEC, pair_layout(), 2.0).ok
    rep = validate_trajectory(traj, SPEC, pair_layout(), geom)
    assert not rep.ok
    assert rep.collisions[0].link_a == "beta" and rep.collisions[0].link_b == "beta"
    assert "wide.toml" in rep.geometry


def test_2d_colliding_but_3d_clear_is_reported_clear():
    b = math.degrees(math.asin(4.0 / 7.6))            # 2D distance 4.0 < 2 * 2.5
    traj = static([[0.0, b], [180.0, 180.0]])
    assert not check_trajectory(traj, SPEC, pair_layout(), 2.5).ok
    rep = validate_trajectory(traj, SPEC, pair_layout(), GEOM)
    assert rep.ok and rep.collisions == []
    # bars 1.5 mm half-wide: 4.0 - 3.0 = 1.0 mm, plus at most the rear arc's sagitta
    assert 1.0 - 1e-9 <= rep.min_distance_mm <= 1.0 + 0.01
    assert rep.pairs[0].links == ("beta", "beta")


def test_fiducial_collision_is_reported_with_its_id():
    # robot 0 (alpha 90, elbow at (0, 7.4)) sweeps its arm from -x (beta 90) to +y
    # (beta 0), over the fiducial at (0, 20) (radius 1 mm), and back
    lay = pair_layout(fiducial=True)
    traj = Trajectory.from_breakpoints([0, 1], [[0, 1], [0, 1]], [[90, 90], [180, 180]],
                                       [[0, 0.5, 1], [0, 1]], [[90, 0, 90], [180, 180]])
    rep = validate_trajectory(traj, SPEC, lay, GEOM)
    assert not rep.ok
    kinds = {(c.kind, c.robot_a, c.link_a, c.other, c.link_b) for c in rep.collisions}
    assert kinds == {("fiducial", 0, "beta", 7, "fiducial")}
    c = rep.collisions[0]
    assert c.t_start < 0.5 < c.t_end
    # the 2D model sees it too (fiducial keep-out 1.5 mm)
    assert not check_trajectory(traj, SPEC, lay, 2.5).ok


def test_pair_minimum_matches_a_dense_exact_sampling():
    # two robots moving at once; the report's minimum is within the tolerance of the
    # minimum of 1001 exact (whole-mesh FCL) samples, and not below it by more than
    # the motion between samples
    traj = Trajectory.from_breakpoints(
        [0, 1], [[0, 1, 2], [0, 2]], [[0, 5, 0], [180, 178]],
        [[0, 1.1, 2], [0, 0.9, 2]], [[90, 26, 90], [180, 184, 180]])
    rep = validate_trajectory(traj, SPEC, pair_layout(), GEOM, distance_tol_mm=0.002,
                              distance_rel_tol=0.0)
    assert rep.ok and 0.9 < rep.pairs[0].t_min < 1.3
    times = np.linspace(0, 2, 1001)
    ang = traj.sample(times)
    ref = np.inf
    for k in range(len(times)):
        for la_, lb_ in (("beta", "beta"), ("alpha", "beta"), ("beta", "alpha")):
            d = whole_link_distance(GEOM, (0, 0), ang[k, 0], la_, (22.4, 0), ang[k, 1], lb_)
            ref = min(ref, d)
    # each link point moves < 40 mm/s here: 2 ms between samples moves the distance < 0.08
    assert rep.min_distance_mm <= ref + 0.002 + 1e-9
    assert rep.min_distance_mm >= ref - 0.08



def test_a_poor_seed_changes_nothing_the_report_guarantees(monkeypatch):
    # the seeds are GJK upper bounds; the minimum and the collisions must stay right
    # however far above the exact value a seed is (here 0.4 mm on every seed)
    from rfp_twin.validation.mesh3d.exact import ExactDistance
    traj = Trajectory.from_breakpoints(
        [0, 1], [[0, 1, 2], [0, 2]], [[0, 5, 0], [180, 178]],
        [[0, 1.1, 2], [0, 0.9, 2]], [[90, 26, 90], [180, 184, 180]])
    kw = dict(distance_tol_mm=0.002, distance_rel_tol=0.0)
    good = validate_trajectory(traj, SPEC, pair_layout(), GEOM, **kw)
    plain = ExactDistance.distance_frames

    def inflated(self, ka, fa, kb, fb, bounds, upper_above=None):
        d = plain(self, ka, fa, kb, fb, bounds)
        return d + 0.4 if upper_above is not None and d > upper_above else d

    monkeypatch.setattr(ExactDistance, "distance_frames", inflated)
    poor = validate_trajectory(traj, SPEC, pair_layout(), GEOM, **kw)
    assert poor.ok and good.ok
    assert poor.n_fcl_calls > good.n_fcl_calls          # the exact step did the work
    assert abs(poor.min_distance_mm - good.min_distance_mm) <= 0.002 + 1e-9
    hit = swing([0.0, 1.0], [30.0, 20.0], 1.0)          # robot 0's bar into robot 1's
    rep = validate_trajectory(hit, SPEC, pair_layout(), GEOM)
    assert len(rep.collisions) == 1 and rep.collisions[0].t_end == pytest.approx(1.0)

# -- bad input ---------------------------------------------------------------------------
def test_unknown_robot_duplicate_ids_and_jumps_are_refused():
    with pytest.raises(UnknownRobotError):
        validate_trajectory(static([[0, 180], [0, 180]], ids=(0, 5)), SPEC, pair_layout(), MODELS)
    with pytest.raises(TrajectoryError, match="more than once"):
        validate_trajectory(static([[0, 180], [0, 180]], ids=(0, 0)), SPEC, pair_layout(),
                            MODELS)
    jump = Trajectory([0, 1], ((np.array([0.0, 1.0]), np.array([0.0, 1.0])),
                               (np.array([0.0, 0.5, 0.5, 1.0]), np.array([0.0, 1.0]))),
                      ((np.array([0.0, 0.0]), np.array([180.0, 180.0])),
                       (np.array([90.0, 90.0, 40.0, 40.0]), np.array([180.0, 180.0]))))
    with pytest.raises(TrajectoryError, match="jumps"):
        validate_trajectory(jump, SPEC, pair_layout(), MODELS)


@pytest.mark.parametrize("kw", [{"min_gap_mm": -1.0}, {"resolution_s": 0.0},
                                {"distance_tol_mm": float("nan")}, {"coarse_mm": 0}])
def test_bad_settings_name_the_field(kw):
    with pytest.raises(SpecError, match=list(kw)[0]):
        validate_trajectory(static([[0, 180], [180, 180]]), SPEC, pair_layout(), MODELS, **kw)
