"""Time-optimal parametrisation (planners/timing.py): limits, optimality, groups."""
from __future__ import annotations

import numpy as np
import pytest

from models.errors import PlanningError
from models.geometry2d import pair_distances
from planners.smoothing import smooth_plan, window_for_limits
from planners.timing import (DEFAULT_BACKEND, TimeLaw, group_grid, interaction_groups,
                             interaction_pairs, law_excess, pl_kinematics, time_group,
                             topp)
from tests.planners.conftest import make_geom, plan_random
from tests.planners.test_smoothing import CORNER

V, A = 30.0, 45.0


def numeric_kinematics(path, robots, law: TimeLaw, dt: float = 2e-4):
    """Largest |dq/dt| and |d2q/dt2| of the smooth timed path, by finite differences."""
    t = np.arange(0.0, law.duration + dt, dt)
    q = path.evaluate(law.s_at(t), robots).reshape(t.size, -1)
    v = np.diff(q, axis=0) / dt
    a = np.diff(q, 2, axis=0) / dt**2
    return np.abs(v).max(), np.abs(a).max()


@pytest.mark.parametrize("distance", [5.0, 40.0])
def test_straight_move_is_the_trapezoid(distance):
    """q = c s on a fine grid: accelerate at a, cruise at v, brake at a."""
    c = 0.1
    grid = np.linspace(0.0, distance / c, 4001)
    qd = np.full((grid.size, 1), c)
    law = topp(grid, qd, np.zeros((grid.size - 1, 1)), [V], [A])
    exact = distance / V + V / A if distance >= V * V / A else 2.0 * np.sqrt(distance / A)
    assert law.duration == pytest.approx(exact, rel=2e-3)
    assert law.sd[0] == 0.0 and law.sd[-1] == 0.0
    assert law.sd.max() * c <= V * (1 + 1e-9)


def test_numba_kernel_matches_the_toppra_library():
    """Same problem, same gridpoints: toppra's TOPPRA (seidel) and ours agree."""
    import toppra as ta
    import toppra.algorithm as algo
    import toppra.constraint as constraint

    ta.setup_logging("WARNING")
    rng = np.random.default_rng(1)
    for _ in range(3):
        path = ta.SplineInterpolator(np.linspace(0, 100, 12),
                                     rng.normal(size=(12, 4)).cumsum(0) * 3, bc_type="clamped")
        for n, rel in ((200, 0.03), (1000, 0.005)):
            grid = np.linspace(0, 100, n + 1)
            inst = algo.TOPPRA([constraint.JointVelocityConstraint(np.array([[-V, V]] * 4)),
                                constraint.JointAccelerationConstraint(np.array([[-A, A]] * 4))],
                               path, gridpoints=grid, solver_wrapper="seidel")
            _, sd, _ = inst.compute_parameterization(0, 0)
            t_lib = np.sum(2 * np.diff(grid) / (sd[1:] + sd[:-1]))
            mid = 0.5 * (grid[1:] + grid[:-1])
            law = topp(grid, path(grid, 1), path(mid, 2), np.full(4, V), np.full(4, A))
            assert law.duration == pytest.approx(t_lib, rel=rel)
            assert law.duration >= t_lib * (1 - 1e-3)     # ours is the conservative one


@pytest.mark.parametrize("window", [10.0, 60.0, 200.0])
def test_smoothed_path_respects_limits_continuously(window):
    sp = smooth_plan(CORNER, window_steps=window)
    law = time_group(sp, [0], (V, V), (A, A))
    vm, am = numeric_kinematics(sp, [0], law)
    assert vm <= V * 1.001 and am <= A * 1.01
    assert vm >= 0.95 * V                                 # and uses them
    # at rest at both ends, at the plan's start and end configurations
    np.testing.assert_allclose(sp.evaluate(law.s_at([0.0, law.duration]))[:, 0],
                               [CORNER.start()[0], CORNER.end()[0]], atol=1e-9)
    # the reversal costs time: wider windows are faster
    assert law.duration > 40.0 / V


def test_wider_windows_are_faster_on_a_real_group():
    geom = make_geom(37, 2.5)
    _, plan = plan_random(geom, 2, step_deg=0.1)
    pairs, cl = interaction_pairs(plan, geom, 1.0)
    labels = interaction_groups(geom.n_robots, pairs[cl < 1.0])
    sizes = np.bincount(labels)
    robots = np.flatnonzero(labels == np.argmax(sizes))
    assert robots.size >= 2
    durations = []
    for w in (5.0, 50.0, 200.0):
        sp = smooth_plan(plan, window_steps=w)
        law = time_group(sp, robots, (V, V), (A, A))
        vm, am = numeric_kinematics(sp, robots, law, dt=5e-4)
        assert vm <= V * 1.001 and am <= A * 1.01
        durations.append(law.duration)
    assert durations[0] > durations[1] > durations[2]


