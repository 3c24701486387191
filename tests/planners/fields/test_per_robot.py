"""Per-robot geometry in the potential-field planners (planners/fields/): each robot's own
alpha length, beta segment and buffer, and obstacles that are segments ("gfa" rows) with
their own keep-out radius. Every test compares a per-robot layout with the nominal one,
so it fails when the per-robot value is ignored. Lengths in mm, angles in deg."""
from __future__ import annotations

import math

import numpy as np
import pytest

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.errors import TargetError
from rfp_twin.models.layout import Layout
from rfp_twin.planners.fields import ApfSettings, CapfSettings, default_margin_mm, plan_apf, \
    random_tip_configs
from rfp_twin.planners.fields.driver import tip_positions
from rfp_twin.planners.fields.field import obstacle_distance, pair_distance, arm_poses
from rfp_twin.planners.fields.tips import assign_tips
from tests.planners.fields.cases import DESI, SDSS, tips

SEG = ApfSettings(model="segment")


def geom_of(spec, xy, kinds=None, **extra) -> ArrayGeometry:
    """Geometry of positions ``xy`` (robots unless ``kinds``) with extra layout columns."""
    n = len(xy)
    lay = Layout(np.arange(n), np.asarray(xy, dtype=float), kinds or ["robot"] * n, name="t",
                 extra={k: np.asarray(v, dtype=object) for k, v in extra.items()})
    return ArrayGeometry(spec, lay, spec.buffer_mm)


# --------------------------------------------------------------------------------------
# alpha length: forward positions, field pose, kernel tips
# --------------------------------------------------------------------------------------
def test_tip_positions_use_each_robots_alpha_length():
    xy = [[0.0, 0.0], [40.0, 0.0]]
    ang = np.array([[30.0, 40.0], [100.0, 20.0]])
    nominal = tip_positions(geom_of(SDSS, xy), ang)
    longer = tip_positions(geom_of(SDSS, xy, alpha_len_mm=[8.4, ""]), ang)
    np.testing.assert_array_equal(nominal, tips(geom_of(SDSS, xy), ang))
    shift = longer - nominal
    np.testing.assert_allclose(shift[0], [math.cos(math.radians(30.0)), math.sin(math.radians(30.0))],
                               atol=1e-12)
    np.testing.assert_array_equal(shift[1], [0.0, 0.0])


def test_pose_puts_each_elbow_at_its_own_alpha_length():
    base = np.array([[0.0, 0.0], [40.0, 0.0]])
    th = np.radians([[60.0, 10.0], [60.0, 10.0]])
    P = np.empty((2, 6))
    arm_poses(base, th, np.array([7.4, 9.4]), P)
    np.testing.assert_allclose(P[0, 4:] - base[0], 7.4 * np.array([0.5, math.sqrt(0.75)]))
    np.testing.assert_allclose(P[1, 4:] - base[1], 9.4 * np.array([0.5, math.sqrt(0.75)]))


@pytest.mark.parametrize("settings", [ApfSettings(), CapfSettings()])
def test_kernel_tip_distance_uses_the_longer_alpha_arm(settings):
    """Tips at (l_alpha0, 3) and (7.4, 3): a 1 mm longer alpha arm on robot 0 brings
    them exactly 1 mm closer, in the kernel's own statistics (start = targets)."""
    xy = [[0.0, 0.0], [10.4, 0.0]]
    ang = np.array([[0.0, 90.0], [180.0, 270.0]])
    out = {}
    for label, extra in (("nominal", {}), ("longer", {"alpha_len_mm": [4.0, ""]})):
        r = plan_apf(geom_of(DESI, xy, **extra), ang, ang, settings)
        assert r.stop_reason == "converged" and r.steps == 0
        out[label] = r.min_tip_distance_mm
    assert out["nominal"] == pytest.approx(4.4, abs=1e-9)
    assert out["longer"] == pytest.approx(3.4, abs=1e-9)


def test_kernel_converges_on_the_tip_of_the_robots_own_arm():
    """The field pulls the tip to the target computed with the robot's alpha length:
    the final angles put its own tip on it (a nominal-arm kernel would not)."""
    geom = geom_of(SDSS, [[0.0, 0.0]], alpha_len_mm=[9.0])
    start = np.array([[20.0, 60.0]])
    targets = np.array([[70.0, 40.0]])
    r = plan_apf(geom, start, targets, ApfSettings(tol_mm=0.01))
    assert r.stop_reason == "converged"
    err = np.hypot(*(tip_positions(geom, r.final) - tip_positions(geom, targets))[0])
    assert err < 0.01
    nominal_err = np.hypot(*(tips(geom, r.final) - tip_positions(geom, targets))[0])
    assert nominal_err > 1.0


