"""Per-robot geometry in the deadlock search (planners/deadlocks/search), its use by the
roadmap planners, and the post-processing's interaction grouping (planners/postprocess/timing/grouping.py).

Each test builds a tiny layout whose ``extra`` columns give one robot its own alpha
length or buffer, or an obstacle its own shape or keep-out radius, and checks against a
distance written out by hand that the nominal layout and the per-robot one differ by
exactly that robot's value.

Scene used throughout (mm, deg): robot A at the origin stretched along +x (alpha 0,
beta 0): its beta segment lies on y = 0 from ``L_A + seg_start`` to ``L_A + seg_end``.
Robot B at (X, 0) at (alpha 90, beta 180): its beta axis is at (X, L_B) and its segment
points straight down from y = L_B - seg_start to y = L_B - seg_end, across y = 0 (since
``seg_end > L_B``). So the two segments are ``X - L_A - seg_end_A`` apart, whatever B's
own lengths are.
"""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.geometry2d import DEG
from rfp_twin.models.layout import Layout
from rfp_twin.models.robot import load_spec
from rfp_twin.planners.plan import REACHED, Plan
from rfp_twin.planners.deadlocks.search import AlphaBetaWorld, PathSet, trim_tails
from rfp_twin.planners.roadmap import ArmTrajectory
from rfp_twin.planners.postprocess.timing.grouping import (pair_clearance_below, interaction_pairs,
                                               pair_clearance)

SPEC = load_spec("sdss-v")
BUFFER = 2.0
MD = 0.25                       # step-rule margin given to the search world, mm
A_CONF = np.array([0.0, 0.0])
B_CONF = np.array([90.0, 180.0])
#: nominal gap between the segments: the step-rule threshold + 0.5 mm
GAP = 2 * BUFFER + MD + 0.5


def _pair_layout(extra: dict | None = None) -> ArrayGeometry:
    """Robots A (index 0) and B (index 1) of the module's scene, ``GAP`` apart nominally."""
    x_b = SPEC.alpha_length_mm + SPEC.segment_end(BUFFER) + GAP
    layout = Layout([1, 2], [[0.0, 0.0], [x_b, 0.0]], ["robot", "robot"], name="t",
                    extra=extra or {})
    return ArrayGeometry(SPEC, layout, BUFFER)


def _gap(geom: ArrayGeometry) -> float:
    """Segment distance of A and B in the scene, by hand: ``X - L_A - seg_end_A``, mm."""
    assert geom.seg_end[1] > geom.alpha_len[1] > geom.seg_start[1]   # B's segment crosses y = 0
    return float(geom.base_xy[1, 0] - geom.alpha_len[0] - geom.seg_end[0])


def _held_plan(geom: ArrayGeometry, confs: np.ndarray, n_steps: int = 10) -> Plan:
    """A plan in which every robot holds ``confs`` (n, 2) deg from step 0 to ``n_steps``."""
    n = geom.n_robots
    return Plan(robot_ids=geom.robot_ids, step_deg=0.1, step_s=0.01, n_steps=n_steps,
                path_ptr=np.arange(0, 2 * n + 1, 2, dtype=np.int64),
                path_step=np.tile([0.0, float(n_steps)], n),
                path_angles=np.repeat(np.asarray(confs, dtype=np.float64), 2, axis=0),
                status=np.array([REACHED] * n, dtype=object), targets=np.asarray(confs),
                original_targets=np.asarray(confs))


LONG_A = {"alpha_len_mm": [SPEC.alpha_length_mm + 1.0, ""]}        # A's alpha arm 1 mm longer
WIDE_B = {"buffer_add_mm": ["", 1.0]}                               # B's buffer 1 mm larger


# -- timing/grouping ------------------------------------------------------------------------


