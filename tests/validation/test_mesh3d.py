"""Tests of the 3D (FCL) validation, validation/mesh3d.py.

Geometry used throughout (SDSS-V preset): robot 0 at the origin, robot 1 at (22.4, 0)
parked at alpha = beta = 180, so its beta bar lies along +x from its beta axis at
(15, 0), the rear end a half-disk of radius 1.5 centred there. Robot 0 holds alpha = 0
and turns its beta arm to angle ``b``: its centre line passes the point (15, 0) at
``7.6 sin b`` (``b <= 90`` deg), so the two bars (half-width 1.5, same height) are
``7.6 sin b - 3`` apart and touch for ``b <= asin(3 / 7.6) = 23.25`` deg.
"""
from __future__ import annotations

import json
import math

import fcl
import numpy as np
import pytest
import trimesh

from models.errors import SpecError, TrajectoryError, UnknownRobotError
from models.geometry import LINKS, geometry_for_spec, load_geometry
from models.layout import Layout
from models.robot import load_spec
from models.trajectory import Trajectory
from validation.checker2d import check_trajectory, segment_distance_np
from validation.mesh3d import (Check3DReport, LinkModels, RobotPair,
                               fit_capsule, link_pose, validate_trajectory)
from validation.mesh3d.bounds import poly_lower_bound as _poly_lb
from validation.mesh3d.exact import ExactDistance as _Exact

SPEC = load_spec("sdss-v")
GEOM = geometry_for_spec(SPEC)
MODELS = LinkModels.from_geometry(GEOM)
B_TOUCH = math.degrees(math.asin(3.0 / 7.6))      # 23.25 deg


def pair_layout(fiducial: bool = False) -> Layout:
    if fiducial:
        return Layout([0, 1, 7], [[0.0, 0.0], [22.4, 0.0], [0.0, 20.0]],
                      ["robot", "robot", "fiducial"], name="pair+fid")
    return Layout([0, 1], [[0.0, 0.0], [22.4, 0.0]], ["robot", "robot"], name="pair")


def swing(beta_times, beta_angles, duration) -> Trajectory:
    """Robot 0 moves its beta arm (alpha 0); robot 1 is parked at (180, 180)."""
    return Trajectory.from_breakpoints(
        [0, 1], [[0.0, duration], [0.0, duration]], [[0.0, 0.0], [180.0, 180.0]],
        [beta_times, [0.0, duration]], [beta_angles, [180.0, 180.0]])


def static(angles, ids=(0, 1)) -> Trajectory:
    """Every robot holds its (alpha, beta) for one second."""
    angles = np.asarray(angles, float).reshape(-1, 2)
    return Trajectory.from_breakpoints(
        list(ids), [[0.0, 1.0]] * len(ids), [[a, a] for a in angles[:, 0]],
        [[0.0, 1.0]] * len(ids), [[b, b] for b in angles[:, 1]])


_WHOLE_BVH: dict = {}


def whole_link_distance(geom, base_a, ang_a, link_a, base_b, ang_b, link_b) -> float:
    """Reference: FCL distance of the whole (concatenated) collision meshes of two posed
    links, built here independently of mesh3d's per-piece pruning."""
    def obj(base, ang, name):
        key = (id(geom), name)
        if key not in _WHOLE_BVH:
            mesh = geom.links[name].collision_mesh
            bvh = fcl.BVHModel()
            bvh.beginModel(len(mesh.vertices), len(mesh.faces))
            bvh.addSubModel(mesh.vertices, mesh.faces.astype(np.int32))
            bvh.endModel()
            _WHOLE_BVH[key] = bvh
        t = geom.link_transform(name, *ang)
        return fcl.CollisionObject(_WHOLE_BVH[key],
                                   fcl.Transform(t[:3, :3], t[:3, 3] + [*base, 0.0]))

    return max(0.0, fcl.distance(obj(base_a, ang_a, link_a), obj(base_b, ang_b, link_b)))


# -- link models -----------------------------------------------------------------------
def test_link_pose_is_the_geometry_transform():
    rng = np.random.default_rng(3)
    for name in ("body", "alpha", "beta", "fiducial"):
        k = LINKS.index(name)
        for a, b in rng.uniform(-400, 400, (5, 2)):
            pose = link_pose(MODELS, k, (3.0, -2.0), a, b)
            t = GEOM.link_transform(name, a, b)
            c, s = math.cos(pose[0]), math.sin(pose[0])
            np.testing.assert_allclose([[c, -s], [s, c]], t[:2, :2], atol=1e-12)
            np.testing.assert_allclose(pose[1:], t[:3, 3] + [3.0, -2.0, 0.0], atol=1e-12)