def test_margin_uses_the_longest_alpha_arm():
    xy = [[0.0, 0.0], [40.0, 0.0]]
    m0 = default_margin_mm(geom_of(SDSS, xy), SEG)
    m1 = default_margin_mm(geom_of(SDSS, xy, alpha_len_mm=["", 8.4]), SEG)
    wa = SDSS.max_speed_deg_s[0] * math.pi / 180.0
    expected = 1.0 * (wa * SEG.dt_s + 2.0 * SEG.simplify_tol_deg * math.pi / 180.0)
    assert m1 - m0 == pytest.approx(expected, rel=1e-9)


def test_random_tips_use_each_robots_own_arm():
    """DESI (3 + 3 mm) hex:7 with 4.5 mm alpha arms on robots 0-2: their tips reach
    1.5..7.5 mm (beyond the nominal 6 mm), and every pair of real tips is > sep apart."""
    lay = Layout.hex_grid_positions(7, DESI.pitch_mm)
    la = [4.5] * 3 + [""] * 4
    geom = ArrayGeometry(DESI, Layout(lay.ids, lay.xy, lay.kinds, name="t",
                                      extra={"alpha_len_mm": np.asarray(la, dtype=object)}),
                         DESI.buffer_mm)
    radii, seps = [], []
    for seed in range(12):
        tip = tip_positions(geom, random_tip_configs(geom, np.random.default_rng(seed), 3.0))
        radii.append(np.hypot(*(tip[:3] - geom.base_xy[:3]).T))
        seps.append(min(np.hypot(*(tip[i] - tip[j])) for i in range(7) for j in range(i)))
    radii = np.concatenate(radii)
    assert np.all((radii >= 1.5 - 1e-9) & (radii <= 7.5 + 1e-9))
    assert radii.max() > 6.0 + 1e-6
    assert min(seps) > 3.0


def test_tip_separation_uses_each_robots_alpha_length():
    """Robot 1 (fixed) has its tip at x = 4.4; robot 0's only candidate (0, 0) puts its
    tip at 4.5 + 3 = 7.5 mm (3.1 mm away: accepted at sep 2); a nominal 3 mm arm would
    put it at 6 mm (1.6 mm: rejected)."""
    base = np.array([[0.0, 0.0], [10.4, 0.0]])
    pool = np.zeros((2, 1, 2))
    fixed = np.array([False, True])
    nbr_ptr, nbr_idx = np.array([0, 1, 2]), np.array([1, 0])
    no_fid = (np.zeros(3, dtype=np.int64), np.zeros(0, dtype=np.int64), np.zeros((0, 2)),
              np.zeros((0, 2)))
    results = []
    for la0 in (4.5, 3.0):
        out = np.array([[0.0, 0.0], [180.0, 0.0]])
        results.append(assign_tips(base, pool, fixed, out, nbr_ptr, nbr_idx, *no_fid,
                                    np.array([la0, 3.0]), 3.0, 2.0, np.zeros(0)))
    assert results == [-1, 0]


# --------------------------------------------------------------------------------------
# segment model: alpha length and buffer of one robot
# --------------------------------------------------------------------------------------
def _facing(extra_gap_mm: float):
    """Robot 0 points right (0, 0); robot 1 at (x1, 0) folded (180, 180) points right
    too: its segment starts 7.4 mm left of its base. Gap along x = d + extra_gap."""
    d = SEG.distances(geom_of(SDSS, [[0.0, 0.0], [40.0, 0.0]]))[0]
    x1 = 7.4 + 15.0 + 7.4 + d + extra_gap_mm
    return [[0.0, 0.0], [x1, 0.0]], np.array([[0.0, 0.0], [180.0, 180.0]]), d


def test_longer_alpha_arm_turns_a_clear_start_into_a_collision():
    xy, ang, d = _facing(0.5)
    r = plan_apf(geom_of(SDSS, xy), ang, ang, SEG)
    assert r.min_distance_mm == pytest.approx(d + 0.5, abs=1e-9)
    with pytest.raises(TargetError, match=r"robots 0 and 1: beta segments 4\.7086 mm apart"):
        plan_apf(geom_of(SDSS, xy, alpha_len_mm=[8.4, ""]), ang, ang, SEG)


