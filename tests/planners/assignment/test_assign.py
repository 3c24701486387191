"""The collision-aware fiber assigner: feasibility (independent 2D check), optimality
(two exact solvers agree, the heuristic never beats them), quotas, fibers, arms, parking."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.catalogue import (APOGEE, BOSS, KINDS, TELESCOPES, Catalogue, Disc,
                                       density_per_mm2, mock_catalogue)
from rfp_twin.models.errors import AssignmentError
from rfp_twin.models.kinematics import forward_fiber
from rfp_twin.models.layout import Layout, layout_by_name
from rfp_twin.models.layout.columns import robot_fibers
from rfp_twin.models.robot import load_spec
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.planners.assignment import (LEFT, PARKED, RIGHT, AssignSettings, Quotas, assign,
                                          build_candidates, parking_angles)
from rfp_twin.planners.stepwise import array_max_displacement
from rfp_twin.validation.checker2d import check_trajectory


def hex_geom(n=37, buffer_mm=2.0):
    spec = load_spec("sdss-v")
    return ArrayGeometry(spec, Layout.hex_grid_positions(n, spec.pitch_mm), buffer_mm)


@pytest.fixture(scope="module")
def apo():
    spec = load_spec("sdss-v-production")
    return ArrayGeometry(spec, layout_by_name("sdss-v-apo", spec.pitch_mm, ()), 2.0)


def covering_catalogue(geom, per_patrol, seed, levels=1, fiber="any"):
    spec = geom.spec
    lo, hi = spec.patrol_annulus_mm
    c = geom.base_xy.mean(axis=0)
    r = float(np.hypot(*(geom.base_xy - c).T).max()) + spec.reach_mm
    return mock_catalogue(np.random.default_rng(seed), Disc((c[0], c[1]), r),
                          density_per_mm2(per_patrol, "patrol",
                                          patrol_area_mm2=np.pi * (hi * hi - lo * lo)),
                          priority_levels=levels, fiber=fiber)


def static_check(geom, angles, buffer_mm):
    """The independent 2D checker on a trajectory that holds ``angles`` for one second."""
    n = geom.n_robots
    t = [np.array([0.0, 1.0])] * n
    traj = Trajectory.from_breakpoints(geom.robot_ids, t, [np.repeat(a, 2) for a in angles[:, 0]],
                                       t, [np.repeat(b, 2) for b in angles[:, 1]])
    return check_trajectory(traj, geom.spec, geom.layout, buffer_mm)


def assert_valid(geom, cat, a):
    """Each target once, each pose's fiber on its target, and the final poses clear."""
    taken = a.target[a.target >= 0]
    assert taken.size == np.unique(taken).size
    assert static_check(geom, a.angles, float(geom.buffer_mm)).ok
    assert np.all(a.arm[a.target < 0] == PARKED)
    # parked: the fold, or (clear parking) the fold turned in alpha by k x 60 deg
    park = a.target < 0
    fold = parking_angles(geom)[park]
    assert np.allclose(a.angles[park, 1], fold[:, 1])
    turn = (a.angles[park, 0] - fold[:, 0]) / 60.0
    assert np.allclose(turn, np.round(turn))


@pytest.mark.parametrize("per_patrol,levels", [(0.6, 1), (1.5, 3), (6.0, 2)])
def test_exact_solvers_agree_and_the_poses_pass_the_2d_check(per_patrol, levels):
    geom = hex_geom()
    cat = covering_catalogue(geom, per_patrol, seed=4, levels=levels)
    margin = array_max_displacement(geom, 0.1)
    res = {}
    for solver in ("highs", "cpsat", "greedy"):
        a = assign(geom, cat, AssignSettings(solver=solver, margin_mm=margin, arms=("right", "left")))
        assert_valid(geom, cat, a)
        assert a.objective == pytest.approx(float(cat.priority[a.target[a.target >= 0]].sum()))
        res[solver] = a
    assert res["highs"].status == res["cpsat"].status == "optimal"
    assert res["highs"].objective == pytest.approx(res["cpsat"].objective)
    assert res["greedy"].objective <= res["highs"].objective + 1e-9
    assert res["greedy"].bound >= res["highs"].objective - 1e-9