def test_capsules_and_z_intervals_enclose_every_piece():
    for k, name in enumerate(LINKS):
        oz = MODELS.offset_z[k]
        for j, piece in enumerate(GEOM.links[name].collision):
            u = MODELS.kind_ptr[k] + j
            x0, y0, x1, y1, r = MODELS.cap[u]
            v = piece.vertices
            d = segment_distance_np(v[:, :2], v[:, :2], np.array([x0, y0]), np.array([x1, y1]))
            assert np.all(d <= r + 1e-9)
            assert MODELS.zlim[u, 0] <= v[:, 2].min() + oz + 1e-12
            assert MODELS.zlim[u, 1] >= v[:, 2].max() + oz - 1e-12


def test_fit_capsule_is_tight_on_a_stadium():
    t = np.linspace(0, 2 * np.pi, 200, endpoint=False)
    pts = np.vstack([np.column_stack([0.5 * np.cos(t) - 3, 0.5 * np.sin(t)]),
                     np.column_stack([0.5 * np.cos(t) + 3, 0.5 * np.sin(t)])])
    seg, r = fit_capsule(pts)
    assert r == pytest.approx(0.5, abs=1e-3)
    assert np.hypot(*(seg[1] - seg[0])) == pytest.approx(6.0, abs=0.02)


def _polygon_distance(p, q) -> float:
    """Brute force: 0 if the convex CCW polygons overlap, else the least vertex-edge distance."""
    def inside(pts, poly):
        for x in pts:
            e = np.roll(poly, -1, axis=0) - poly
            w = x - poly
            if np.all(e[:, 0] * w[:, 1] - e[:, 1] * w[:, 0] >= 0):
                return True
        return False

    def cross(a, b, c, d):
        def o(p_, q_, r_):
            return np.sign((q_[0] - p_[0]) * (r_[1] - p_[1]) - (q_[1] - p_[1]) * (r_[0] - p_[0]))

        return o(a, b, c) != o(a, b, d) and o(c, d, a) != o(c, d, b)

    if inside(p, q) or inside(q, p):
        return 0.0
    for i in range(len(p)):
        for j in range(len(q)):
            if cross(p[i], p[(i + 1) % len(p)], q[j], q[(j + 1) % len(q)]):
                return 0.0
    best = np.inf
    for a, b in ((p, q), (q, p)):
        for i in range(len(b)):
            s0, s1 = b[i], b[(i + 1) % len(b)]
            best = min(best, segment_distance_np(a, a, s0, s1).min())
    return float(best)


def test_hull_prism_bound_is_the_polygon_distance_and_never_above_it():
    from scipy.spatial import ConvexHull

    rng = np.random.default_rng(7)
    gaps = []
    for _ in range(300):
        a = rng.normal(size=(rng.integers(3, 15), 2)) * rng.uniform(0.3, 3)
        b = rng.normal(size=(rng.integers(3, 15), 2)) * rng.uniform(0.3, 3)
        a, b = a[ConvexHull(a).vertices], b[ConvexHull(b).vertices]
        pxy = np.vstack([a, b])
        pptr = np.array([0, len(a), len(a) + len(b)])
        t1, t2 = rng.uniform(0, 2 * np.pi, 2)
        ox, oy = rng.normal(size=2) * 4
        lb = _poly_lb(0, 1, math.cos(t1), math.sin(t1), 0.0, 0.0, math.cos(t2), math.sin(t2),
                      ox, oy, pptr, pxy)
        def rot(t):
            return np.array([[math.cos(t), -math.sin(t)], [math.sin(t), math.cos(t)]])

        ref = _polygon_distance(a @ rot(t1).T, b @ rot(t2).T + [ox, oy])
        gaps.append(ref - lb)
    gaps = np.array(gaps)
    assert gaps.min() > -1e-9          # a lower bound
    assert gaps.max() < 1e-9           # and exact (GJK converges on polygons)


