"""Per-robot geometry in the shared 2D clearance functions: rfp_twin.models.geometry2d
(``pair_distances``, ``fiducial_distances``) and ArrayGeometry.pair_clearance /
fiducial_clearance on layouts with per-robot and per-obstacle columns (mm, deg).

The references are independent numpy code (``_segment_distance`` below: dense samples
on one segment, exact distance to the other, so at most ``H`` above the true distance).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.geometry2d import fiducial_distances, pair_distances
from rfp_twin.models.layout import Layout
from rfp_twin.models.layout.columns import obstacle_arrays, robot_collision_arrays
from rfp_twin.models.robot import load_spec

SPEC = load_spec("sdss-v")
LA, LB, PITCH = 7.4, 15.0, 22.4
H = 1e-3


def _points_to_segment(pts, a, b):
    u = b - a
    den = float(u @ u)
    t = np.zeros(len(pts)) if den == 0.0 else np.clip((pts - a) @ u / den, 0.0, 1.0)
    return np.hypot(*(a + t[:, None] * u - pts).T)


def _segment_distance(p, q, a, b):
    """Distance of segment p-q to segment a-b, to within H mm (from above)."""
    n = max(2, int(math.ceil(np.hypot(*(q - p)) / H)) + 1)
    pts = p + np.linspace(0.0, 1.0, n)[:, None] * (q - p)
    return float(_points_to_segment(pts, a, b).min())


def _bodies(base, angles, la, s0, s1):
    """(n, 2) start and end of each robot's beta collision segment, mm (numpy)."""
    r = np.deg2rad(angles)
    elbow = base + la[:, None] * np.column_stack([np.cos(r[:, 0]), np.sin(r[:, 0])])
    u = np.column_stack([np.cos(r.sum(1)), np.sin(r.sum(1))])
    return elbow + s0[:, None] * u, elbow + s1[:, None] * u


# -- kernels --------------------------------------------------------------------------
def test_pair_distances_use_each_robots_alpha_arm_and_segment():
    """Robot 0 at (0, 90): segment x = l_0, y in [s0_0, s1_0]. Robot 1 folded at (22.4, 0)
    with beta pointing along -x: its tip is at x = 22.4 + l_1 cos 10 - s1_1."""
    base = np.array([[0.0, 0.0], [PITCH, 0.0]])
    ang = np.array([[0.0, 90.0], [10.0, 170.0]])
    pairs = np.array([[0, 1]], dtype=np.int64)
    c10 = math.cos(math.radians(10.0))
    nominal = pair_distances(base, ang, pairs, LA, 0.0, np.full(2, LB))[0]
    assert nominal == pytest.approx(PITCH + LA * c10 - LB - LA, abs=1e-9)
    la = np.array([9.0, 6.5])
    d = pair_distances(base, ang, pairs, la, np.zeros(2), np.array([LB, 14.0]))[0]
    assert d == pytest.approx(PITCH + 6.5 * c10 - 14.0 - 9.0, abs=1e-9)
    assert d != pytest.approx(nominal, abs=0.5)
    # robot 0's segment starting 5 mm out on a 9 mm alpha arm: x = 9, y in [5, 15];
    # robot 1's tip at (22.4 + 7.4 cos 10 - 15, 7.4 sin 10)
    d = pair_distances(base, ang, pairs, np.array([9.0, LA]), np.array([5.0, 0.0]),
                       np.full(2, LB))[0]
    tip = np.array([PITCH + LA * c10 - LB, LA * math.sin(math.radians(10.0))])
    assert d == pytest.approx(math.hypot(tip[0] - 9.0, 5.0 - tip[1]), abs=1e-9)


