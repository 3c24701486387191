"""The 2D check uses each robot's own geometry and each obstacle's own shape
(validation/checker2d with the layout columns of rfp_twin.models.layout.columns).

Geometry of tests/validation/conftest.py: robot 0 at the origin holds alpha 0 and swings
its beta arm; robot 1 at (22.4, 0) is parked at (180, 180), so its collision segment
starts at its beta axis (22.4 - l_1, 0) and points along +x. Robot 0's centre line (from
its beta axis (l_0, 0), at angle b <= 90 deg) passes that start at ``(22.4 - l_1 - l_0)
sin b``: 7.6 sin b with the spec's 7.4 mm alpha arms.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from rfp_twin.models.errors import LayoutError
from rfp_twin.models.layout import Layout
from rfp_twin.models.layout.columns import obstacle_arrays, robot_collision_arrays
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.validation.checker2d import check_trajectory, coarse_grid, speed_bounds_mm_s
from rfp_twin.validation.numerics import segment_distance_np
from tests.validation.conftest import PITCH, SPEC, pair_layout, static, swing

BUF = 2.5
RES = 1e-5
LA = SPEC.alpha_length_mm
FBUF = SPEC.fiducial_buffer_mm


def columns_pair(**columns) -> Layout:
    """:func:`pair_layout` with per-robot columns (one value per robot, "" = blank)."""
    base = pair_layout()
    return Layout(base.ids, base.xy, base.kinds, name="pair-cols",
                  extra={k: [str(v) for v in vals] for k, vals in columns.items()})


def swing_to(b_min: float) -> Trajectory:
    """Robot 0's beta 90 -> b_min -> 90 deg in 2 s (closest at t = 1 s)."""
    return swing([0.0, 1.0, 2.0], [90.0, b_min, 90.0], 2.0)


def gap(l0: float = LA, l1: float = LA, b_deg: float = 50.0) -> float:
    """Centre-line distance of the pair at robot 0's beta ``b_deg``, mm."""
    return (PITCH - l0 - l1) * math.sin(math.radians(b_deg))


# -- alpha arm length ---------------------------------------------------------------
@pytest.mark.parametrize("robot", [0, 1])
def test_longer_alpha_arm_of_one_robot_collides(robot):
    nominal = check_trajectory(swing_to(50.0), SPEC, pair_layout(), BUF, resolution_s=RES)
    assert nominal.ok and nominal.pair_min_distance_mm[0] == pytest.approx(gap(), abs=0.02)
    lens = [LA, LA]
    lens[robot] = 9.0                                          # 6.0 sin 50 = 4.60 < 5
    layout = columns_pair(alpha_len_mm=lens)
    report = check_trajectory(swing_to(50.0), SPEC, layout, BUF, resolution_s=RES)
    assert not report.ok and len(report.collisions) == 1
    c = report.collisions[0]
    assert (c.kind, c.robot_a, c.other, c.threshold_mm) == ("robot", 0, 1, 2 * BUF)
    assert c.min_distance_mm == pytest.approx(gap(*lens), abs=0.02)
    # enters where (22.4 - l0 - l1) sin b = 2 buffer, b linear in t
    b_in = math.degrees(math.asin(2 * BUF / (PITCH - sum(lens))))
    assert c.t_start == pytest.approx((90.0 - b_in) / 40.0, abs=2 * RES)
    assert c.t_end == pytest.approx(2.0 - (90.0 - b_in) / 40.0, abs=2 * RES)


def test_blank_cells_are_the_spec_and_bit_identical():
    """Columns present but blank (or equal to the spec) change nothing, bit for bit."""
    traj = swing_to(40.0)
    ref = check_trajectory(traj, SPEC, pair_layout(), BUF, resolution_s=RES).to_dict()
    for layout in (columns_pair(alpha_len_mm=["", ""], buffer_add_mm=["", ""]),
                   columns_pair(alpha_len_mm=[LA, LA], buffer_add_mm=[0.0, 0.0])):
        got = check_trajectory(traj, SPEC, layout, BUF, resolution_s=RES).to_dict()
        ref.pop("seconds", None)
        got.pop("seconds")
        assert got == ref