def test_larger_buffer_of_one_robot_raises_its_threshold():
    xy, ang, d = _facing(0.5)
    geom = geom_of(SDSS, xy, buffer_add_mm=["", 0.75])
    with pytest.raises(TargetError, match=rf"allowed: > d = {d + 0.75:.4f} mm"):
        plan_apf(geom, ang, ang, SEG)
    # the tip model's tips are points: buffers do not enter it
    plan_apf(geom, ang, ang, ApfSettings())


def test_larger_buffer_holds_a_robot_farther_away():
    """Robot 0 (offline) lies along y = 0; robot 1 above it is pulled to a tip 1 mm
    inside the nominal threshold d. The barrier holds it just outside d, and outside
    d + 0.5 when its buffer is 0.5 mm larger (pair threshold and envelope grow)."""
    d = SEG.distances(geom_of(SDSS, [[0.0, 0.0], [40.0, 0.0]]))[0]
    xy = [[0.0, 0.0], [14.9, 22.4 + d - 1.0]]
    start = np.array([[0.0, 0.0], [270.0, 40.0]])
    targets = np.array([[0.0, 0.0], [270.0, 0.0]])
    gaps = {}
    for label, add in (("nominal", ""), ("worn", 0.5)):
        geom = geom_of(SDSS, xy, buffer_add_mm=["", add])
        r = plan_apf(geom, start, targets, ApfSettings(model="segment", max_time_s=4.0),
                     movable=np.array([False, True]))
        P = np.empty((2, 6))
        arm_poses(geom.base_xy, np.radians(r.final), geom.alpha_len, P)
        gaps[label] = pair_distance(P, 0, 1, True, 15.0, geom.seg_start, geom.seg_end)[0]
        assert r.min_distance_mm > r.d_mm
    assert d < gaps["nominal"] < d + 0.45
    assert gaps["worn"] > d + 0.5


# --------------------------------------------------------------------------------------
# obstacles: guide-camera edges are segments
# --------------------------------------------------------------------------------------
def _gfa(h_mm: float, segment: bool = True):
    """One SDSS robot at the origin, arm along +x (segment 7.4..22.4 mm on y = 0) and a
    gfa edge from (14.9, h + 40) down to (14.9, h): its near end faces the middle of the
    beta segment. ``segment=False``: the same row without its second end (a point)."""
    xy = [[0.0, 0.0], [14.9, h_mm + 40.0]]
    extra = {"x2_mm": ["", 14.9], "y2_mm": ["", h_mm]} if segment else {}
    return geom_of(SDSS, xy, ["robot", "gfa"], **extra)


def test_field_distance_to_a_gfa_segment_is_at_the_arm_middle():
    geom = _gfa(5.0)
    P = np.empty((1, 6))
    arm_poses(geom.base_xy, np.zeros((1, 2)), geom.alpha_len, P)
    s, r, px, py, qx, qy = obstacle_distance(P, 0, geom.fid_xy, geom.fid_end_xy, 0, True, 15.0,
                                geom.seg_start, geom.seg_end)
    assert s == pytest.approx(5.0) and r == pytest.approx(7.5)
    assert (px, py, qx, qy) == pytest.approx((14.9, 0.0, 14.9, 5.0))
    point = _gfa(5.0, segment=False)
    s_pt, *_ = obstacle_distance(P, 0, point.fid_xy, point.fid_end_xy, 0, True, 15.0, point.seg_start,
                    point.seg_end)
    assert s_pt == pytest.approx(45.0)


def test_gfa_segment_blocks_a_start_that_its_first_end_does_not():
    d_f = SEG.distances(_gfa(3.7))[2]
    ang = np.zeros((1, 2))
    h = d_f - 0.5
    r = plan_apf(_gfa(h, segment=False), ang, ang, SEG)
    assert r.stop_reason == "converged"
    with pytest.raises(TargetError, match=rf"robot 0: {h:.4f} mm from gfa 1; allowed: > {d_f:.4f}"):
        plan_apf(_gfa(h), ang, ang, SEG)


def _edge_distance(geom, angles_deg):
    """(distance of robot 0's beta segment to obstacle 0, r of its closest point), mm."""
    P = np.empty((1, 6))
    arm_poses(geom.base_xy, np.radians(np.asarray(angles_deg, dtype=float)), geom.alpha_len, P)
    s, r, *_ = obstacle_distance(P, 0, geom.fid_xy, geom.fid_end_xy, 0, True, 15.0, geom.seg_start,
                    geom.seg_end)
    return s, r


