"""The post-processing pipeline (planners/postprocess/pipeline.py), checked numerically.

Every trajectory is checked on its own terms: the firmware's piecewise-linear product
(slopes, three-point accelerations), its point counts, its distance to the smooth timed
path it simplifies, its ends, and the independent 2D checker at the stated buffer.
"""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.errors import PlanningError, SpecError
from rfp_twin.models.layout import Layout
from rfp_twin.models.robot import load_spec
from rfp_twin.planners.plan import Plan
from rfp_twin.planners.postprocess import postprocess
from rfp_twin.planners.postprocess.pipeline import WIGGLE_REVERSALS
from rfp_twin.planners.postprocess.simplify import direction_reversals
from rfp_twin.planners.postprocess.timing import pl_kinematics
from rfp_twin.models.trajectory import Trajectory
from tests.planners.conftest import make_geom, plan_random
from rfp_twin.validation.checker2d import check_trajectory


def assert_firmware_ready(traj: Trajectory, rep, plan: Plan, geom: ArrayGeometry,
                          max_points: int = 1024) -> None:
    spec = geom.spec
    # limits, within 1 %, on the piecewise-linear product
    for ax in range(2):
        for i in range(traj.n_robots):
            v, a = pl_kinematics(traj.times[ax][i], traj.angles[ax][i])
            assert v <= spec.max_speed_deg_s[ax] * 1.01
            assert a <= spec.max_accel_deg_s2[ax] * 1.01
    assert max(rep.max_speed_deg_s) <= 30.0 * 1.01 and max(rep.max_accel_deg_s2) <= 45.0 * 1.01
    # firmware capacity
    counts = traj.point_counts()
    assert counts.max() <= max_points and rep.points_per_axis_max == counts.max()
    # exact ends
    np.testing.assert_array_equal(traj.start(), plan.start())
    np.testing.assert_array_equal(traj.end(), plan.end())
    # within the tolerance of the smooth timed path (plus the dense sampling error
    # a * sample_s^2 / 8 between samples)
    t = np.linspace(0.0, traj.duration, 20001)
    gap = np.abs(traj.sample(t) - rep.timed.sample(t)).max(axis=(0, 2))
    sampling = max(spec.max_accel_deg_s2) * rep.sample_s**2 / 8
    assert np.all(gap <= rep.timed.tolerance_deg + sampling + 1e-9)
    assert np.all(rep.timed.tolerance_deg <= rep.max_tolerance_used_deg + 1e-12)
    # and collision-free at the planning buffer minus the stated budget
    assert rep.verified and rep.budget_mm == 0.03
    assert rep.verify_buffer_mm == pytest.approx(geom.buffer_mm - 0.03)
    check = check_trajectory(traj, spec, geom.layout, rep.verify_buffer_mm)
    assert check.ok, check.table()
    assert check.min_clearance_mm > 0.0
    assert rep.min_clearance_mm == pytest.approx(check.min_clearance_mm, abs=0.01)
    # the post-processing's own check of the whole trajectory (its first full check with
    # each round's re-checks merged in) is what a full check of the result finds
    final = rep.final_check
    assert final.ok and final.n_robots == check.n_robots
    for ids, dist, fids, fdist in ((final.pair_ids, final.pair_min_distance_mm,
                                    check.pair_ids, check.pair_min_distance_mm),
                                   (final.fiducial_pair_ids, final.fiducial_min_distance_mm,
                                    check.fiducial_pair_ids, check.fiducial_min_distance_mm)):
        mine = dict(zip(map(tuple, np.sort(ids, axis=1).tolist()), dist.tolist()))
        full = dict(zip(map(tuple, np.sort(fids, axis=1).tolist()), fdist.tolist()))
        assert mine.keys() == full.keys()
        for key, d in full.items():
            assert mine[key] == pytest.approx(d, abs=0.01 + 0.02 * d)


@pytest.mark.parametrize("n_positions,buffer_mm,seed", [
    (37, 1.5, 0),
    (91, 2.0, 1),
    (127, 2.5, 2),
    (169, 2.0, 3),
    (169, 3.0, 4),
])
def test_firmware_ready_and_collision_free(n_positions, buffer_mm, seed):
    geom = make_geom(n_positions, buffer_mm)
    _, plan = plan_random(geom, seed, step_deg=0.1)
    traj, rep = postprocess(plan, geom, verifier=check_trajectory)
    assert_firmware_ready(traj, rep, plan, geom)
    assert rep.check_rounds == rep.retries + 1
    assert rep.duration_s >= plan.n_steps * plan.step_s * 0.9
    assert rep.points_per_axis_median < 40
    assert set(rep.stage_seconds) == {"smooth", "group", "time", "simplify", "verify", "total"}


