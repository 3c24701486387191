"""The 3D check uses each robot's own geometry and each obstacle's own shape
(validation/mesh3d with the layout columns of rfp_twin.models.layout.columns).

Geometry of tests/validation/conftest.py: robot 0 at the origin holds alpha 0 and turns
its beta arm to ``b``; robot 1 at (22.4, 0) is parked at (180, 180), so its bar lies along
+x from its beta axis at (22.4 - l_1, 0), the rear a half-disk of radius 1.5 there. The
bars (half-width 1.5, same height) are ``(22.4 - l_0 - l_1) sin b - 3`` apart: 7.6 sin b - 3
with the spec's 7.4 mm alpha arms.

References are built independently of mesh3d: FCL distances of the whole collision meshes
placed where the MuJoCo model (models/mjcf) puts the bodies after ``mj_forward``.
"""
from __future__ import annotations

import math

import fcl
import mujoco
import numpy as np
import pytest
import trimesh

from rfp_twin.models.geometry import LINKS
from rfp_twin.models.layout import Layout, layout_by_name
from rfp_twin.models.layout.columns import obstacle_arrays
from rfp_twin.models.mjcf import build_model
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.validation.mesh3d import validate_trajectory
from rfp_twin.validation.mesh3d.broadphase import poses_and_bounds
from rfp_twin.validation.mesh3d.links import link_frame, placement
from rfp_twin.validation.mesh3d.scene import Scene
from rfp_twin.validation.numerics import axis_csr, segment_distance_np
from tests.validation.conftest import (PITCH, SPEC, pair_layout, sdss_geometry, sdss_models,
                                       static, swing)

GEOM = sdss_geometry()
MODELS = sdss_models()
LA = SPEC.alpha_length_mm
BETA = LINKS.index("beta")


def columns(base: Layout, **cols) -> Layout:
    """``base`` with per-position columns (one value per position, "" = blank)."""
    return Layout(base.ids, base.xy, base.kinds, name=f"{base.name}-cols",
                  extra={k: [str(v) for v in vals] for k, vals in cols.items()})


def report_dict(rep) -> dict:
    out = rep.to_dict()
    for key in ("seconds", "seconds_broadphase", "seconds_exact"):
        out.pop(key)
    return out


# -- an independent reference: MuJoCo body poses + FCL on the whole meshes -------------------
_BVH: dict = {}


def _fcl(mesh: trimesh.Trimesh, rot, trans, key=None) -> fcl.CollisionObject:
    """An FCL object of ``mesh`` (its BVH cached under ``key``) at ``(rot, trans)``."""
    if key is None or key not in _BVH:
        bvh = fcl.BVHModel()
        bvh.beginModel(len(mesh.vertices), len(mesh.faces))
        bvh.addSubModel(np.asarray(mesh.vertices, float), np.asarray(mesh.faces, np.int32))
        bvh.endModel()
        if key is None:
            return fcl.CollisionObject(bvh, fcl.Transform(np.asarray(rot, float),
                                                          np.asarray(trans, float)))
        _BVH[key] = bvh
    return fcl.CollisionObject(_BVH[key], fcl.Transform(np.asarray(rot, float),
                                                        np.asarray(trans, float)))


def mujoco_reference(layout: Layout, angles: np.ndarray, pairs, per_link: bool = False,
                     twin=None) -> dict:
    """{(robot id, other id): smallest surface distance (0: crossing), mm} of the robot's
    body, alpha and beta meshes against the other's (a robot's, or an obstacle's: the
    fiducial mesh or MuJoCo's wall box, named "gfa"), all placed where MuJoCo (``twin``,
    default built here) puts them; with ``per_link`` a dict {(link, other link): distance}
    per pair instead."""
    twin = twin if twin is not None else build_model(SPEC, layout, GEOM)
    d = twin.make_data(angles)
    idx, m = twin.index, twin.model
    meshes = {n: GEOM.links[n].collision_mesh for n in LINKS}

    robots = set(layout.robot_ids.tolist())

    def links(obj_id: int) -> dict:
        if obj_id in robots:
            k = layout.robot_index(obj_id)
            return {n: _fcl(meshes[n], d.xmat[b].reshape(3, 3), d.xpos[b], n)
                    for n, b in (("body", idx.base_body[k]), ("alpha", idx.alpha_body[k]),
                                 ("beta", idx.beta_body[k]))}
        k = int(np.flatnonzero(layout.fiducial_ids == obj_id)[0])
        geoms = [g for g in np.flatnonzero(idx.geom_fiducial == k) if idx.geom_collision[g]]
        if m.geom_type[geoms[0]] == mujoco.mjtGeom.mjGEOM_BOX:
            g = geoms[0]
            return {"gfa": _fcl(trimesh.creation.box(extents=2 * m.geom_size[g]),
                                d.geom_xmat[g].reshape(3, 3), d.geom_xpos[g])}
        b = idx.fiducial_body[k]
        return {"fiducial": _fcl(meshes["fiducial"], d.xmat[b].reshape(3, 3), d.xpos[b],
                                 "fiducial")}

    objs: dict = {}
    out = {}
    for a_id, b_id in pairs:
        for obj_id in (a_id, b_id):
            if obj_id not in objs:
                objs[obj_id] = links(obj_id)
        la, lb = objs[a_id], objs[b_id]
        dist = {(x, y): max(0.0, fcl.distance(ox, oy)) for x, ox in la.items()
                for y, oy in lb.items()}
        out[(a_id, b_id)] = dist if per_link else min(dist.values())
    return out