def real_groups(n_positions=37, buffer_mm=2.0, seed=2):
    """A real greedy plan at 0.1 deg, smoothed as the pipeline does (window v^2 / (a d)),
    and its interaction groups (1 mm): (path, [robot index arrays])."""
    geom = make_geom(n_positions, buffer_mm)
    _, plan = plan_random(geom, seed, step_deg=0.1)
    sp = smooth_plan(plan, window_steps=window_for_limits((V, V), (A, A), plan.step_deg))
    pairs, cl = interaction_pairs(plan, geom, 1.0)
    labels = interaction_groups(geom.n_robots, pairs[cl < 1.0])
    return sp, [np.flatnonzero(labels == g) for g in np.unique(labels)]


def test_toppra_backend_solves_every_group_of_a_real_smoothed_plan():
    """The library (seidel) on real groups: every one solved, within the limits, and the
    same law as the numba kernel (the same discretised problem on the same grid)."""
    sp, groups = real_groups()
    assert max(g.size for g in groups) >= 2
    mrange = sp.moving_range()
    for robots in groups:
        lib = time_group(sp, robots, (V, V), (A, A), backend="toppra", fallback=False,
                         moving_range=mrange)
        ker = time_group(sp, robots, (V, V), (A, A), backend="numba", moving_range=mrange)
        if ker.solver == "static":
            assert lib.solver == "static"
            continue
        assert lib.solver == "toppra" and ker.solver == "numba"
        np.testing.assert_array_equal(lib.s, ker.s)
        assert lib.duration == pytest.approx(ker.duration, rel=1e-4)
        assert lib.sd[0] == 0.0 and lib.sd[-1] == 0.0
        # the smooth timed path, by finite differences: within the limits (1 %)
        vm, am = numeric_kinematics(sp, robots, lib, dt=5e-4)
        assert vm <= V * 1.01 and am <= A * 1.01
        # and the discretised constraints the law was solved under (limits * 0.999)
        k = robots.size
        qd = sp.evaluate(lib.s, robots, 1).reshape(lib.s.size, 2 * k)
        mid = 0.5 * (lib.s[1:] + lib.s[:-1])
        qdd = sp.evaluate(mid, robots, 2).reshape(mid.size, 2 * k)
        rv, ra = law_excess(np.diff(lib.s), qd, qdd, np.full(2 * k, V * 0.999),
                            np.full(2 * k, A * 0.999), lib.sd**2, 1e5)
        assert rv <= 1.0 + 1e-9 and ra <= 1.0 + 1e-6


def test_toppra_backend_falls_back_to_the_kernel_only_when_the_library_fails(monkeypatch):
    from planners import timing_toppra

    sp, groups = real_groups()
    robots = max(groups, key=len)
    ker = time_group(sp, robots, (V, V), (A, A), backend="numba")
    monkeypatch.setattr(timing_toppra, "solve", lambda *args: None)
    law = time_group(sp, robots, (V, V), (A, A), backend="toppra")
    assert law.solver == "fallback" and law.duration == ker.duration
    with pytest.raises(PlanningError, match="toppra"):
        time_group(sp, robots, (V, V), (A, A), backend="toppra", fallback=False)


def test_groups_above_the_toppra_size_cap_go_to_the_kernel():
    """toppra_max_robots: a group larger than the cap is timed by the kernel (solver
    "numba-large"), with the same law the library gives it without the cap."""
    sp, groups = real_groups()
    robots = max(groups, key=len)
    assert robots.size >= 2
    capped = time_group(sp, robots, (V, V), (A, A), backend="toppra",
                        toppra_max_robots=robots.size - 1)
    free = time_group(sp, robots, (V, V), (A, A), backend="toppra", toppra_max_robots=None)
    ker = time_group(sp, robots, (V, V), (A, A), backend="numba")
    assert capped.solver == "numba-large" and free.solver == "toppra"
    assert capped.duration == ker.duration
    assert free.duration == pytest.approx(capped.duration, rel=1e-4)
    at_cap = time_group(sp, robots, (V, V), (A, A), backend="toppra",
                        toppra_max_robots=robots.size)
    assert at_cap.solver == "toppra"