@pytest.mark.parametrize("n_positions,buffer_mm,seed", [(37, 1.5, 0), (91, 2.0, 1)])
def test_toppra_backend_times_every_group_and_passes_the_checker(n_positions, buffer_mm, seed):
    """The toppra library as the timing backend of the whole pipeline: no group left to
    the numba kernel, the same fold as the kernel's, firmware-ready and collision-free."""
    geom = make_geom(n_positions, buffer_mm)
    _, plan = plan_random(geom, seed, step_deg=0.1)
    traj, rep = postprocess(plan, geom, backend="toppra", verifier=check_trajectory)
    assert rep.backend == "toppra"
    assert rep.timing_fallbacks == 0 and "numba" not in rep.timing_solvers
    assert rep.timing_solvers["toppra"] == rep.n_groups - rep.timing_solvers.get("static", 0) > 0
    assert_firmware_ready(traj, rep, plan, geom)
    _, ker = postprocess(plan, geom, backend="numba", verifier=check_trajectory)
    assert ker.timing_solvers.get("numba") == rep.timing_solvers["toppra"]
    assert rep.duration_s == pytest.approx(ker.duration_s, rel=1e-4)
    assert rep.to_dict()["timing_fallbacks"] == 0


def test_markov_plan_is_pre_simplified_and_stays_collision_free():
    geom = make_geom(91, 2.0)
    _, plan = plan_random(geom, 3, step_deg=0.1, algorithm="markov")
    traj, rep = postprocess(plan, geom, verifier=check_trajectory)
    assert rep.presimplify_deg == 0.2 and rep.plan_breakpoints == plan.path_step.size
    assert rep.smoothed_breakpoints < 0.5 * rep.plan_breakpoints
    assert_firmware_ready(traj, rep, plan, geom)
    _, raw = postprocess(plan, geom, presimplify_deg=0.0, wiggle_presimplify_deg=0.0,
                         verifier=check_trajectory)
    assert raw.smoothed_breakpoints == raw.plan_breakpoints and raw.verified
    with pytest.raises(SpecError, match="presimplify_deg"):
        postprocess(plan, geom, presimplify_deg=-0.1, verifier=check_trajectory)
    with pytest.raises(SpecError, match="wiggle_presimplify_deg"):
        postprocess(plan, geom, wiggle_presimplify_deg=11.0, verifier=check_trajectory)


def test_wiggly_robots_get_the_wiggle_tolerance_and_stay_collision_free():
    """A Markov random walk turns back hundreds of times: its robots are cut within the
    wiggle tolerance (fewer breakpoints, a shorter timed fold), and the independent 2D
    checker still passes the result."""
    geom = make_geom(91, 2.0)
    _, plan = plan_random(geom, 3, step_deg=0.1, algorithm="markov")
    wiggly = direction_reversals(plan.path_ptr, plan.path_angles) > WIGGLE_REVERSALS
    assert wiggly.sum() > plan.n_robots // 2
    _, plain = postprocess(plan, geom, wiggle_presimplify_deg=0.0, verifier=check_trajectory)
    traj, rep = postprocess(plan, geom, verifier=check_trajectory)
    assert plain.n_wiggly_robots == rep.n_wiggly_robots == int(wiggly.sum())
    assert rep.smoothed_breakpoints < plain.smoothed_breakpoints
    assert rep.duration_s < plain.duration_s
    assert_firmware_ready(traj, rep, plan, geom)
    assert rep.to_dict()["n_wiggly_robots"] == rep.n_wiggly_robots


def test_production_layout_with_fiducials_and_a_small_point_budget():
    spec = load_spec("sdss-v-production")
    lay = Layout.sdss_v_grid(fiducial_ids=(0, 3, 10, 20, 33, 48))
    geom = ArrayGeometry(spec, lay, 2.0)
    _, plan = plan_random(geom, 5, step_deg=0.2)
    # 16 points per axis: 12 needed all 8 verification rounds already with the old grid
    # (any change of the time law tipped it over); 16 needs 4
    traj, rep = postprocess(plan, (spec, lay), 2.0, max_points=16, verifier=check_trajectory)
    assert_firmware_ready(traj, rep, plan, geom, max_points=16)
    assert rep.max_tolerance_used_deg > rep.tolerance_deg       # the budget forced it