# -- alpha arm --------------------------------------------------------------------------------
@pytest.mark.parametrize("robot", [0, 1])
def test_a_longer_alpha_arm_turns_a_clear_pair_into_a_collision(robot):
    traj = static([[0.0, 30.0], [180.0, 180.0]])          # 7.6 sin 30 - 3 = 0.8 mm apart
    nominal = validate_trajectory(traj, SPEC, pair_layout(), GEOM)
    assert nominal.ok and nominal.min_distance_mm == pytest.approx(0.8, abs=0.02)
    lens = [LA, LA]
    lens[robot] = 9.5                                      # 5.5 sin 30 - 3 < 0
    rep = validate_trajectory(traj, SPEC, columns(pair_layout(), alpha_len_mm=lens), GEOM)
    assert not rep.ok
    c = rep.collisions[0]
    assert (c.kind, c.robot_a, c.link_a, c.other, c.link_b) == ("robot", 0, "beta", 1, "beta")
    # in between: clear, at the distance MuJoCo's model of that layout gives
    lens[robot] = 8.4                                      # 6.6 sin 30 - 3 = 0.3 mm
    lay = columns(pair_layout(), alpha_len_mm=lens)
    rep = validate_trajectory(traj, SPEC, lay, GEOM, distance_tol_mm=1e-9, distance_rel_tol=0.0)
    ref = mujoco_reference(lay, np.array([[0.0, 30.0], [180.0, 180.0]]), [(0, 1)])[(0, 1)]
    assert rep.ok and rep.min_distance_mm == pytest.approx(ref, abs=1e-7)
    assert ref == pytest.approx(0.3, abs=0.02) and abs(ref - nominal.min_distance_mm) > 0.4


def test_a_longer_alpha_arm_starts_the_contact_earlier():
    # robot 0's beta 90 -> 20 -> 90 deg in 2 s (70 deg/s): touching for (22.4 - l0 - 7.4)
    # sin b <= 3, from b = 23.25 deg nominally, from b = 30 deg with l0 = 9
    traj = swing([0.0, 1.0, 2.0], [90.0, 20.0, 90.0], 2.0)
    for l0, b_in in ((LA, math.degrees(math.asin(3.0 / 7.6))), (9.0, 30.0)):
        rep = validate_trajectory(traj, SPEC, columns(pair_layout(), alpha_len_mm=[l0, ""]),
                                  GEOM)
        assert len(rep.collisions) == 1
        c = rep.collisions[0]
        # the mesh is a polygon inscribed in the outline: contact a little later
        assert (90.0 - b_in) / 70.0 - 1e-4 <= c.t_start <= (90.0 - b_in) / 70.0 + 0.01
        assert c.t_end == pytest.approx(2.0 - c.t_start, abs=1e-4)