def test_speed_bounds_use_each_robots_alpha_arm():
    """V_i = l_i A_i + r_max (A_i + B_i): robot 0 turns alpha only (A = 60 deg/s)."""
    traj = Trajectory.from_breakpoints([0, 1], [[0.0, 1.0], [0.0, 1.0]],
                                       [[0.0, 60.0], [180.0, 180.0]],
                                       [[0.0, 1.0], [0.0, 1.0]], [[90.0, 90.0], [180.0, 180.0]])
    a = math.radians(60.0)
    r_max = SPEC.segment_end(BUF)
    layout = columns_pair(alpha_len_mm=[12.0, ""])
    assert speed_bounds_mm_s(traj, SPEC, BUF)[0] == pytest.approx((LA + r_max) * a)
    v = speed_bounds_mm_s(traj, SPEC, BUF, layout=layout)
    np.testing.assert_allclose(v, [(12.0 + r_max) * a, 0.0], rtol=1e-12)
    vm = speed_bounds_mm_s(traj, SPEC, BUF, mean=True, layout=layout)
    np.testing.assert_allclose(vm, v, rtol=1e-12)                 # constant rate
    # the coarse grid is finer for the faster (longer) arm
    assert len(coarse_grid(traj, SPEC, BUF, 0, 1, layout=layout)) > \
        len(coarse_grid(traj, SPEC, BUF, 0, 1))


def test_long_alpha_arm_sweep_matches_dense_sampling():
    """A fast alpha sweep of a long-armed robot across a parked one: the contact and
    its extent agree with dense sampling of the per-robot geometry (arm, buffer)."""
    layout = columns_pair(alpha_len_mm=[12.0, ""], buffer_add_mm=["", 0.4])
    # robot 0: beta 0 (arm straight out, reach 27 mm), alpha -40 -> 40 deg in 0.2 s
    traj = Trajectory.from_breakpoints([0, 1], [[0.0, 0.2], [0.0, 0.2]],
                                       [[-40.0, 40.0], [180.0, 180.0]],
                                       [[0.0, 0.2], [0.0, 0.2]], [[0.0, 0.0], [180.0, 180.0]])
    report = check_trajectory(traj, SPEC, layout, BUF, resolution_s=RES)
    la, s0, s1, buf = robot_collision_arrays(SPEC, layout, BUF)
    t = np.linspace(0.0, 0.2, 200_001)
    ang = np.deg2rad(traj.sample(t))
    ends = []
    for k in range(2):
        elbow = layout.robot_xy[k] + la[k] * np.stack([np.cos(ang[:, k, 0]),
                                                       np.sin(ang[:, k, 0])], -1)
        u = np.stack([np.cos(ang[:, k, 0] + ang[:, k, 1]), np.sin(ang[:, k, 0] + ang[:, k, 1])], -1)
        ends.append((elbow + s0[k] * u, elbow + s1[k] * u))
    d = segment_distance_np(*ends[0], *ends[1])
    thr = buf[0] + buf[1]
    hit = t[d <= thr]
    assert hit.size and len(report.collisions) == 1
    c = report.collisions[0]
    assert c.threshold_mm == pytest.approx(2 * BUF + 0.4)
    assert abs(c.t_start - hit[0]) <= 3e-6 + 2 * RES and abs(c.t_end - hit[-1]) <= 3e-6 + 2 * RES
    assert c.min_distance_mm == pytest.approx(d.min(), abs=1e-3)


def test_brief_pass_of_a_long_arm_is_caught():
    """A 100 mm alpha arm holds for 5 s, then sweeps its tip through a fiducial in 0.1 s
    (contact ~0.02 s): the coarse grid (mean speed) is ~1 s apart, so only a speed
    bound with this robot's own arm length keeps the bisection from clearing it."""
    layout = Layout([0, 5], [[0.0, 0.0], [107.5, 0.0]], ["robot", "fiducial"], name="long",
                    extra={"alpha_len_mm": ["100", ""]})
    traj = Trajectory.from_breakpoints([0], [[0.0, 5.0, 5.1, 10.0]],
                                       [[-10.0, -10.0, 11.0, 11.0]], [[0.0, 10.0]], [[0.0, 0.0]])
    report = check_trajectory(traj, SPEC, layout, BUF, resolution_s=RES)
    assert len(report.collisions) == 1
    c = report.collisions[0]
    thr = BUF + FBUF
    a_in = math.degrees(math.asin(thr / 107.5))          # |alpha| below this: contact
    t0 = 5.0 + 0.1 * (10.0 - a_in) / 21.0
    assert (c.kind, c.robot_a, c.other) == ("fiducial", 0, 5) and not c.conservative
    assert c.t_start == pytest.approx(t0, abs=2 * RES)
    assert c.t_end == pytest.approx(t0 + 0.1 * 2 * a_in / 21.0, abs=2 * RES)


