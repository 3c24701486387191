"""The MuJoCo model uses each robot's own geometry and each obstacle's own shape
(models/mjcf with the layout columns of rfp_twin.models.layout.columns), and the twin's
fiber error uses each robot's own arm (twin/sim/control.py).

Nominal SDSS-V numbers (mm): alpha arm 7.4, beta frame 5.8 above the robot frame, fiber
tips 2.0 above it (fiber_z 7.8), beta link z range [4.3, 7.8], fiducial post radius 1.0.
"""
from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from rfp_twin.models.errors import LayoutError
from rfp_twin.models.kinematics import forward_fiber
from rfp_twin.models.layout import Layout, layout_by_name
from rfp_twin.models.layout.columns import FIBERS, robot_column, robot_fibers
from rfp_twin.models.mjcf import build_model
from rfp_twin.models.mjcf.bodies import SLAB_Z_MARGIN_MM
from rfp_twin.models.robot import load_spec

SPEC = load_spec("sdss-v")
PITCH = SPEC.pitch_mm
LA = SPEC.alpha_length_mm


def hex7(**columns) -> Layout:
    """7 robots (hex ring) with per-robot columns (one value per robot, "" blank)."""
    g = Layout.hex_grid(1, PITCH)
    return Layout(g.ids, g.xy, g.kinds, name="hex7-cols",
                  extra={k: [str(v) for v in vals] for k, vals in columns.items()})


def model_bytes(twin) -> bytes:
    buf = np.zeros(mujoco.mj_sizeModel(twin.model), np.uint8)
    mujoco.mj_saveModel(twin.model, None, buf)
    return buf.tobytes()


def contact_geoms(twin, d) -> set[tuple[int, int]]:
    g = np.asarray(d.contact.geom).reshape(-1, 2)
    return {tuple(sorted(map(int, p))) for p in g}


# -- blank columns: the nominal model, bit for bit --------------------------------------------
def test_blank_or_nominal_columns_give_the_same_model_bit_for_bit():
    ref = model_bytes(build_model(SPEC, Layout.hex_grid(1, PITCH)))
    blank = hex7(alpha_len_mm=[""] * 7, z_mm=[""] * 7, kx=[""] * 7, ky=[""] * 7, kz=[""] * 7)
    same = hex7(alpha_len_mm=[LA] * 7, z_mm=[0.0] * 7, kx=[0.0] * 7, ky=[0.0] * 7, kz=[1.0] * 7)
    for lay in (blank, same):
        got = build_model(SPEC, Layout(lay.ids, lay.xy, lay.kinds, name="hex-7", extra=lay.extra))
        assert model_bytes(got) == ref
    # and a real column value changes it
    longer = hex7(alpha_len_mm=[LA] * 6 + [LA + 0.1])
    assert model_bytes(build_model(SPEC, Layout(longer.ids, longer.xy, longer.kinds,
                                                name="hex-7", extra=longer.extra))) != ref


# -- alpha arm -------------------------------------------------------------------------------
def test_longer_alpha_arm_puts_the_beta_joint_further_out():
    lens = [LA] * 7
    lens[3] = 8.6
    twin = build_model(SPEC, hex7(alpha_len_mm=lens))
    nominal = build_model(SPEC, Layout.hex_grid(1, PITCH))
    rng = np.random.default_rng(4)
    angles = rng.uniform(0, 360, (7, 2))
    for tw, expect in ((twin, lens), (nominal, [LA] * 7)):
        d = tw.make_data(angles)
        idx = tw.index
        # beta hinge anchor and beta body origin: l_alpha from the alpha axis, in the plane
        arm = d.xanchor[idx.beta_joint] - d.xanchor[idx.alpha_joint]
        assert np.hypot(arm[:, 0], arm[:, 1]) == pytest.approx(expect, abs=1e-9)
        a = np.radians(angles[:, 0])
        arm_xy = np.column_stack([np.cos(a), np.sin(a)]) * np.array(expect)[:, None]
        expect_xy = tw.layout.robot_xy + arm_xy
        assert d.xpos[idx.beta_body][:, :2] == pytest.approx(expect_xy, abs=1e-9)
    # the fibers ride on the longer arm; its servo sees a larger inertia (stiffer gains)
    d, d0 = twin.make_data(angles), nominal.make_data(angles)
    met = twin.index.fiber_names.index("metrology")
    shift = twin.fiber_xyz(d)[3, met] - nominal.fiber_xyz(d0)[3, met]
    assert np.hypot(*shift[:2]) == pytest.approx(8.6 - LA, abs=1e-9)
    kp = twin.model.actuator_gainprm[twin.index.actuator[:, 0], 0]
    assert kp[3] > kp[0] and np.all(kp[[0, 1, 2, 4, 5, 6]] == kp[0])
    # the alpha link's mesh stays the nominal one
    assert np.array_equal(twin.model.geom_size[twin.index.robot_geoms(3)],
                          nominal.model.geom_size[nominal.index.robot_geoms(3)])