def test_uniform_arrays_are_bit_identical_to_scalars():
    rng = np.random.default_rng(3)
    base = rng.uniform(-40, 40, (12, 2))
    ang = np.column_stack([rng.uniform(0, 360, 12), rng.uniform(0, 180, 12)])
    pairs = np.array([(i, j) for i in range(12) for j in range(i + 1, 12)], dtype=np.int64)
    seg = np.full(12, 14.7)
    a = pair_distances(base, ang, pairs, LA, 0.5, seg)
    b = pair_distances(base, ang, pairs, np.full(12, LA), np.full(12, 0.5), seg)
    assert a.tobytes() == b.tobytes()
    fid = rng.uniform(-40, 40, (5, 2))
    rf = np.array([(i, f) for i in range(12) for f in range(5)], dtype=np.int64)
    c = fiducial_distances(base, ang, rf, fid, LA, 0.5, seg)
    d = fiducial_distances(base, ang, rf, fid, np.full(12, LA), np.full(12, 0.5), seg, fid.copy())
    assert c.tobytes() == d.tobytes()


def test_fiducial_distances_to_a_segment_obstacle_hit_in_its_middle():
    """Robot at (0, 0), alpha 90, beta 0: segment x = 0, y in [7.4, 22.4]. The obstacle
    y = 25, x in [-40, 40] is 2.6 mm away in its middle; its first end is 47 mm away."""
    base = np.zeros((1, 2))
    ang = np.array([[90.0, 0.0]])
    rf = np.zeros((1, 2), dtype=np.int64)
    a = np.array([[-40.0, 25.0]])
    b = np.array([[40.0, 25.0]])
    args = (base, ang, rf, a, np.array([LA]), np.zeros(1), np.array([LB]))
    assert fiducial_distances(*args)[0] == pytest.approx(math.hypot(40.0, 25.0 - 22.4))
    assert fiducial_distances(*args, b)[0] == pytest.approx(2.6, abs=1e-12)
    assert fiducial_distances(*args, a.copy())[0] == fiducial_distances(*args)[0]  # a point
    # a crossing obstacle is 0 away
    cross = np.array([[-5.0, 10.0]]), np.array([[5.0, 10.0]])
    assert fiducial_distances(base, ang, rf, cross[0], LA, 0.0, np.array([LB]), cross[1])[0] == 0.0


# -- ArrayGeometry on a layout with columns -----------------------------------------
def columns_layout() -> Layout:
    """hex:19 (22.4 mm) with per-robot alpha arms, buffers, a metrology shift, one
    fiducial and two guide-camera edges (segments) with their own keep-out radii."""
    grid = Layout.hex_grid(2, PITCH)
    n = grid.n_robots
    rng = np.random.default_rng(8)
    obstacles = np.array([[-70.0, 0.0], [0.0, 62.0], [40.0, -55.0]])
    alpha = [f"{v:.3f}" for v in rng.uniform(6.8, 8.4, n)]
    alpha[3] = ""
    add = ["", "0.3", "-0.4"] * 6 + [""]
    blank = [""] * 3
    extra = {"alpha_len_mm": alpha + blank, "buffer_add_mm": add + blank,
             "met_x_mm": [""] * (n - 1) + ["14.9"] + blank,
             "x2_mm": [""] * n + ["", "60.0", "-10.0"],
             "y2_mm": [""] * n + ["", "62.0", "-55.0"],
             "obstacle_buffer_mm": [""] * n + ["", "2.0", "1.0"]}
    return Layout(np.arange(n + 3), np.vstack([grid.xy, obstacles]),
                  ["robot"] * n + ["fiducial", "gfa", "gfa"], name="hex19-cols", extra=extra)


@pytest.fixture(scope="module")
def geoms():
    layout = columns_layout()
    plain = Layout(layout.ids, layout.xy, layout.kinds, name="hex19")
    return ArrayGeometry(SPEC, layout, 2.5), ArrayGeometry(SPEC, plain, 2.5)


