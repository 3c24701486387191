"""Each robot's travel range in model angles: the spec's (the firmware's, in encoder
angles) shifted by the robot's encoder offsets (``alpha_offset_deg``, ``beta_offset_deg``).
Every consumer uses the robot's own range: the layout reader, target checks and random
targets, the stepwise kernel, the deadlock search's roadmap bounds, post-processing, the
run loader and the MuJoCo joints."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.errors import SpecError, TargetError
from rfp_twin.models.layout import Layout
from rfp_twin.models.layout.columns import fit_to_limits, robot_joint_limits
from rfp_twin.models.robot import load_spec
from rfp_twin.planners.stepwise import array_max_displacement, run_array
from rfp_twin.planners.plan.targets import check_angles, random_targets

SPEC = load_spec("sdss-v")            # alpha [0, 360], beta [0, 360]
STEP = 0.5


def hex7(alpha_off=None, beta_off=None, **extra) -> ArrayGeometry:
    g = Layout.hex_grid(1, SPEC.pitch_mm)
    cols = dict(extra)
    if alpha_off is not None:
        cols["alpha_offset_deg"] = [str(v) for v in alpha_off]
    if beta_off is not None:
        cols["beta_offset_deg"] = [str(v) for v in beta_off]
    return ArrayGeometry(SPEC, Layout(g.ids, g.xy, g.kinds, name="t", extra=cols), 2.0)


def test_limits_are_the_spec_shifted_by_each_robots_offsets():
    geom = hex7([-30.0, "", 4.0, "", "", "", ""], [10.0, "", -1.5, "", "", "", ""])
    lim = geom.limits
    assert lim[0].tolist() == [-30.0, 330.0, 10.0, 370.0]
    assert lim[2].tolist() == [4.0, 364.0, -1.5, 358.5]
    assert np.all(lim[[1, 3, 4, 5, 6]] == [0.0, 360.0, 0.0, 360.0])
    assert np.array_equal(robot_joint_limits(SPEC, Layout.hex_grid(1, SPEC.pitch_mm)),
                          np.tile([0.0, 360.0, 0.0, 360.0], (7, 1)))


def test_fit_turns_alpha_into_the_range_and_flags_beta_outside():
    lim = np.array([[-30.0, 330.0, 10.0, 190.0]] * 4)
    got, inside = fit_to_limits(np.array([[340.0, 100.0], [-25.0, 185.0], [700.0, 50.0],
                                          [10.0, 5.0]]), lim)
    assert got[:, 0].tolist() == pytest.approx([-20.0, -25.0, -20.0, 10.0])
    assert inside.tolist() == [True, True, True, False]      # beta 5 < 10: out of reach
    same, ok = fit_to_limits(np.array([[0.0, 0.0], [359.9, 180.0]]),
                             np.tile([0.0, 360.0, 0.0, 180.0], (2, 1)))
    assert same.tolist() == [[0.0, 0.0], [359.9, 180.0]] and ok.all()   # nominal: unchanged


def test_checks_accept_the_robots_own_range_only():
    geom = hex7([-30.0] + [""] * 6, [10.0] + [""] * 6)
    ok = np.tile([10.0, 170.0], (7, 1))
    ok[0] = [-20.0, 365.0]                        # legal for robot 0 only
    check_angles(geom, ok)
    with pytest.raises(TargetError, match=r"robot 0: field 'beta' = 5.0; allowed: \[10.0, 370.0\]"):
        check_angles(geom, np.vstack([[[-20.0, 5.0]], ok[1:]]))
    with pytest.raises(TargetError, match=r"robot 0: field 'alpha' = -20.0; allowed: \[0.0, 360.0\]"):
        check_angles(hex7(), ok)


def test_random_targets_stay_in_each_robots_range_and_use_all_of_it():
    geom = hex7([-30.0] * 7, [10.0] * 7)
    rng = np.random.default_rng(4)
    draws = np.vstack([random_targets(geom, rng) for _ in range(40)])
    lim = geom.limits[0]
    assert draws[:, 0].min() >= lim[0] and draws[:, 0].max() <= lim[1]
    assert draws[:, 1].min() >= lim[2] and draws[:, 1].max() <= lim[3]
    assert (draws[:, 0] < 0.0).any()         # alpha below the spec's 0: the shifted range


@pytest.mark.parametrize("greed, phobia", [(1.0, 0.0), (0.9, 0.3)], ids=["greedy", "markov"])
def test_the_stepwise_kernel_moves_within_the_robots_own_range(greed, phobia):
    """Robot 0 (range alpha [-30, 330], beta [10, 370]) goes from (-5, 170) down to
    (-20, 170), legal for it alone; nobody else moves. Its plan stays in its range and
    steps at most STEP per axis; with the spec's range the kernel's alpha stop is 0."""
    start = np.tile([10.0, 170.0], (7, 1))
    dest = start.copy()
    start[0], dest[0] = [-5.0, 170.0], [-20.0, 170.0]
    movable = np.zeros(7, bool)
    movable[0] = True
    runs = {}
    for name, geom in (("own", hex7([-30.0] + [""] * 6, [10.0] + [""] * 6)), ("spec", hex7())):
        runs[name] = run_array(geom, start, dest, movable, step_deg=STEP, max_steps=500,
                               md=array_max_displacement(geom, STEP), greed=greed,
                               phobia=phobia, seed=2)
    own = runs["own"]
    assert np.allclose(own.final[0], dest[0], atol=1e-9)
    mine = own.ev_angles[own.ev_robot == 0]
    assert mine[:, 0].min() >= -30.0 and mine[:, 0].max() <= 330.0 and mine[:, 1].min() >= 10.0
    mine = np.vstack([mine, own.final[0]])
    steps = np.append(own.ev_step[own.ev_robot == 0], own.n_steps)
    rate = np.abs(np.diff(mine, axis=0)) / np.maximum(np.diff(steps), 1)[:, None]
    assert rate.max() <= STEP + 1e-9              # no jump: at most a step per step
    spec_run = runs["spec"].ev_angles[runs["spec"].ev_robot == 0]
    assert spec_run[0, 0] == -5.0 and runs["spec"].final[0, 0] >= 0.0   # held at its stop
    assert not np.allclose(runs["spec"].final[0], dest[0])


def test_the_search_roadmap_uses_the_robots_own_range():
    from rfp_twin.planners.roadmap.alpha_beta.paths import PathSet
    from rfp_twin.planners.roadmap.alpha_beta.world import AlphaBetaWorld

    fold = np.tile([10.0, 170.0], (7, 1))
    q = np.array([[-20.0, 365.0], [345.0, 100.0], [10.0, 5.0]])
    got = {}
    for name, geom in (("own", hex7([-30.0] + [""] * 6, [10.0] + [""] * 6)), ("spec", hex7())):
        paths = PathSet([np.zeros(1)] * 7, [fold[i][None, :].copy() for i in range(7)])
        world = AlphaBetaWorld(geom, paths, np.ones(7, bool), 1.0, STEP)
        arm = world.arm(0, fold[0], fold[0])
        got[name] = (arm.forbidden(q).tolist(), arm.lower.tolist(), arm.upper.tolist(),
                     world.via(fold[0], fold[0], robot=0)[0][0, 1])
    assert got["own"] == ([False, True, True], [-30.0, 10.0], [330.0, 370.0], 180.0)
    assert got["spec"] == ([True, False, False], [0.0, 0.0], [360.0, 360.0], 180.0)


def test_postprocess_refuses_a_plan_outside_the_robots_range():
    from rfp_twin.planners.postprocess import postprocess
    from rfp_twin.validation.checker2d import check_trajectory
    from tests.planners.postprocess.test_pipeline import chase_plan

    plan, nominal = chase_plan()                   # both robots at beta 0 throughout
    lay = nominal.layout
    shifted = ArrayGeometry(SPEC, Layout(lay.ids, lay.xy, lay.kinds, name="pair",
                                         extra={"beta_offset_deg": ["", "10"]}), 2.0)
    with pytest.raises(SpecError, match=r"robot 2: field 'plan beta' = '0.0000 deg'; "
                                        r"allowed: \[10, 370\] deg"):
        postprocess(plan, shifted, verifier=check_trajectory)
    traj, _ = postprocess(plan, nominal, verifier=check_trajectory)     # legal for the spec
    assert traj.n_robots == 2


def test_fit_to_limits_broadcasts_one_robots_limits_over_its_draws():
    """(r, k, 2) draws with (r, 1, 4) limits fit exactly as the rows repeated k times."""
    rng = np.random.default_rng(0)
    lim = np.column_stack([rng.uniform(-30, 10, 5), rng.uniform(340, 380, 5),
                           rng.uniform(0, 20, 5), rng.uniform(150, 200, 5)])
    draws = np.column_stack([rng.uniform(-400, 800, 5 * 7), rng.uniform(-10, 210, 5 * 7)])
    flat, ok_flat = fit_to_limits(draws, np.repeat(lim, 7, axis=0))
    blk, ok_blk = fit_to_limits(draws.reshape(5, 7, 2), lim[:, None, :])
    assert np.array_equal(flat, blk.reshape(-1, 2)) and np.array_equal(ok_flat, ok_blk.ravel())
    assert 0 < ok_flat.sum() < ok_flat.size