# -- grouping ---------------------------------------------------------------------------
def chase_plan() -> tuple[Plan, ArrayGeometry]:
    """Two robots 22.4 mm apart. B (right) swings its arm from pointing at A (alpha 180)
    up and away (alpha 60) over 1200 steps; A swings from pointing away (alpha 180) over
    the top towards B (alpha 0) over 1800 steps, chasing B's arm at the same rate.
    Clear throughout the plan (0.47 mm at the closest), but only because B keeps ahead."""
    spec = load_spec("sdss-v")
    lay = Layout(ids=[1, 2], xy=[[0.0, 0.0], [22.4, 0.0]], kinds=["robot", "robot"], name="pair")
    geom = ArrayGeometry(spec, lay, 2.0)
    steps = np.array([0.0, 1800.0, 0.0, 1200.0, 1800.0])
    angles = np.array([[180.0, 0.0], [0.0, 0.0], [180.0, 0.0], [60.0, 0.0], [60.0, 0.0]])
    plan = Plan(np.array([1, 2]), 0.1, spec.step_seconds(0.1), 1800, np.array([0, 2, 5]),
                steps, angles, np.array(["reached"] * 2, dtype=object),
                np.array([[0.0, 0.0], [60.0, 0.0]]), np.array([[0.0, 0.0], [60.0, 0.0]]))
    return plan, geom


def test_chasing_robots_collide_when_timed_apart_and_not_when_grouped():
    plan, geom = chase_plan()
    raw = check_trajectory(Trajectory.from_plan(plan), geom.spec, geom.layout, 2.0)
    assert raw.ok and 0.3 < raw.min_clearance_mm < 1.0
    # timed apart (no interaction edges): A's faster, shorter-to-finish motion runs into B
    apart, rep_apart = postprocess(plan, geom, interaction_mm=0.0, verifier=None)
    assert rep_apart.n_groups == 2
    hit = check_trajectory(apart, geom.spec, geom.layout, 1.97)
    assert not hit.ok and hit.min_clearance_mm < -1.0
    with pytest.raises(PlanningError, match="collision"):
        postprocess(plan, geom, interaction_mm=0.0, max_retries=0, verifier=check_trajectory)
    # grouped (interaction distance 1 mm > their closest 0.3-1 mm): one path parameter,
    # clear at once
    traj, rep = postprocess(plan, geom, interaction_mm=1.0, verifier=check_trajectory)
    assert rep.n_groups == 1 and rep.largest_group == 2
    assert rep.merges == 0 and rep.retries == 0
    assert_firmware_ready(traj, rep, plan, geom)
    # and the repair loop reaches the same grouping from the split one (as with the
    # default 0.3 mm, below their closest approach)
    for mm in (0.0, None):
        kw = {} if mm is None else {"interaction_mm": mm}
        _, rep_fix = postprocess(plan, geom, verifier=check_trajectory, **kw)
        assert rep_fix.merges == 1 and rep_fix.largest_group == 2 and rep_fix.verified


# -- arguments ----------------------------------------------------------------------------
@pytest.mark.parametrize("kwargs,field", [
    ({"budget_mm": 2.5}, "budget_mm"),
    ({"max_points": 1}, "max_points"),
    ({"tolerance_deg": 0.0}, "tolerance_deg"),
    ({"smoothing": "savgol"}, "smoothing"),
    ({"align": "middle"}, "align"),
    ({"backend": "ruckig"}, "backend"),
    ({"sample_s": 0.0}, "sample_s"),
])
def test_bad_arguments_name_the_field(kwargs, field):
    plan, geom = chase_plan()
    with pytest.raises(SpecError, match=field):
        postprocess(plan, geom, **kwargs, verifier=check_trajectory)


def test_plan_must_match_the_layout():
    plan, _ = chase_plan()
    with pytest.raises(SpecError, match="robot_ids"):
        postprocess(plan, make_geom(37, 2.0), verifier=check_trajectory)


def test_a_plan_outside_the_joint_limits_is_refused_naming_the_robot():
    plan, geom = chase_plan()
    plan.path_angles[1, 0] = -30.0          # robot 1 swings through its alpha stop
    with pytest.raises(SpecError, match=r"robot 1: field 'plan alpha' = '-30.0000 deg'; "
                                        r"allowed: \[0, 360\] deg"):
        postprocess(plan, geom, verifier=check_trajectory)
    plan.path_angles[1, 0] = -1e-12         # rounding is not an excursion
    traj, _ = postprocess(plan, geom, verifier=check_trajectory)
    assert min(a.min() for a in traj.angles[0]) >= 0.0      # samples clipped to the stop