def test_neighbour_pairs_grow_with_the_longest_alpha_arm():
    lay = Layout([0, 1], [[0.0, 0.0], [48.0, 0.0]], ["robot", "robot"], name="far")
    twin = build_model(SPEC, lay)
    assert 2 * twin.geometry.beta_reach_mm() < 48.0 and len(twin.neighbour_pairs()) == 0
    longer = Layout(lay.ids, lay.xy, lay.kinds, name="far", extra={"alpha_len_mm": ["8.0", ""]})
    assert build_model(SPEC, longer).neighbour_pairs().tolist() == [[0, 1]]


# -- fibers ----------------------------------------------------------------------------------
def test_fiber_sites_are_each_robots_own_and_absent_where_not_carried():
    cols = {"met_x_mm": [14.5, "", "", "", "", "", ""], "met_y_mm": [0.2, "", "", "", "", "", ""],
            "boss_x_mm": [15.1] + [14.965] * 6, "boss_y_mm": [-0.4] + [-0.376] * 6,
            "apogee_x_mm": ["", 15.0, "", "", "", "", ""],
            "apogee_y_mm": ["", 0.3, "", "", "", "", ""],
            "alpha_len_mm": [7.3, 7.5, "", "", "", "", ""]}
    lay = hex7(**cols)
    twin = build_model(SPEC, lay)
    idx = twin.index
    assert idx.fiber_names == FIBERS
    carried = idx.fiber_site >= 0
    assert carried[:, 0].all() and carried[:, 1].all()
    assert carried[:, 2].tolist() == [False, True, False, False, False, False, False]
    assert mujoco.mj_name2id(twin.model, mujoco.mjtObj.mjOBJ_SITE, "r0_apogee") == -1
    angles = np.random.default_rng(2).uniform(0, 360, (7, 2))
    d = twin.make_data(angles)
    xyz = twin.fiber_xyz(d)
    assert np.isnan(xyz[~carried]).all() and np.isfinite(xyz[carried]).all()
    own = robot_fibers(lay, {"metrology": (14.314, 0.0), "boss": (14.965, -0.376),
                             "apogee": (14.965, 0.376)})
    la = robot_column(lay, "alpha_len_mm", LA)
    for f in range(3):
        rows = np.flatnonzero(carried[:, f])
        expect = forward_fiber(lay.robot_xy[rows], angles[rows], la[rows], own[rows, f])
        assert xyz[rows, f, :2] == pytest.approx(expect, abs=1e-9)
    nominal = build_model(SPEC, Layout.hex_grid(1, PITCH))
    assert xyz[0, 0, :2] != pytest.approx(nominal.fiber_xyz(nominal.make_data(angles))[0, 0, :2],
                                          abs=1e-3)


# -- obstacles: fiducial posts and guide-camera walls --------------------------------------
def wall_layout(segment: bool = True) -> Layout:
    """Robot 0 at the origin, robot 1 far away, a gfa row 9 from (-30, 20) to (30, 20)
    (blank end: a point at (-30, 20))."""
    x2, y2 = ("30.0", "20.0") if segment else ("", "")
    return Layout([0, 1, 9], [[0.0, 0.0], [60.0, 0.0], [-30.0, 20.0]],
                  ["robot", "robot", "gfa"], name="wall",
                  extra={"x2_mm": ["", "", x2], "y2_mm": ["", "", y2]})