def test_link_speeds_use_each_robots_alpha_arm():
    traj = swing([0.0, 1.0, 2.0], [90.0, 20.0, 90.0], 2.0)
    alpha_turn = Trajectory.from_breakpoints([0, 1], [[0.0, 2.0], [0.0, 2.0]],
                                             [[0.0, 120.0], [180.0, 180.0]],
                                             [[0.0, 2.0], [0.0, 2.0]], [[0.0, 0.0], [180.0, 180.0]])
    lay = columns(pair_layout(), alpha_len_mm=[9.0, ""])
    for tr in (traj, alpha_turn):
        scene = Scene(tr, lay, MODELS, 0.0)
        nominal = Scene(tr, pair_layout(), MODELS, 0.0)
        csr = [(c[0], c[1], c[3]) for c in (axis_csr(tr, ax) for ax in (0, 1))]
        v, _ = scene.link_speeds(scene.models, *csr, 2.0)
        v0, _ = nominal.link_speeds(MODELS, *csr, 2.0)
        w_alpha = math.radians(60.0) if tr is alpha_turn else 0.0
        assert v[0, BETA] == pytest.approx(v0[0, BETA] + 1.6 * w_alpha, abs=1e-12)
        assert np.array_equal(v[1], v0[1])
        assert scene.rad_alpha[BETA] == pytest.approx(MODELS.rad_alpha[BETA] + 1.6)


def test_per_robot_values_that_change_nothing_here_change_nothing_at_all():
    """A third robot far away with its own alpha arm takes the per-robot path of the check;
    the pair's report is the nominal one, bit for bit."""
    base = Layout([0, 1, 2], [[0.0, 0.0], [PITCH, 0.0], [300.0, 0.0]], ["robot"] * 3, name="p3")
    traj = swing([0.0, 1.0, 2.0], [90.0, 20.0, 90.0], 2.0)
    ref = report_dict(validate_trajectory(traj, SPEC, base, GEOM))
    lay = columns(base, alpha_len_mm=["", "", 8.0], z_mm=["", "", 0.0])
    assert placement(lay, MODELS) is not None and Scene(traj, lay, MODELS, 0.0).placed
    assert report_dict(validate_trajectory(traj, SPEC, lay, GEOM)) == ref
    blank = columns(base, alpha_len_mm=[""] * 3, kx=[""] * 3, ky=[""] * 3, kz=[""] * 3)
    assert placement(blank, MODELS) is None
    assert report_dict(validate_trajectory(traj, SPEC, blank, GEOM)) == ref


# -- guide-camera walls -----------------------------------------------------------------------
def wall_layout(segment: bool = True) -> Layout:
    """Robot 0 at the origin, robot 1 far away, gfa row 9 from (-30, 20) to (30, 20) (a
    point at (-30, 20) when not ``segment``)."""
    x2, y2 = ("30.0", "20.0") if segment else ("", "")
    return Layout([0, 1, 9], [[0.0, 0.0], [60.0, 0.0], [-30.0, 20.0]], ["robot", "robot", "gfa"],
                  name="wall", extra={"x2_mm": ["", "", x2], "y2_mm": ["", "", y2]})


def test_a_beta_arm_sweeping_through_the_middle_of_a_guide_camera_edge_is_reported():
    # robot 0 turns alpha 0 -> 180 deg in 2 s with its arm stretched (beta 0): its head
    # reaches the wall's face (y = 19) near alpha 52 deg
    traj = Trajectory.from_breakpoints([0, 1], [[0.0, 2.0], [0.0, 2.0]], [[0.0, 180.0], [0.0, 0.0]],
                                       [[0.0, 2.0], [0.0, 2.0]], [[0.0, 0.0], [180.0, 180.0]])
    rep = validate_trajectory(traj, SPEC, wall_layout(), GEOM)
    assert len(rep.collisions) == 1
    c = rep.collisions[0]
    assert (c.kind, c.robot_a, c.link_a, c.other, c.link_b) == ("fiducial", 0, "beta", 9, "gfa")
    # first contact: the rounded head (radius 1.5 about 7.4 + 14.73 mm out) reaches y = 19
    a_in = math.degrees(math.asin((19.0 - 1.5) / (LA + GEOM.params.head_centre_mm)))
    assert a_in / 90.0 - 1e-4 <= c.t_start <= a_in / 90.0 + 0.005
    assert c.t_end == pytest.approx(2.0 - c.t_start, abs=1e-4)
    assert rep.pairs[0].ids == (0, 9) and rep.pairs[0].links == ("beta", "gfa")
    assert "beta-gfa" in rep.link_kind_min_mm
    # the same row as a point obstacle (its first end, 36 mm away) is never reached
    point = validate_trajectory(traj, SPEC, wall_layout(segment=False), GEOM)
    assert point.ok and point.n_pairs == 0
    # MuJoCo's wall, at alpha 90: touching; at alpha 45: 1.4 mm clear, as the check finds
    arm_up = np.array([[90.0, 0.0], [0.0, 180.0]])
    assert mujoco_reference(wall_layout(), arm_up, [(0, 9)])[(0, 9)] == 0.0
    half = static([[45.0, 0.0], [0.0, 180.0]])
    got = validate_trajectory(half, SPEC, wall_layout(), GEOM, distance_tol_mm=1e-9,
                              distance_rel_tol=0.0).min_distance_mm
    ref = mujoco_reference(wall_layout(), np.array([[45.0, 0.0], [0.0, 180.0]]), [(0, 9)])
    assert got == pytest.approx(ref[(0, 9)], abs=1e-7) and 1.0 < got < 2.0