def test_pair_clearance_uses_each_robots_alpha_length_and_buffer():
    confs = np.array([A_CONF, B_CONF])
    nominal, long_a, wide_b = (_pair_layout(e) for e in (None, LONG_A, WIDE_B))
    assert nominal.uniform and not long_a.uniform and not wide_b.uniform
    got = {}
    for name, geom in (("nominal", nominal), ("long_a", long_a), ("wide_b", wide_b)):
        c = pair_clearance(_held_plan(geom, confs), geom, 0, 1, [0.0, 5.0])
        want = _gap(geom) - geom.buffer[0] - geom.buffer[1]
        np.testing.assert_allclose(c, want, atol=1e-9)
        got[name] = c[0]
    assert got["nominal"] == pytest.approx(GAP - 2 * BUFFER, abs=1e-9)
    assert got["nominal"] - got["long_a"] == pytest.approx(1.0, abs=1e-9)    # 1 mm longer arm
    assert got["nominal"] - got["wide_b"] == pytest.approx(1.0, abs=1e-9)    # 1 mm more buffer


def test_interaction_pairs_see_a_longer_alpha_arm():
    confs = np.array([A_CONF, B_CONF])
    margin = GAP - 2 * BUFFER - 0.5        # between the nominal and the long-arm clearance
    for extra, below in ((None, False), (LONG_A, True)):
        geom = _pair_layout(extra)
        pairs, cl = interaction_pairs(_held_plan(geom, confs), geom, margin)
        assert pairs.tolist() == [[0, 1]]
        assert bool(cl[0] < margin) is below


def test_interaction_walk_bounds_the_speed_of_a_long_arm():
    """A robot with a 200 mm alpha arm sweeps its beta arm past a neighbour: its capsule
    moves ~27 times faster than a nominal one, so a walk whose strides assumed the spec's
    alpha length would jump over the close approach; the per-robot bound finds it."""
    l_long = 200.0
    layout = Layout([1, 2], [[0.0, 0.0], [l_long + 15.0, 0.0]], ["robot", "robot"], name="t",
                    extra={"alpha_len_mm": [l_long, ""]})
    geom = ArrayGeometry(SPEC, layout, BUFFER)
    # A: alpha -30 -> 30 deg over 60 steps, folded (beta 180, segment back towards its base);
    # B: alpha 180, beta 180: its segment from 7.6 mm right of A's beta axis (at alpha 0) outwards
    plan = Plan(robot_ids=geom.robot_ids, step_deg=1.0, step_s=0.1, n_steps=60,
                path_ptr=np.array([0, 2, 4]), path_step=np.array([0.0, 60.0, 0.0, 60.0]),
                path_angles=np.array([[-30.0, 180.0], [30.0, 180.0], [180.0, 180.0],
                                      [180.0, 180.0]]),
                status=np.array([REACHED] * 2, dtype=object), targets=np.zeros((2, 2)),
                original_targets=np.zeros((2, 2)))
    margin = 5.0
    dense = pair_clearance(plan, geom, 0, 1, np.linspace(0.0, 60.0, 6001))
    # closest at A's alpha 0: A's beta axis at x = 200, B's at x = 215 - 7.4; both segments
    # start seg_start from their axes, towards each other
    gap = (l_long + 15.0 - SPEC.alpha_length_mm) - l_long - 2 * SPEC.segment_start_mm
    assert dense.min() == pytest.approx(gap - 2 * BUFFER, abs=1e-6)
    assert dense.min() < margin
    pairs, cl = interaction_pairs(plan, geom, margin)
    assert pairs.tolist() == [[0, 1]] and cl[0] < margin
    # the same walk with the spec's alpha length in the speed bound misses it
    r = max(float(geom.seg_end.max()), SPEC.segment_start_mm)
    mu_spec = np.full(2, (SPEC.alpha_length_mm + 2.0 * r) * plan.step_deg * DEG)
    wrong = pair_clearance_below(plan.path_ptr, plan.path_step, plan.path_angles, 60.0,
                                  geom.base_xy, pairs, geom.alpha_len, geom.seg_start,
                                  geom.seg_end, geom.buffer, mu_spec, margin)
    assert wrong[0] >= margin


# -- the deadlock search: the world's black boxes and trim_tails -----------------------------------


def _world(geom: ArrayGeometry, b_movable: bool) -> AlphaBetaWorld:
    """A world in which B holds B_CONF from step 0 (a mover, or offline)."""
    paths = PathSet([np.zeros(1), np.zeros(1)], [A_CONF[None, :].copy(), B_CONF[None, :].copy()])
    return AlphaBetaWorld(geom, paths, np.array([True, b_movable]), MD, 0.5)