def test_a_gfa_segment_is_a_wall_that_a_beta_arm_hits_in_its_middle():
    twin = build_model(SPEC, wall_layout())
    m, idx = twin.model, twin.index
    geoms = np.flatnonzero(idx.geom_fiducial == 0)
    assert len(geoms) == 2 and np.all(m.geom_type[geoms] == mujoco.mjtGeom.mjGEOM_BOX)
    col = [g for g in geoms if idx.geom_collision[g]]
    assert len(col) == 1
    assert m.geom_conaffinity[col[0]] == 1 and m.geom_contype[col[0]] == 0   # beta arms only
    d = twin.make_data(np.array([[90.0, 0.0], [0.0, 180.0]]))   # arm along +y: tip at 23.6
    # a box 60 + 2 long, 2 thick, around y = 20, over the beta arms' heights
    assert m.geom_size[col[0]] == pytest.approx([31.0, 1.0, (3.5 + 2 * SLAB_Z_MARGIN_MM) / 2])
    assert d.geom_xpos[col[0]] == pytest.approx([0.0, 20.0, twin.base_z_mm + 6.05])
    hit = {p for p in contact_geoms(twin, d) if col[0] in p}
    assert hit and all(set(p) - {col[0]} <= set(idx.robot_geoms(0, collision=True)) for p in hit)
    assert all(m.geom_bodyid[(set(p) - {col[0]}).pop()] == idx.beta_body[0] for p in hit)
    # arm along -y: clear; and a point obstacle at the wall's first end is never reached
    twin.set_angles(d, np.array([[270.0, 0.0], [0.0, 180.0]]))
    assert not any(col[0] in p for p in contact_geoms(twin, d))
    post = build_model(SPEC, wall_layout(segment=False))
    d = post.make_data(np.array([[90.0, 0.0], [0.0, 180.0]]))
    assert not np.any(post.index.geom_fiducial[np.asarray(d.contact.geom).reshape(-1)] >= 0)


def test_instrument_walls_and_posts():
    lay = layout_by_name("sdss-v-apo", PITCH)
    twin = build_model(SPEC, lay)
    m, idx = twin.model, twin.index
    kinds = lay.kinds[~lay.robot_mask]
    for f, kind in enumerate(kinds):
        geoms = np.flatnonzero(idx.geom_fiducial == f)
        box = m.geom_type[geoms] == mujoco.mjtGeom.mjGEOM_BOX
        assert box.all() if kind == "gfa" else not box.any()
    assert (kinds == "gfa").sum() == 6


# -- curved wok: heights and tilts -----------------------------------------------------------
def test_curved_wok_robots_stand_at_their_height_along_their_axis():
    lay = layout_by_name("sdss-v-curved", PITCH)
    twin = build_model(SPEC, lay)
    z = robot_column(lay, "z_mm", 0.0)
    k = np.column_stack([robot_column(lay, c, 0.0) for c in ("kx", "ky", "kz")])
    k /= np.linalg.norm(k, axis=1)[:, None]
    d = twin.make_data(np.zeros((lay.n_robots, 2)))
    idx, p = twin.index, twin.geometry.params
    base = d.xpos[idx.base_body]
    # each robot's axis meets the focal surface (fiber_z_mm up the axis from its base) at
    # the layout's x, y and z_mm: where the 2D planner puts it
    on_surface = base + p.fiber_z_mm * k
    assert on_surface[:, :2] == pytest.approx(lay.robot_xy, abs=1e-9)
    assert on_surface[:, 2] == pytest.approx(p.focal_z_mm + z, abs=1e-9)
    assert np.abs(base[:, :2] - lay.robot_xy).max() > 0.5 * p.fiber_z_mm * np.sin(np.radians(1.5))
    assert z.max() > 4.0 and np.degrees(np.arccos(k[:, 2])).max() > 1.5
    # the metrology fiber at alpha = beta = 0: fiber_z along the robot's axis, its arm
    # (l_alpha + x, y) turned by the smallest rotation taking z to k (scipy, independently)
    met = idx.fiber_names.index("metrology")
    fib = robot_fibers(lay, {"metrology": (14.314, 0.0)})[:, 0]
    la = robot_column(lay, "alpha_len_mm", LA)
    rel = twin.fiber_xyz(d)[:, met] - base
    assert np.einsum("ij,ij->i", rel, k) == pytest.approx(np.full(len(k), p.fiber_z_mm), abs=1e-9)
    axis = np.cross([0.0, 0.0, 1.0], k)
    sin = np.linalg.norm(axis, axis=1)
    rotvec = np.where(sin[:, None] > 0, axis / np.maximum(sin, 1e-300)[:, None], 0.0) \
        * np.arctan2(sin, k[:, 2])[:, None]
    local = np.column_stack([la + fib[:, 0], fib[:, 1], np.full(len(la), p.fiber_z_mm)])
    assert rel == pytest.approx(Rotation.from_rotvec(rotvec).apply(local), abs=1e-9)
    # z grows along k: robots tilted along their arm have their fiber up to 0.6 mm higher
    # or lower than a flat robot's
    dz = twin.fiber_xyz(d)[:, met, 2] - (base[:, 2] + p.fiber_z_mm)
    assert dz.max() > 0.5 and dz.min() < -0.5
    # obstacles stand at their nearest robot's height
    fz = d.xpos[idx.fiducial_body][:, 2] - twin.base_z_mm
    obs = lay.xy[~lay.robot_mask]
    near = np.argmin(np.linalg.norm(obs[:, None] - lay.robot_xy[None], axis=2), axis=1)
    gfa = lay.kinds[~lay.robot_mask] == "gfa"
    assert fz[~gfa] == pytest.approx(z[near[~gfa]], abs=1e-9)