# -- FCL against an analytic distance -----------------------------------------------------
def test_fcl_distance_of_capsule_meshes_matches_the_analytic_distance(tmp_path):
    # the beta link replaced by a capsule mesh (axis x in [0, 15] at z = 1, radius 1.2):
    # two robots' capsules at one height are 2D segment distance - 2 r apart
    r, n = 1.2, 32
    cap = trimesh.creation.capsule(height=15.0, radius=r, count=[n, n])
    cap.apply_transform(trimesh.transformations.rotation_matrix(math.pi / 2, [0, 1, 0]))
    cap.apply_translation([7.5 - cap.bounds.mean(axis=0)[0], 0.0, 1.0])
    cap.export(tmp_path / "capsule.stl")
    toml = tmp_path / "capsule.toml"
    toml.write_text('extends = "sdss-v"\n[geometry.meshes]\nbeta = "capsule.stl"\n')
    geom = load_geometry(toml)
    pair = RobotPair(LinkModels.from_geometry(geom), (22.4, 0.0))
    rng = np.random.default_rng(11)
    ang = rng.uniform(0, 360, (400, 4))
    la = SPEC.alpha_length_mm
    a0, b0, a1, b1 = np.deg2rad(ang).T
    e0 = np.column_stack([la * np.cos(a0), la * np.sin(a0)])
    e1 = np.column_stack([22.4 + la * np.cos(a1), la * np.sin(a1)])
    f0 = e0 + 15.0 * np.column_stack([np.cos(a0 + b0), np.sin(a0 + b0)])
    f1 = e1 + 15.0 * np.column_stack([np.cos(a1 + b1), np.sin(a1 + b1)])
    analytic = segment_distance_np(e0, f0, e1, f1) - 2 * r
    near = (analytic > 0.05) & (analytic < 4.0)
    assert near.sum() > 20
    d, links = pair.distances(ang[near], with_links=True)
    assert all(lk == ("beta", "beta") for lk in links)
    # inscribed tessellation: never closer than the true surfaces, at most two sagittas
    # farther (STL and the CAD slabs store float32 vertices: 1e-5 mm)
    sagitta = r * (1 - math.cos(math.pi / n)) * 2
    assert np.all(d >= analytic[near] - 1e-5)
    assert np.all(d <= analytic[near] + 2 * sagitta + 1e-5)


def test_bounds_are_exact_on_the_procedural_prisms_and_below_fcl():
    pair = RobotPair(MODELS, (22.4, 0.0))
    ang = np.random.default_rng(2).uniform(0, 360, (300, 4))
    lb = pair.bounds(ang)
    d = pair.distances(ang)
    assert np.all(lb <= d + 1e-9)
    np.testing.assert_allclose(lb, d, atol=1e-7)
    np.testing.assert_array_equal(pair.collides(ang), d <= 0.0)


def test_a_piece_inside_another_counts_as_touching():
    # robot B's ferrule placed inside robot A's beta bar: the surfaces do not meet, so
    # FCL's BVH distance is positive; the solid distance is 0
    ex = _Exact(MODELS)
    k = LINKS.index("beta")
    za = MODELS.offset_z[k]
    pose_a = (0.0, 0.0, 0.0)
    pose_b = (0.0, 0.0, 0.0)
    zb = za + 1.8                      # ferrule (z -1..0 in its frame) -> bar height 0.8..1.8
    ferrule = MODELS.kind_ptr[k] + 2
    bar = MODELS.kind_ptr[k]
    o1 = fcl.CollisionObject(MODELS.bvh[bar], fcl.Transform(np.eye(3), np.array([0, 0, za])))
    o2 = fcl.CollisionObject(MODELS.bvh[ferrule], fcl.Transform(np.eye(3), np.array([0, 0, zb])))
    assert fcl.distance(o1, o2) > 0.1
    bounds = np.full(9, -1.0)
    assert ex.distance(k, pose_a, za, k, pose_b, zb, bounds) == 0.0
    assert ex.collides(k, pose_a, za, k, pose_b, zb, bounds)


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


def test_report_serialises_and_counts_work():
    traj = swing([0.0, 1.0], [90.0, 30.0], 1.0)
    rep = validate_trajectory(traj, SPEC, pair_layout(), MODELS)
    assert isinstance(rep, Check3DReport)
    d = json.loads(json.dumps(rep.to_dict()))
    assert d["ok"] and d["n_pairs"] == 1 and d["n_collisions"] == 0
    assert d["n_fcl_calls"] >= 1 and d["n_exact_evals"] >= 1 and d["n_capsule_evals"] > 0
    assert set(d["link_kind_min_mm"]) == {"alpha-beta", "beta-beta"}
    assert "3D check (FCL): OK" in rep.table()


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