@pytest.mark.parametrize("extra, blocked", [(None, False), (LONG_A, True), (WIDE_B, True)])
def test_world_collisions_use_each_robots_geometry(extra, blocked):
    geom = _pair_layout(extra)
    threshold = geom.buffer[0] + geom.buffer[1] + MD
    assert bool(_gap(geom) <= threshold) is blocked          # by hand: GAP -/+ 1 mm vs 2 b + MD
    q = A_CONF[None, :]
    mover = _world(geom, True).arm(0, A_CONF, A_CONF)
    assert bool(mover.collides(q, np.zeros(1))[0]) is blocked
    assert not mover.forbidden(q)[0]
    offline = _world(geom, False).arm(0, A_CONF, A_CONF)
    assert bool(offline.forbidden(q)[0]) is blocked
    # the pairwise trajectory test of the priority search
    world = _world(geom, True)
    hold = lambda c: ArmTrajectory(np.array([0.0, 3.0]), np.array([c, c]), np.array([c, c]),
                                   0, 0, 0)
    assert world.conflict(0, hold(A_CONF), 1, hold(B_CONF)) is blocked


@pytest.mark.parametrize("extra, trimmed", [(None, [0]), (LONG_A, [])])
def test_trim_tails_holds_each_robot_with_its_own_arm(extra, trimmed):
    """A arrives at A_CONF at step 10, steps aside and is back at 30: trimmed only where
    its own (held) arm keeps the step rule with B."""
    geom = _pair_layout(extra)
    away = A_CONF + [0.0, 90.0]
    paths = PathSet([np.array([0.0, 10.0, 20.0, 30.0]), np.zeros(1)],
                    [np.array([away, A_CONF, away, A_CONF]), B_CONF[None, :].copy()])
    dest = np.array([A_CONF, B_CONF])
    assert trim_tails(geom, paths, dest, np.array([False, True]), MD) == trimmed


def _obstacle_world(extra: dict, xy) -> tuple[ArrayGeometry, AlphaBetaWorld]:
    """One robot at the origin and one obstacle row (kind "gfa") at ``xy``."""
    layout = Layout([1, 2], [[0.0, 0.0], xy], ["robot", "gfa"], name="t", extra=extra)
    geom = ArrayGeometry(SPEC, layout, BUFFER)
    paths = PathSet([np.zeros(1)], [A_CONF[None, :].copy()])
    return geom, AlphaBetaWorld(geom, paths, np.array([True]), MD, 0.5)


def test_world_sees_a_gfa_segment_obstacle():
    """A guide-camera edge from (15, 30) to (15, -30) crosses A's stretched arm (y = 0,
    x 7.4..22.4); a point at its first end is 30 mm away and blocks nothing."""
    q = np.array([A_CONF, [90.0, 0.0]])          # stretched along +x; along +y (x = 0)
    seg_geom, seg_world = _obstacle_world({"x2_mm": ["", 15.0], "y2_mm": ["", -30.0]},
                                          [15.0, 30.0])
    assert seg_geom.robot_fid_pairs.tolist() == [[0, 0]]
    np.testing.assert_array_equal(seg_geom.fid_end_xy, [[15.0, -30.0]])
    arm = seg_world.arm(0, A_CONF, A_CONF)
    np.testing.assert_array_equal(arm.forbidden(q), [True, False])
    _, pt_world = _obstacle_world({}, [15.0, 30.0])
    np.testing.assert_array_equal(pt_world.arm(0, A_CONF, A_CONF).forbidden(q), [False, False])


def test_world_uses_each_obstacles_buffer():
    """A point 6 mm off A's stretched arm: clear at the spec's 1.5 mm keep-out (threshold
    2 + 1.5 + MD = 3.75 mm), blocked at 4 mm (6.25 mm)."""
    q = A_CONF[None, :]
    for extra, blocked in (({}, False), ({"obstacle_buffer_mm": ["", 4.0]}, True)):
        geom, world = _obstacle_world(extra, [15.0, 6.0])
        assert bool(6.0 <= BUFFER + geom.fid_buffer[0] + MD) is blocked
        assert bool(world.arm(0, A_CONF, A_CONF).forbidden(q)[0]) is blocked