def test_a_raised_robot_passes_over_and_a_tilted_one_dips_into_its_neighbour():
    """Crossing beta arms (robot 0: alpha 0, beta 60; robot 1 at the pitch: alpha 120,
    beta 60; nothing else near): they touch on a flat wok; robot 1 raised by 2.1 mm puts
    its bar (z 7.9 - 9.9) 0.1 mm above robot 0's (5.8 - 7.8); tilted by 2 deg towards the
    crossing point (13 mm from its base) it dips 0.45 mm back into robot 0's arm."""
    angles = np.array([[0.0, 60.0], [120.0, 60.0]])

    def touching(extra) -> bool:
        lay = Layout([0, 1], [[0.0, 0.0], [PITCH, 0.0]], ["robot", "robot"], name="x",
                     extra=extra)
        twin = build_model(SPEC, lay)
        d = twin.make_data(angles)
        g = np.asarray(d.contact.geom).reshape(-1, 2)
        r = twin.index.geom_robot[g]
        return bool(np.any(r[:, 0] != r[:, 1]))

    assert touching({})
    assert not touching({"z_mm": ["", "2.1"]})
    s = math.sin(math.radians(2.0))
    u = np.array([-11.3, 6.41]) / np.hypot(-11.3, 6.41)
    tilt = {"z_mm": ["", "2.1"], "kx": ["", str(s * u[0])], "ky": ["", str(s * u[1])],
            "kz": ["", repr(math.cos(math.radians(2.0)))]}
    assert touching(tilt)
    away = dict(tilt, kx=["", str(-s * u[0])], ky=["", str(-s * u[1])])
    assert not touching(away)


def test_an_axis_that_is_not_a_unit_vector_is_refused():
    with pytest.raises(LayoutError, match="robot 3 fields 'kx, ky, kz'.*unit vector"):
        build_model(SPEC, hex7(kx=["", "", "", "0.5", "", "", ""]))


# -- the twin's fiber error ------------------------------------------------------------------
def test_fiber_error_uses_each_robots_arm():
    from rfp_twin.twin.sim.control import fiber_error_mm

    lay = hex7(alpha_len_mm=[9.0] + [""] * 6)
    twin = build_model(SPEC, lay)
    nominal = build_model(SPEC, Layout.hex_grid(1, PITCH))
    fold = np.tile([10.0, 170.0], (7, 1))
    turned = fold.copy()
    turned[:, 0] += 90.0                  # alpha turned by 90 deg, beta kept
    err, err0 = fiber_error_mm(twin, turned, fold), fiber_error_mm(nominal, turned, fold)
    # the fiber swings on a circle of radius |l_alpha + 15 e^{i 170}| about the alpha axis
    radius = lambda la: abs(la + 15.0 * np.exp(1j * np.radians(170.0)))  # noqa: E731
    assert err0 == pytest.approx([math.sqrt(2) * radius(LA)] * 7, abs=1e-9)
    assert err[0] == pytest.approx(math.sqrt(2) * radius(9.0), abs=1e-9)
    assert err[1:] == pytest.approx(err0[1:], abs=1e-12)


def test_joint_ranges_are_each_robots_own():
    """Encoder offsets shift a robot's joint range (model angles); others keep the spec's."""
    twin = build_model(SPEC, hex7(alpha_offset_deg=[-30.0] + [""] * 6,
                                  beta_offset_deg=["", 4.5] + [""] * 5))
    m, idx = twin.model, twin.index
    a, b = np.radians(SPEC.alpha_limits_deg), np.radians(SPEC.beta_limits_deg)
    assert m.jnt_range[idx.alpha_joint[0]] == pytest.approx(a - np.radians(30.0), abs=1e-12)
    assert m.jnt_range[idx.beta_joint[1]] == pytest.approx(b + np.radians(4.5), abs=1e-12)
    assert m.jnt_range[idx.beta_joint[0]] == pytest.approx(b, abs=0)
    assert np.all(m.jnt_range[idx.alpha_joint[1:]] == a)