def test_fibers_land_on_their_targets_with_each_robots_own_geometry(apo):
    """Calibrated APO: BOSS targets on BOSS fibers, APOGEE targets only on robots that carry
    one, each robot's own alpha arm and fiber; the poses clear of fiducials and cameras."""
    tel = TELESCOPES["apo"]
    rng = np.random.default_rng(2)
    disc = Disc((0.0, 0.0), tel.field_radius_mm)
    d = density_per_mm2(150, "deg2", plate_scale_mm_per_deg=tel.plate_scale_mm_per_deg)
    cat = Catalogue.concat([mock_catalogue(rng, disc, d, fiber="boss"),
                            mock_catalogue(rng, disc, d, fiber="apogee", first_id=10_000)])
    margin = array_max_displacement(apo, 0.1)
    a = assign(apo, cat, AssignSettings(margin_mm=margin))
    assert a.status == "optimal" and a.n_assigned > 400
    assert_valid(apo, cat, a)
    assert np.all(apo.fiducial_clearance(a.angles) > margin)
    fibers = robot_fibers(apo.layout, {})
    on = np.flatnonzero(a.target >= 0)
    slot = a.slot[on].astype(int) + 1                  # robot_fibers: 0 met, 1 boss, 2 apogee
    tip = forward_fiber(apo.base_xy[on], a.angles[on], apo.alpha_len[on],
                        fibers[on, slot])
    assert np.allclose(tip, cat.xy[a.target[on]], atol=1e-6)
    need = cat.fiber[a.target[on]]
    assert np.all(slot[need == BOSS] == 1) and np.all(slot[need == APOGEE] == 2)
    assert np.all(np.isfinite(fibers[on[need == APOGEE], 2, 0]))
    assert np.all(a.arm[on] == RIGHT)


def test_left_arms_are_candidates_only_when_asked():
    geom = hex_geom(7)
    cat = covering_catalogue(geom, 2.0, seed=1)
    right = build_candidates(geom, cat, arms=("right",))
    both = build_candidates(geom, cat, arms=("right", "left"))
    assert set(right.arm.tolist()) == {RIGHT, PARKED}
    assert set(both.arm.tolist()) == {RIGHT, LEFT, PARKED}
    real = right.target >= 0
    assert np.all(right.angles[real, 1] <= 180.0)
    left = both.arm == LEFT
    assert np.all(both.angles[left, 1] > 180.0)
    assert np.count_nonzero(left) == np.count_nonzero(real)     # every target inside the rim


def test_forbidden_pairs_are_never_assigned():
    geom = hex_geom(19)
    cat = covering_catalogue(geom, 1.0, seed=3)
    first = assign(geom, cat, AssignSettings(solver="highs"))
    on = np.flatnonzero(first.target >= 0)[:5]
    forbidden = frozenset((int(geom.robot_ids[i]), int(first.target_ids[i])) for i in on)
    again = assign(geom, cat, AssignSettings(solver="highs", forbidden=forbidden))
    pairs = set(zip(geom.robot_ids.tolist(), again.target_ids.tolist()))
    assert not pairs & forbidden
    assert again.objective <= first.objective


def test_a_quota_that_conflicts_cannot_be_met_names_region_and_best_count():
    """Two sky targets 0.1 mm apart: both reachable, never both taken (the fibers collide)."""
    geom = hex_geom(7)
    x, y = geom.base_xy[0] + [10.0, 0.0]
    cat = Catalogue([1, 2, 3], [[x, y], [x + 0.1, y], [x - 20, y - 5]], [1, 1, 1],
                    [KINDS.index("sky")] * 2 + [0], [2, 2, 2])
    ok = assign(geom, cat, AssignSettings(solver="highs", quotas=Quotas(sky=1)))
    assert ok.counts()["sky"] == 1
    with pytest.raises(AssignmentError, match=r"sky quota in the whole plane: needs 2; the best "
                                              r"count reachable is 1"):
        assign(geom, cat, AssignSettings(solver="highs", quotas=Quotas(sky=2)))
    with pytest.raises(AssignmentError, match=r"region [01] of 2 \(sector [0-9]+-[0-9]+ deg\): needs 1; at most 0 reachable"):
        assign(geom, cat, AssignSettings(solver="highs", quotas=Quotas(sky=1, sectors=2)))


@pytest.mark.parametrize("solver,sky_density", [("auto", 10), ("greedy", 30)])
def test_quotas_are_met_per_region(apo, solver, sky_density):
    """The exact solver meets 3 sky fibers per quarter from 10 sky targets/deg^2; the
    heuristic's quota fill (greedy, fewest excluded poses first) from 30."""
    tel = TELESCOPES["apo"]
    rng = np.random.default_rng(7)
    disc = Disc((0.0, 0.0), tel.field_radius_mm)
    per = (lambda d: density_per_mm2(d, "deg2", plate_scale_mm_per_deg=tel.plate_scale_mm_per_deg))
    cat = Catalogue.concat([mock_catalogue(rng, disc, per(300)),
                            mock_catalogue(rng, disc, per(sky_density), kind="sky",
                                           first_id=10**6)])
    q = Quotas(sky=3, sectors=4)
    a = assign(apo, cat, AssignSettings(solver=solver, quotas=q, margin_mm=0.1))
    assert_valid(apo, cat, a)
    on = a.target >= 0
    sky = np.flatnonzero(on)[cat.kind[a.target[on]] == KINDS.index("sky")]
    c = apo.base_xy.mean(axis=0)
    xy = cat.xy[a.target[sky]]
    sector = (np.arctan2(xy[:, 1] - c[1], xy[:, 0] - c[0]) % (2 * np.pi)) // (np.pi / 2)
    assert np.bincount(sector.astype(int), minlength=4).min() >= 3