# -- buffers ------------------------------------------------------------------------
def test_buffer_add_of_one_robot_turns_clear_into_collision():
    traj = swing_to(45.0)                     # 7.6 sin 45 = 5.37 mm: clear at 2 x 2.5
    assert check_trajectory(traj, SPEC, pair_layout(), BUF, resolution_s=RES).ok
    report = check_trajectory(traj, SPEC, columns_pair(buffer_add_mm=["", 0.5]), BUF,
                              resolution_s=RES)
    assert [(c.robot_a, c.other) for c in report.collisions] == [(0, 1)]
    assert report.collisions[0].threshold_mm == pytest.approx(2 * BUF + 0.5)
    assert report.min_clearance_mm == pytest.approx(gap(b_deg=45.0) - 2 * BUF - 0.5, abs=0.02)


def test_negative_buffer_add_clears_a_collision():
    traj = swing_to(40.0)                     # 7.6 sin 40 = 4.885 mm < 5
    assert not check_trajectory(traj, SPEC, pair_layout(), BUF, resolution_s=RES).ok
    report = check_trajectory(traj, SPEC, columns_pair(buffer_add_mm=[-0.2, ""]), BUF,
                              resolution_s=RES)
    assert report.ok
    assert report.min_clearance_mm == pytest.approx(gap(b_deg=40.0) - 2 * BUF + 0.2, abs=0.01)


def test_bad_per_robot_buffer_names_the_robot():
    with pytest.raises(LayoutError, match="robot 1 field 'buffer_add_mm'"):
        check_trajectory(swing_to(45.0), SPEC, columns_pair(buffer_add_mm=["", -3.0]), BUF)


# -- obstacles ----------------------------------------------------------------------
GFA_ID = 900
#: A guide-camera edge: the segment y = 25 mm, x in [-40, 40]; both ends ~47 mm from
#: robot 0's base, its middle 25 mm away.
GFA_A, GFA_B = (-40.0, 25.0), (40.0, 25.0)


def gfa_layout(segment: bool = True, obstacle_buffer="") -> Layout:
    extra = {"x2_mm": ["", str(GFA_B[0])] if segment else ["", ""],
             "y2_mm": ["", str(GFA_B[1])] if segment else ["", ""],
             "obstacle_buffer_mm": ["", str(obstacle_buffer)]}
    return Layout([0, GFA_ID], [[0.0, 0.0], list(GFA_A)], ["robot", "gfa"], name="gfa",
                  extra=extra)


def alpha_sweep() -> Trajectory:
    """Robot 0, beta 0 (reach 7.4 + 15 = 22.4 mm), alpha 0 -> 180 deg in 1 s."""
    return Trajectory.from_breakpoints([0], [[0.0, 1.0]], [[0.0, 180.0]], [[0.0, 1.0]],
                                       [[0.0, 0.0]])


def test_gfa_segment_hit_in_its_middle():
    reach = LA + SPEC.segment_end(BUF)                       # 22.4 mm
    point = check_trajectory(alpha_sweep(), SPEC, gfa_layout(segment=False), BUF,
                             resolution_s=RES)
    assert point.ok and point.n_fiducial_pairs == 0          # first end ~47 mm away
    report = check_trajectory(alpha_sweep(), SPEC, gfa_layout(), BUF, resolution_s=RES)
    assert report.n_fiducial_pairs == 1
    assert report.fiducial_pair_ids.tolist() == [[0, GFA_ID]]
    assert len(report.collisions) == 1
    c = report.collisions[0]
    thr = BUF + FBUF
    assert (c.kind, c.robot_a, c.other) == ("fiducial", 0, GFA_ID)
    assert c.threshold_mm == pytest.approx(thr)
    # the tip at 22.4 (cos a, sin a) is 25 - 22.4 sin a from the edge, a = 180 t deg
    a_in = math.degrees(math.asin((25.0 - thr) / reach))
    assert c.t_start == pytest.approx(a_in / 180.0, abs=2 * RES)
    assert c.t_end == pytest.approx(1.0 - a_in / 180.0, abs=2 * RES)
    assert c.t_min == pytest.approx(0.5, abs=1e-3)
    assert c.min_distance_mm == pytest.approx(25.0 - reach, abs=0.02)
    assert report.fiducial_min_distance_mm[0] == pytest.approx(25.0 - reach, abs=0.02)