# -- heights and tilts -------------------------------------------------------------------------
CROSSING = np.array([[0.0, 60.0], [120.0, 60.0]])


def crossing_layout(**robot1) -> Layout:
    """Robots 0, 1 at the pitch; robot 1 gets the given columns. At CROSSING their beta
    bars cross 13 mm from robot 1's base, towards (-11.3, 6.41)."""
    return columns(Layout([0, 1], [[0.0, 0.0], [PITCH, 0.0]], ["robot", "robot"], name="x"),
                   **{k: ["", v] for k, v in robot1.items()})


def tilted(sign: float, z: float = 2.1, deg: float = 2.0) -> dict:
    s = math.sin(math.radians(deg))
    u = sign * np.array([-11.3, 6.41]) / math.hypot(-11.3, 6.41)
    return {"z_mm": z, "kx": s * u[0], "ky": s * u[1], "kz": math.cos(math.radians(deg))}


def test_raised_and_tilted_robots_are_checked_at_their_own_height():
    traj = static(CROSSING)
    tight = dict(distance_tol_mm=1e-9, distance_rel_tol=0.0)
    assert not validate_trajectory(traj, SPEC, crossing_layout(), GEOM).ok
    # raised 2.1 mm: robot 1's bar (7.9 - 9.9) passes 0.1 mm above robot 0's (5.8 - 7.8)
    lay = crossing_layout(z_mm=2.1)
    rep = validate_trajectory(traj, SPEC, lay, GEOM, **tight)
    ref = mujoco_reference(lay, CROSSING, [(0, 1)])[(0, 1)]
    assert rep.ok and rep.min_distance_mm == pytest.approx(0.1, abs=1e-9)
    assert ref == pytest.approx(rep.min_distance_mm, abs=1e-7)
    # tilted 2 deg towards the crossing: it dips into robot 0's arm; away from it: clear
    lay = crossing_layout(**tilted(1.0))
    rep = validate_trajectory(traj, SPEC, lay, GEOM)
    assert not rep.ok and {(c.link_a, c.link_b) for c in rep.collisions} == {("beta", "beta")}
    assert mujoco_reference(lay, CROSSING, [(0, 1)])[(0, 1)] == 0.0
    assert kernel_bounds(Scene(traj, lay, MODELS, 0.0), traj).min() <= 0.0
    lay = crossing_layout(**tilted(-1.0))
    rep = validate_trajectory(traj, SPEC, lay, GEOM, **tight)
    ref = mujoco_reference(lay, CROSSING, [(0, 1)])[(0, 1)]
    assert rep.ok and rep.min_distance_mm == pytest.approx(ref, abs=1e-7)
    assert rep.min_distance_mm > 0.4