def test_clearances_match_numpy_and_differ_from_nominal(geoms):
    geom, nominal = geoms
    assert not geom.uniform and nominal.uniform
    la, s0, s1, buf = robot_collision_arrays(SPEC, geom.layout, 2.5)
    oa, ob, obuf = obstacle_arrays(SPEC, geom.layout)
    rng = np.random.default_rng(21)
    n = geom.n_robots
    for _ in range(3):
        ang = np.column_stack([rng.uniform(0, 360, n), rng.uniform(0, 180, n)])
        p, q = _bodies(geom.base_xy, ang, la, s0, s1)
        ref = np.array([_segment_distance(p[i], q[i], p[j], q[j]) - buf[i] - buf[j]
                        for i, j in geom.pairs])
        got = geom.pair_clearance(ang)
        assert np.all(got <= ref + 1e-9) and np.all(got >= ref - H)
        rf = geom.robot_fid_pairs
        assert {int(f) for f in rf[:, 1]} == {0, 1, 2}
        ref = np.array([_segment_distance(p[i], q[i], oa[f], ob[f]) - buf[i] - obuf[f]
                        for i, f in rf])
        got_f = geom.fiducial_clearance(ang)
        assert np.all(got_f <= ref + 1e-9) and np.all(got_f >= ref - H)
        spec_values = pair_distances(geom.base_xy, ang, geom.pairs, LA, 0.0,
                                     np.full(n, LB)) - 5.0
        assert np.abs(got - spec_values).max() > 0.1
    # the larger reach of the longer arms can only add neighbour pairs
    assert {tuple(p) for p in nominal.pairs.tolist()} <= {tuple(p) for p in geom.pairs.tolist()}


def test_longer_alpha_arm_turns_a_clear_pose_into_a_collision():
    """Two robots folded towards each other along a row: clear with 7.4 mm arms, in
    collision when one alpha arm is 1.5 mm longer (ArrayGeometry.pair_clearance)."""
    ang = np.array([[0.0, 180.0], [180.0, 180.0]])   # beta arms point back at own base
    # robot 0's segment: x in [7.4 - 15, 7.4] = [-7.6, 7.4]; robot 1's: [15, 30]
    xy = [[0.0, 0.0], [PITCH, 0.0]]
    plain = ArrayGeometry(SPEC, Layout([0, 1], xy, ["robot"] * 2, name="two"), 2.5)
    assert plain.pair_clearance(ang)[0] == pytest.approx(15.0 - 7.4 - 5.0)
    longer = Layout([0, 1], xy, ["robot"] * 2, name="two", extra={"alpha_len_mm": ["10.5", ""]})
    geom = ArrayGeometry(SPEC, longer, 2.5)
    assert geom.pair_clearance(ang)[0] == pytest.approx(15.0 - 10.5 - 5.0)
    assert geom.pair_clearance(ang)[0] < 0.0 < plain.pair_clearance(ang)[0]
    bigger = Layout([0, 1], xy, ["robot"] * 2, name="two", extra={"buffer_add_mm": ["", "2.7"]})
    assert ArrayGeometry(SPEC, bigger, 2.5).pair_clearance(ang)[0] == \
        pytest.approx(15.0 - 7.4 - 7.7)


def test_fiducial_clearance_uses_the_segment_and_its_buffer():
    """Robot at alpha 90, beta 0 (tip at (0, 22.4)) under a guide-camera edge at y = 25
    from x = -40 to 40 with a 1 mm keep-out: clearance 2.6 - 2.5 - 1.0 < 0; the point at
    its first end would be far clear (and not even a candidate)."""
    ang = np.array([[90.0, 0.0]])
    xy = [[0.0, 0.0], [-40.0, 25.0]]
    seg = Layout([0, 9], xy, ["robot", "gfa"], name="gfa",
                 extra={"x2_mm": ["", "40"], "y2_mm": ["", "25"],
                        "obstacle_buffer_mm": ["", "1.0"]})
    geom = ArrayGeometry(SPEC, seg, 2.5)
    assert geom.robot_fid_pairs.tolist() == [[0, 0]]
    assert geom.fiducial_clearance(ang)[0] == pytest.approx(25.0 - 22.4 - 2.5 - 1.0, abs=1e-12)
    point = ArrayGeometry(SPEC, Layout([0, 9], xy, ["robot", "gfa"], name="pt"), 2.5)
    assert point.robot_fid_pairs.shape == (0, 2)