def test_obstacle_buffer_of_one_obstacle():
    """The tip passes 2.6 mm from the edge: clear with a 0.09 mm keep-out (2.59 mm
    threshold; out of reach, so not even a candidate pair), hit with 0.11 mm."""
    small = check_trajectory(alpha_sweep(), SPEC, gfa_layout(obstacle_buffer=0.09), BUF,
                             resolution_s=RES)
    assert small.ok and small.n_fiducial_pairs == 0
    big = check_trajectory(alpha_sweep(), SPEC, gfa_layout(obstacle_buffer=0.11), BUF,
                           resolution_s=RES)
    assert [(c.kind, c.other) for c in big.collisions] == [("fiducial", GFA_ID)]
    assert big.collisions[0].threshold_mm == pytest.approx(BUF + 0.11)
    assert big.min_clearance_mm == pytest.approx(25.0 - 22.4 - BUF - 0.11, abs=0.005)


def test_static_hex7_with_per_robot_geometry_matches_numpy():
    """Static hex:7 pose with per-robot arms, buffers and segment obstacles: every pair
    minimum is the segment distance of the layout's own bodies (numpy), and differs from
    the nominal check."""
    grid = Layout.hex_grid(1, PITCH)
    n = grid.n_robots
    xy = np.vstack([grid.xy, [[-47.0, 0.0], [0.0, 44.0]]])
    kinds = ["robot"] * n + ["fiducial", "gfa"]
    blank2 = ["", ""]
    extra = {"alpha_len_mm": [7.4, 8.1, 6.9, "", 7.9, 7.4, 8.6] + blank2,
             "buffer_add_mm": ["", 0.3, "", -0.4, "", 0.2, ""] + blank2,
             "met_x_mm": ["", "", 14.9, "", "", "", ""] + blank2,
             "x2_mm": [""] * n + ["", 30.0], "y2_mm": [""] * n + ["", 44.0],
             "obstacle_buffer_mm": [""] * n + ["", 2.0]}
    layout = Layout(np.arange(n + 2), xy, kinds, name="hex7-cols", extra=extra)
    rng = np.random.default_rng(11)
    angles = np.column_stack([rng.uniform(0, 360, n), rng.uniform(0, 180, n)])
    traj = static(angles, ids=range(n))
    report = check_trajectory(traj, SPEC, layout, BUF)
    nominal = check_trajectory(traj, SPEC, Layout(layout.ids, xy, kinds, name="nom"), BUF)

    la, s0, s1, buf = robot_collision_arrays(SPEC, layout, BUF)
    a, b, obuf = obstacle_arrays(SPEC, layout)
    r = np.deg2rad(angles)
    elbow = grid.xy + la[:, None] * np.column_stack([np.cos(r[:, 0]), np.sin(r[:, 0])])
    u = np.column_stack([np.cos(r.sum(1)), np.sin(r.sum(1))])
    p0, p1 = elbow + s0[:, None] * u, elbow + s1[:, None] * u
    i, j = report.pair_ids.T
    np.testing.assert_allclose(report.pair_min_distance_mm,
                               segment_distance_np(p0[i], p1[i], p0[j], p1[j]), atol=1e-9)
    assert report.n_fiducial_pairs > 0
    i, f = report.fiducial_pair_ids[:, 0], report.fiducial_pair_ids[:, 1] - n
    np.testing.assert_allclose(report.fiducial_min_distance_mm,
                               segment_distance_np(p0[i], p1[i], a[f], b[f]), atol=1e-9)
    clear = min(np.min(report.pair_min_distance_mm - buf[report.pair_ids[:, 0]]
                       - buf[report.pair_ids[:, 1]]),
                np.min(report.fiducial_min_distance_mm - buf[i] - obuf[f]))
    assert report.min_clearance_mm == pytest.approx(clear, abs=1e-12)
    assert not np.array_equal(report.pair_min_distance_mm, nominal.pair_min_distance_mm)
