"""Local smoothing windows (planners/postprocess/smoothing_local.py): exact, C1, narrow only where asked."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.planners.plan import Plan, build_paths
from rfp_twin.planners.postprocess.smoothing import smooth_plan
from rfp_twin.planners.postprocess.smoothing_local import WindowRegions, smooth_plan_local

W = 40.0
PAD = 20.0


def zigzag_plan(n_steps: int = 400, seed: int = 0) -> Plan:
    """Two robots that move at one step per step with frequent corners and waits."""
    rng = np.random.default_rng(seed)
    steps, robot, angles = [], [], []
    for i in range(2):
        q = np.array([10.0 + 30 * i, 170.0])
        for s in range(1, n_steps + 1):
            q = q + rng.choice([-0.1, 0.0, 0.1, 0.1], size=2)
            steps.append(s)
            robot.append(i)
            angles.append(q.copy())
    ev_robot = np.array(robot, dtype=np.int64)
    ev_step = np.array(steps, dtype=np.float64)
    ev_angles = np.array(angles)
    start = np.array([[10.0, 170.0], [40.0, 170.0]])
    end = np.array([ev_angles[ev_robot == i][-1] for i in range(2)])
    ptr, st, ang = build_paths(2, ev_robot, ev_step, ev_angles, start, end, n_steps)
    return Plan(np.array([7, 8]), 0.1, 0.1 / 30.0, n_steps, ptr, st, ang,
                np.array(["reached", "reached"], dtype=object), end, end)


def test_without_regions_it_is_the_plain_running_average():
    plan = zigzag_plan()
    w = np.full(2, W)
    a = smooth_plan(plan, window_steps=w, pad_steps=PAD)
    b = smooth_plan_local(plan, w, WindowRegions(2), PAD)
    np.testing.assert_array_equal(a.coef, b.coef)
    np.testing.assert_array_equal(a.knots, b.knots)


def test_deep_inside_a_stretch_the_path_is_the_narrow_average_and_elsewhere_the_wide():
    plan = zigzag_plan()
    w = np.full(2, W)
    reg = WindowRegions(2)
    reg.add(0, 100.0, 260.0, 1)
    reg.add(0, 150.0, 210.0, 2)
    path = smooth_plan_local(plan, w, reg, PAD)
    wide = smooth_plan(plan, window_steps=w, pad_steps=PAD)
    mid = smooth_plan(plan, window_steps=np.full(2, W / 2), pad_steps=PAD)
    narrow = smooth_plan(plan, window_steps=np.full(2, W / 4), pad_steps=PAD)
    u = np.arange(0.0, 401.0, 0.5) + PAD
    got = path.evaluate(u, [0])[:, 0]
    # far from the stretches: the wide average; level 1 beyond W/2 from its ends and
    # outside level 2: the W/2 average; deep in level 2: the W/4 average
    for lo, hi, ref in ((0, 100 - W, wide), (260 + W, 400, wide), (120, 150 - W / 4, mid),
                        (150 + W / 4, 210 - W / 4, narrow)):
        m = (u - PAD >= lo) & (u - PAD <= hi)
        assert m.any()
        np.testing.assert_allclose(got[m], ref.evaluate(u[m], [0])[:, 0], atol=1e-9)
    # the other robot is untouched
    np.testing.assert_array_equal(path.evaluate(u, [1]), wide.evaluate(u, [1]))


def test_c1_with_the_plans_exact_ends():
    plan = zigzag_plan(seed=3)
    reg = WindowRegions(2)
    reg.add(1, 50.0, 390.0, 1)
    reg.add(1, 300.0, 400.0, 3)        # covers the plan's end
    path = smooth_plan_local(plan, np.full(2, W), reg, PAD)
    s = np.linspace(0.0, path.s_end, 400_001)
    ds = s[1] - s[0]
    q, qd = path.evaluate(s, [1], 0)[:, 0], path.evaluate(s, [1], 1)[:, 0]
    # C0 and C1: no jumps beyond what the local slope / curvature explain
    assert np.abs(np.diff(q, axis=0)).max() <= np.abs(qd).max() * ds * 1.01 + 1e-12
    qdd = path.evaluate(s, [1], 2)[:, 0]
    assert np.abs(np.diff(qd, axis=0)).max() <= np.abs(qdd).max() * ds * 1.01 + 1e-12
    np.testing.assert_array_equal(path.start(), plan.start())
    np.testing.assert_array_equal(path.end(), plan.end())
    np.testing.assert_allclose(path.evaluate([0.0, path.s_end], [1])[:, 0],
                               np.stack([plan.start()[1], plan.end()[1]]), atol=1e-9)


def test_a_stretch_that_covers_the_end_smooths_the_end_corner_with_its_own_window():
    """A robot still moving on the plan's last step: its end corner is smoothed with the
    window of the stretch that covers the end, not the widest one."""
    plan = zigzag_plan(seed=5)
    reg = WindowRegions(2)
    reg.add(0, 300.0, 500.0, 2)
    path = smooth_plan_local(plan, np.full(2, W), reg, PAD)
    narrow = smooth_plan(plan, window_steps=np.full(2, W / 4), pad_steps=PAD)
    wide = smooth_plan(plan, window_steps=np.full(2, W), pad_steps=PAD)
    u = np.arange(300.0 + W, 400.0 + PAD, 0.5) + PAD
    np.testing.assert_allclose(path.evaluate(u, [0]), narrow.evaluate(u, [0]), atol=1e-9)
    dev_local = np.abs(path.evaluate([400.0 + PAD], [0]) - plan.end()[0]).max()
    dev_wide = np.abs(wide.evaluate([400.0 + PAD], [0]) - plan.end()[0]).max()
    assert dev_local < dev_wide


def test_regions_nest_and_report_their_level():
    reg = WindowRegions(3)
    assert reg.level(0, 0.0, 10.0) == 0 and reg.robots() == []
    assert reg.add(0, 100.0, 200.0, 2)
    assert reg.regions[0] == [[(100.0, 200.0)], [(100.0, 200.0)]]
    assert not reg.add(0, 120.0, 180.0, 1)          # already covered: nothing changes
    assert reg.add(0, 150.0, 260.0, 1)
    assert reg.regions[0][0] == [(100.0, 260.0)]
    assert reg.level(0, 210.0, 220.0) == 1 and reg.level(0, 190.0, 220.0) == 2
    assert reg.inside(0, 120.0, 180.0, 2, 20.0) and not reg.inside(0, 120.0, 190.0, 2, 20.0)
    assert reg.robots() == [0] and reg.max_level() == 2


@pytest.mark.parametrize("level", [1, 4])
def test_narrow_average_is_kept_at_any_level(level):
    plan = zigzag_plan(seed=level)
    reg = WindowRegions(2)
    for k in range(1, level + 1):
        reg.add(1, 100.0 + 10 * k, 300.0 - 10 * k, k)
    path = smooth_plan_local(plan, np.full(2, W), reg, PAD)
    ref = smooth_plan(plan, window_steps=np.full(2, W / 2 ** level), pad_steps=PAD)
    u = np.arange(100.0 + 10 * level + W, 300.0 - 10 * level - W, 1.0) + PAD
    np.testing.assert_allclose(path.evaluate(u, [1]), ref.evaluate(u, [1]), atol=1e-9)