def test_the_bounds_hold_for_tilted_links_and_a_tilt_made_contact_is_timed():
    """Robot 1 raised by 2.3 mm (its bar 0.3 mm above robot 0's) and tilted by 1 deg
    towards the crossing: its bar dips onto robot 0's only where they cross far enough out
    (robot 0's beta 60 -> 90 -> 60 deg in 2 s: beyond ~84 deg); the bounds stay below the
    reference's distances and the contact interval is the reference's."""
    lay = crossing_layout(**tilted(1.0, z=2.3, deg=1.0))
    traj = Trajectory.from_breakpoints([0, 1], [[0.0, 2.0], [0.0, 2.0]],
                                       [[0.0, 0.0], [120.0, 120.0]],
                                       [[0.0, 1.0, 2.0], [0.0, 2.0]],
                                       [[60.0, 90.0, 60.0], [60.0, 60.0]])
    scene = Scene(traj, lay, MODELS, 0.0)
    names = scene.models.kind_names
    twin = build_model(SPEC, lay, GEOM)
    times = np.linspace(0.0, 2.0, 201)
    zero = []
    for t in times:
        ang = traj.sample(np.array([t]))[0]
        ref = mujoco_reference(lay, ang, [(0, 1)], per_link=True, twin=twin)[(0, 1)]
        bound = kernel_bounds(scene, traj, float(t))
        for p in range(scene.n_link_pairs):
            assert bound[p] <= ref[(names[scene.lp_ka[p]], names[scene.lp_kb[p]])] + 1e-9
        if ref[("beta", "beta")] == 0.0:
            zero.append(t)
    assert 0.6 < zero[0] < 0.95 and 1.05 < zero[-1] < 1.4        # a contact in the middle
    assert np.allclose(np.diff(zero), times[1])                     # one interval
    rep = validate_trajectory(traj, SPEC, lay, GEOM)
    assert len(rep.collisions) == 1
    c = rep.collisions[0]
    assert (c.link_a, c.link_b) == ("beta", "beta") and not c.conservative
    assert zero[0] - times[1] <= c.t_start <= zero[0] and zero[-1] <= c.t_end <= zero[-1] + times[1]


def test_link_transforms_are_mujocos_body_poses_on_the_curved_wok():
    lay = layout_by_name("sdss-v-curved", PITCH)
    twin = build_model(SPEC, lay, GEOM)
    rng = np.random.default_rng(7)
    angles = rng.uniform(0.0, 360.0, (lay.n_robots, 2))
    d = twin.make_data(angles)
    pl = placement(lay, MODELS)
    tilt = np.degrees(np.arccos(pl.rot[:, 2, 2]))
    picks = list(rng.choice(lay.n_robots, 6, replace=False)) + [int(np.argmax(tilt))]
    assert tilt[picks].max() > 1.5
    idx = twin.index
    for k in picks:
        for name, body in (("body", idx.base_body[k]), ("alpha", idx.alpha_body[k]),
                           ("beta", idx.beta_body[k])):
            rot, trans = link_frame(MODELS, LINKS.index(name), pl.base[k], *angles[k],
                                    l_alpha=pl.alpha_len[k], rot=pl.rot[k])
            np.testing.assert_allclose(trans + [0.0, 0.0, twin.base_z_mm], d.xpos[body],
                                       atol=1e-9, rtol=0)
            np.testing.assert_allclose(rot, d.xmat[body].reshape(3, 3), atol=1e-12, rtol=0)
    # obstacles stand where MuJoCo puts them
    np.testing.assert_allclose(d.xpos[idx.fiducial_body] - [0.0, 0.0, twin.base_z_mm],
                               np.column_stack([pl.obs_a, pl.obs_z]), atol=1e-9, rtol=0)


def kernel_bounds(scene: Scene, traj: Trajectory, t: float = 0.5) -> np.ndarray:
    """(n_link_pairs,) the kernels' lower bound of every link pair of ``scene`` at ``t``."""
    m = scene.models
    pa, ta, aa, _ = axis_csr(traj, 0)
    pb, tb, ab, _ = axis_csr(traj, 1)
    qp = np.arange(scene.n_link_pairs, dtype=np.int64)
    _, bounds = poses_and_bounds(qp, np.full(len(qp), t), scene.lp_oa, scene.lp_ka, scene.lp_ob,
                                 scene.lp_kb, scene.obj_rob, scene.obj_x, scene.obj_y, scene.place,
                                 pa, ta, aa, pb, tb, ab, m.kind_ptr, m.cap, m.zlim, m.poly_ptr,
                                 m.poly_xy, m.max_piece_pairs)
    return bounds.min(axis=1)