def test_no_target_in_reach_and_bad_settings():
    geom = hex_geom(7)
    far = Catalogue([1], [[1000.0, 0.0]], [1], [0], [0], source="far.csv")
    with pytest.raises(AssignmentError, match="far.csv: none of its 1 targets is within reach"):
        assign(geom, far)
    with pytest.raises(AssignmentError, match="--solver 'gurobi'"):
        AssignSettings(solver="gurobi")
    with pytest.raises(AssignmentError, match="quota field 'sky' = -1"):
        Quotas(sky=-1)
    empty = assign(geom, Catalogue([], np.zeros((0, 2)), [], [], []))
    assert empty.n_assigned == 0 and empty.status == "optimal"


def test_the_heuristic_is_feasible_and_near_its_bound_on_a_dense_field():
    geom = hex_geom(91)
    cat = covering_catalogue(geom, 20.0, seed=5, levels=1)
    a = assign(geom, cat, AssignSettings(solver="greedy", margin_mm=0.07))
    assert_valid(geom, cat, a)
    assert a.gap <= 0.01 and a.bound >= a.objective


def test_large_components_are_improved_window_by_window(monkeypatch):
    """A component above the exact solver's size: the greedy poses improved by windows
    solved exactly; feasible, never worse than greedy, never better than the optimum."""
    import importlib

    assign_module = importlib.import_module("rfp_twin.planners.assignment.assign")

    geom = hex_geom(127)
    cat = covering_catalogue(geom, 2.0, seed=11, levels=2)
    margin = array_max_displacement(geom, 0.1)
    exact = assign(geom, cat, AssignSettings(solver="highs", margin_mm=margin))
    monkeypatch.setattr(assign_module, "MAX_EXACT_ROBOTS", 20)
    win = assign(geom, cat, AssignSettings(solver="highs", margin_mm=margin))
    assert win.stats["windows_solved"] > 0 and win.status == "feasible"
    assert_valid(geom, cat, win)
    assert win.stats["greedy_objective"] <= win.objective <= exact.objective + 1e-9
    assert win.bound >= exact.objective - 1e-9


def test_dominated_poses_are_dropped_without_losing_the_optimum():
    """Presolve by dominance: the same optimum as the full program (CP-SAT on every pose,
    HiGHS after the presolve), and a pose is only dropped for a pose of its own robot."""
    import importlib

    from rfp_twin.planners.assignment.conflicts import conflict_pairs, neighbour_pairs
    from rfp_twin.planners.assignment.dominance import exclusion_csr, undominated

    assign_module = importlib.import_module("rfp_twin.planners.assignment.assign")
    geom = hex_geom(37)
    cat = covering_catalogue(geom, 3.0, seed=8, levels=3)
    margin = array_max_displacement(geom, 0.1)
    cands = build_candidates(geom, cat, margin_mm=margin)
    pairs = neighbour_pairs(geom, margin)
    a, b = conflict_pairs(cands, pairs, geom.buffer, margin)
    keep = undominated(cands, a, b)
    assert 0 < np.count_nonzero(~keep) < cands.n
    ptr, idx = exclusion_csr(cands, a, b)
    for c in np.flatnonzero(~keep)[:50]:
        r = cands.robot[c]
        mates = [d for d in range(cands.ptr[r], cands.ptr[r + 1]) if d != c
                 and cands.weight[d] >= cands.weight[c]
                 and set(idx[ptr[d]:ptr[d + 1]]) <= set(idx[ptr[c]:ptr[c + 1]])]
        assert mates
    with_presolve = assign(geom, cat, AssignSettings(solver="highs", margin_mm=margin))
    original = assign_module.undominated
    try:
        assign_module.undominated = lambda cands, a, b, group=None: np.ones(cands.n, dtype=bool)
        without = assign(geom, cat, AssignSettings(solver="highs", margin_mm=margin))
    finally:
        assign_module.undominated = original
    assert with_presolve.status == without.status == "optimal"
    assert with_presolve.objective == pytest.approx(without.objective)
    assert_valid(geom, cat, with_presolve)


def test_offline_robots_keep_their_pose_and_the_others_clear_it():
    geom = hex_geom(19)
    cat = covering_catalogue(geom, 3.0, seed=6)
    free = assign(geom, cat, AssignSettings(solver="highs"))
    busy = [int(geom.robot_ids[k]) for k in np.flatnonzero(free.target >= 0)[:2]]
    fixed = ((busy[0], 200.0, 30.0), (busy[1], 10.0, 170.0))
    a = assign(geom, cat, AssignSettings(solver="highs", fixed=fixed))
    rows = [geom.layout.robot_index(r) for r in busy]
    assert np.all(a.target[rows] == -1)
    assert np.allclose(a.angles[rows], [[200.0, 30.0], [10.0, 170.0]])
    assert_valid_except_parking(geom, a)


def assert_valid_except_parking(geom, a):
    taken = a.target[a.target >= 0]
    assert taken.size == np.unique(taken).size
    assert static_check(geom, a.angles, float(geom.buffer_mm)).ok