def test_gfa_segment_repels_the_beta_segment():
    """Target: alpha 4 deg (the arm's middle rises 1 mm towards the edge, 1.2 mm
    outside d_fid). The segment edge pushes the middle of the arm away: the robot bends
    beta to bring its tip near the target with the arm farther from the edge than the
    target's arm, and does not converge; a point at the edge's first end does not act."""
    d_f, D_f = SEG.distances(_gfa(5.0))[2:4]
    h = d_f + 1.2
    assert h < D_f
    start = np.zeros((1, 2))
    targets = np.array([[4.0, 0.0]])
    free = plan_apf(_gfa(h, segment=False), start, targets, SEG)
    held = plan_apf(_gfa(h), start, targets, SEG)
    assert free.stop_reason == "converged" and abs(free.final[0, 1]) < 3.0
    assert not held.converged[0]
    assert d_f < held.min_fiducial_distance_mm < h
    geom = _gfa(h)
    s_target, r_target = _edge_distance(geom, targets)
    s_final, r_final = _edge_distance(geom, held.final)
    assert s_target < d_f + 0.3 and 5.0 < r_target < 10.0     # near the arm's middle
    assert s_final > s_target + 0.2
    assert held.final[0, 1] > 5.0


def test_larger_obstacle_buffer_raises_its_threshold():
    ang = np.zeros((1, 2))
    d_f = SEG.distances(_gfa(5.0))[2]
    xy = [[0.0, 0.0], [14.9, 40.0 + d_f + 0.5]]
    extra = {"x2_mm": ["", 14.9], "y2_mm": ["", d_f + 0.5]}
    plan_apf(geom_of(SDSS, xy, ["robot", "gfa"], **extra), ang, ang, SEG)
    wide = geom_of(SDSS, xy, ["robot", "gfa"], obstacle_buffer_mm=["", 2.5], **extra)
    with pytest.raises(TargetError, match=rf"allowed: > {d_f + 1.0:.4f} mm"):
        plan_apf(wide, ang, ang, SEG)


def test_random_tips_keep_off_a_gfa_segment():
    """DESI robot with an edge along y = 1 across its whole patrol disk (first end at
    x = 10, outside it): tips stay > sep / 2 + 1 mm from the line, which a point at the
    first end would not enforce."""
    xy = [[0.0, 0.0], [10.0, 1.0]]
    geom = geom_of(DESI, xy, ["robot", "gfa"], x2_mm=["", -10.0], y2_mm=["", 1.0])
    point = geom_of(DESI, xy, ["robot", "gfa"])
    ys, ys_point = [], []
    for seed in range(20):
        ys.append(tips(geom, random_tip_configs(geom, np.random.default_rng(seed), 2.0))[0, 1])
        ys_point.append(tips(point, random_tip_configs(point, np.random.default_rng(seed), 2.0))[0, 1])
    assert np.all(np.abs(np.array(ys) - 1.0) > 2.0)
    assert np.any(np.abs(np.array(ys_point) - 1.0) <= 2.0)


# --------------------------------------------------------------------------------------
# nominal values written out change nothing
# --------------------------------------------------------------------------------------
def test_blank_and_nominal_columns_give_identical_runs():
    lay = Layout.hex_grid_positions(7, DESI.pitch_mm)
    geom = ArrayGeometry(DESI, lay, DESI.buffer_mm)
    cols = {"alpha_len_mm": np.asarray([""] * 3 + [3.0] * 4, dtype=object),
            "buffer_add_mm": np.asarray([0.0] + [""] * 6, dtype=object)}
    same = ArrayGeometry(DESI, Layout(lay.ids, lay.xy, lay.kinds, name="t", extra=cols),
                         DESI.buffer_mm)
    rng = np.random.default_rng(4)
    start = random_tip_configs(geom, rng, 2.1)
    targets = random_tip_configs(geom, rng, 3.0)
    np.testing.assert_array_equal(random_tip_configs(same, np.random.default_rng(8), 2.1),
                                  random_tip_configs(geom, np.random.default_rng(8), 2.1))
    for settings in (ApfSettings(), ApfSettings(model="segment", d_mm=2.0, D_mm=3.0)):
        a = plan_apf(geom, start, targets, settings)
        b = plan_apf(same, start, targets, settings)
        np.testing.assert_array_equal(a.final, b.final)
        assert (a.steps, a.min_distance_mm) == (b.steps, b.min_distance_mm)