@pytest.mark.parametrize("name", ["sdss-v-curved", "sdss-v-apo"])
def test_instrument_check_matches_the_mujoco_posed_reference(name):
    """Robots around a guide camera and a fiducial of a calibrated instrument, random
    configurations: every pair's distance (and every contact) is the reference's."""
    lay = layout_by_name(name, PITCH)
    obs = np.flatnonzero(~lay.robot_mask)
    gfa = obs[lay.kinds[obs] == "gfa"][0]
    mid = (lay.xy[gfa] + np.array([float(lay.extra["x2_mm"][gfa]),
                                   float(lay.extra["y2_mm"][gfa])])) / 2.0
    near = np.argsort(np.hypot(*(lay.robot_xy - mid).T))[:6]
    fid = obs[lay.kinds[obs] == "fiducial"]
    f = fid[np.argmin(np.hypot(*(lay.xy[fid] - lay.robot_xy[near[0]]).T))]
    near = np.union1d(near, np.argsort(np.hypot(*(lay.robot_xy - lay.xy[f]).T))[:3])
    ids = lay.robot_ids[near]
    rng = np.random.default_rng(3 if name == "sdss-v-apo" else 5)
    found = {"robot": 0, "fiducial": 0, "hit": 0, "wall": 0}
    twin = build_model(SPEC, lay, GEOM)
    a, b, _ = obstacle_arrays(SPEC, lay)
    for _ in range(3):
        ang = rng.uniform(0.0, 360.0, (len(ids), 2))
        traj = static(ang, ids=ids)
        rep = validate_trajectory(traj, SPEC, lay, GEOM, distance_tol_mm=1e-9,
                                  distance_rel_tol=0.0)
        scene = Scene(traj, lay, MODELS, 0.0)
        names = scene.models.kind_names
        cand = {}
        for p, g in enumerate(scene.lp_group):
            cand.setdefault(scene.pair_ids(int(g))[1:], set()).add(
                (names[scene.lp_ka[p]], names[scene.lp_kb[p]]))
        all_ang = np.tile(SPEC.fold_deg, (lay.n_robots, 1)).astype(float)
        all_ang[near] = ang
        # every robot pair of these robots within 60 mm, and each robot with every obstacle
        # every pair of these robots, and each robot with every obstacle within 60 mm
        xy = lay.robot_xy[near]
        others = [(int(ids[i]), int(ids[j])) for i in range(len(ids))
                  for j in range(i + 1, len(ids))]
        for i in range(len(ids)):
            p = np.broadcast_to(xy[i], a.shape)
            others += [(int(ids[i]), int(f)) for f in
                       lay.fiducial_ids[segment_distance_np(p, p, a, b) < 60.0]]
        ref = mujoco_reference(lay, all_ang, others, per_link=True, twin=twin)
        reported = {pd.ids: pd for pd in rep.pairs}
        for key, dist in ref.items():
            links = cand.get(key, set())
            # links that are no candidates never touch
            assert min([v for k, v in dist.items() if k not in links], default=1.0) > 0.0, \
                (key, links, dist)
            if not links:
                assert key not in reported
                continue
            pd = reported[key]
            r = min(dist[k] for k in links)
            found[pd.kind] += 1
            found["wall"] += ("beta", "gfa") in links
            if r > 1e-6:                            # surfaces apart: the solid distance
                assert pd.min_distance_mm == pytest.approx(r, abs=1e-7), pd
            else:
                found["hit"] += 1
                assert any((c.robot_a, c.other) == key for c in rep.collisions)
        assert len({(c.robot_a, c.other) for c in rep.collisions}) \
            == sum(min(ref[k][x] for x in cand[k]) <= 1e-6 for k in cand)
        # the kernels' bounds (tilted links posed per pair, with slacks) stay below the
        # reference distance of every link pair, and close to it between robots
        bound = kernel_bounds(scene, traj)
        for p, g in enumerate(scene.lp_group):
            key = scene.pair_ids(int(g))[1:]
            r = ref[key][(names[scene.lp_ka[p]], names[scene.lp_kb[p]])]
            assert bound[p] <= r + 1e-9, (key, p, bound[p], r)
            if scene.pair_ids(int(g))[0] == "robot" and 0.0 < r < 1.0:
                assert bound[p] > r - 0.1
    assert found["robot"] > 15 and found["fiducial"] >= 6 and found["wall"] >= 3
    assert found["hit"] > 0


def test_slacks_between_neighbours_of_the_curved_wok_are_small():
    lay = layout_by_name("sdss-v-curved", PITCH)
    ids = lay.robot_ids
    scene = Scene(static(np.zeros((len(ids), 2)), ids=ids), lay, MODELS, 0.0)
    slack = scene.place[2]
    robots = scene.obj_rob[scene.lp_ob] >= 0
    assert scene.placed and len(slack) == scene.n_link_pairs
    assert slack[robots, 0].max() < 0.05 and slack[robots, 1].max() < 0.2
    assert slack[~robots, 0].max() < 0.1 and slack[~robots, 1].max() < 1.0
    assert "gfa" in scene.models.kind_names and scene.models.kind_names.count("gfa") == 6