def test_grid_is_coarse_only_on_straight_cruises():
    """Every knot is a gridpoint, curved intervals are cut at grid_steps, and the coarse
    straight intervals cost (almost) nothing against 4 steps everywhere."""
    sp, groups = real_groups()
    mrange = sp.moving_range()
    n_fine = n_coarse = 0
    for robots in groups:
        k = robots.size
        lim = (np.full(2 * k, V), np.full(2 * k, A), 1e5)
        fine = group_grid(sp, robots, 4.0, mrange)
        coarse = group_grid(sp, robots, 4.0, mrange, limits=lim)
        if fine.size < 2:
            continue
        assert np.all(np.diff(coarse) > 0) and coarse[0] == fine[0] and coarse[-1] == fine[-1]
        knots = np.unique(np.concatenate([sp.robot_knots(int(i)) for i in robots]))
        inside = knots[(knots > fine[0]) & (knots < fine[-1])]
        assert np.all(np.isin(inside, coarse))
        mid = 0.5 * (coarse[1:] + coarse[:-1])
        curved = np.any(sp.evaluate(mid, robots, 2).reshape(mid.size, -1) != 0, axis=1)
        assert np.all(np.diff(coarse)[curved] <= 4.0 + 1e-9)
        assert np.diff(coarse).max() <= 128.0 + 1e-9
        n_fine += fine.size
        n_coarse += coarse.size
        d_fine = time_group(sp, robots, (V, V), (A, A), straight_steps=4.0, moving_range=mrange)
        d_coarse = time_group(sp, robots, (V, V), (A, A), moving_range=mrange)
        assert d_fine.duration * (1 - 1e-6) <= d_coarse.duration <= d_fine.duration * 1.001
    assert n_coarse < 0.6 * n_fine


def test_static_group_and_scaling():
    still = smooth_plan(CORNER, window_steps=10)
    law = time_group(still, [0], (V, V), (A, A))
    slow = law.scaled(2.0)
    assert slow.duration == pytest.approx(2 * law.duration)
    np.testing.assert_allclose(slow.s_at(2 * np.array([0.3, 1.1])), law.s_at([0.3, 1.1]))
    s = law.s_at(np.linspace(-1, law.duration + 1, 999))
    assert np.all(np.diff(s) >= 0) and s[0] == law.s[0] and s[-1] == law.s[-1]
    static = TimeLaw.static(3.0)
    assert static.duration == 0.0 and static.s_at([0.0, 5.0]).tolist() == [3.0, 3.0]
    assert static.solver == "static" and slow.solver == law.solver == DEFAULT_BACKEND


def test_pl_kinematics_three_point_definition():
    t = np.array([0.0, 1.0, 3.0, 4.0])
    y = np.array([0.0, 2.0, 2.0, 5.0])        # slopes 2, 0, 3
    vm, am = pl_kinematics(t, y)
    assert vm == 3.0
    # a_0 = 2*2/1 = 4 (from rest); 2*(0-2)/3; 2*(3-0)/3 = 2; a_end = 2*3/1 = 6
    assert am == pytest.approx(6.0)
    assert pl_kinematics(np.array([0.0]), np.array([1.0])) == (0.0, 0.0)
    assert pl_kinematics(np.array([0.0, 0.0]), np.array([0.0, 1.0]))[0] == np.inf


def test_interaction_pairs_match_dense_sampling():
    geom = make_geom(37, 3.0)
    _, plan = plan_random(geom, 0, step_deg=0.1)
    margin = 1.5
    pairs, cl = interaction_pairs(plan, geom, margin)
    steps = np.arange(plan.n_steps + 1.0)
    ang = plan.angles_at(steps)
    spec = geom.spec
    dense = np.min([pair_distances(geom.base_xy, a, geom.pairs, spec.alpha_length_mm,
                                   spec.segment_start_mm, geom.seg_end) for a in ang],
                   axis=0) - 2 * geom.buffer_mm
    np.testing.assert_array_equal(pairs, geom.pairs)
    below = dense < margin
    assert below.any() and (~below).any()
    np.testing.assert_array_equal(cl < margin, below)
    assert np.all(cl[~below] >= dense[~below] - 1e-9)    # smallest samples: upper bounds


def test_interaction_groups_are_connected_components():
    labels = interaction_groups(6, np.array([[0, 1], [1, 2], [4, 5]]))
    assert labels[0] == labels[1] == labels[2]
    assert labels[4] == labels[5] != labels[0]
    assert len(set(labels.tolist())) == 3
