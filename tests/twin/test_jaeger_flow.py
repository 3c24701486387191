"""SDSS-V's configuration flow (twin/jaeger_flow.py): decollide, retries, production smoothing."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.errors import PlanningError
from rfp_twin.models.robot import load_spec
from rfp_twin.planners.plan import DEADLOCKED
from rfp_twin.planners.stepwise import array_max_displacement
from rfp_twin.planners.stepwise.recovery import min_clearance
from rfp_twin.twin.jaeger_flow import decollide, jaeger_flow
from rfp_twin.twin.pipeline import PlanOptions, Reconfiguration
from rfp_twin.validation.checker2d import check_trajectory
from tests.twin.cli.runner import plan_ok, run

STEP = 0.2


@pytest.fixture(scope="module")
def hex37():
    spec = load_spec("sdss-v").with_overrides(buffer_mm=3.0)
    return Reconfiguration.from_names(spec, "hex:37",
                                      options=PlanOptions(step_deg=STEP, resolve="none"))


def deadlocking_targets(rc):
    """A seed whose greedy plan (no resolution) leaves robots deadlocked."""
    for seed in range(40):
        tg = rc.random_targets(np.random.default_rng(seed))
        plan, _ = rc.plan(tg, np.random.default_rng(seed))
        if np.any(plan.status == DEADLOCKED):
            return seed, tg
    raise AssertionError("no deadlocking seed")


def test_decollide_moves_colliding_robots_only_science_last(hex37):
    geom = hex37.geom
    tg = hex37.random_targets(np.random.default_rng(1))
    a, b = (int(v) for v in geom.pairs[0])
    poses = tg.copy()
    # robot b turns until it overlaps robot a
    for cand in np.linspace(0, 360, 73):
        poses[b] = (cand, 10.0)
        if min_clearance(geom, poses) < 0.0:
            break
    assert min_clearance(geom, poses) < 0.0
    science = np.ones(geom.n_robots, bool)
    science[b] = False                       # b has no science target: it is moved first
    before = poses.copy()
    moved = decollide(geom, poses, np.ones(geom.n_robots, bool), np.random.default_rng(0),
                      order_first=~science, margin_mm=array_max_displacement(geom, STEP))
    assert moved == [int(geom.robot_ids[b])]
    assert min_clearance(geom, poses) > 0.0
    unchanged = np.ones(geom.n_robots, bool)
    unchanged[b] = False
    np.testing.assert_array_equal(poses[unchanged], before[unchanged])


def test_flow_unlocks_deadlocks_by_moving_targets_and_its_trajectory_is_checked(hex37):
    seed, tg = deadlocking_targets(hex37)
    flow = jaeger_flow(hex37.geom, tg, np.random.default_rng(seed), step_deg=STEP)
    assert flow.attempts >= 2 and flow.unlocked and flow.n_lost == len(flow.unlocked)
    assert not np.any(flow.plan.status == DEADLOCKED)
    lost = np.isin(hex37.geom.robot_ids, flow.unlocked)
    assert np.all(np.any(flow.poses[lost] != tg[lost], axis=1))
    np.testing.assert_array_equal(flow.poses[~lost], tg[~lost])
    # it unfolds from the fold to the poses planned, in production timing (12 deg/s)
    np.testing.assert_allclose(flow.trajectory.end(), flow.poses, atol=0.05)
    assert set(flow.checks) == {"twin@3", "production@3", "twin@2.92", "production@2.92"}
    again = check_trajectory(flow.trajectory, hex37.spec, hex37.layout, 3.0)
    assert again.min_clearance_mm == pytest.approx(flow.checks["twin@3"].min_clearance_mm)


def test_flow_fails_when_retries_are_exhausted(hex37):
    seed, tg = deadlocking_targets(hex37)
    with pytest.raises(PlanningError, match="still deadlocked after 0 retries"):
        jaeger_flow(hex37.geom, tg, np.random.default_rng(seed), step_deg=STEP, retries=0)


def test_plan_flow_jaeger_writes_what_production_would_send(tmp_path):
    out = tmp_path / "jf"
    r, summary = plan_ok(out, "--layout", "hex:37", "--buffer", "2.5", "--step", "0.2",
                         "--seed", "3", "--flow", "jaeger")
    assert "targets lost" in r.stdout and "production rule" in r.stdout
    assert summary["flow"] == "jaeger" and summary["production"]["smooth_points"] == 21
    assert summary["n_targets_lost"] == len(set(summary["unlocked"]) | set(summary["decollided"]))
    assert (out / "trajectories.json").is_file()
    r = run("plan", "--layout", "hex:7", "--flow", "kaiju", "--out", str(tmp_path / "x"))
    assert r.returncode == 2 and "--flow 'kaiju'; allowed: twin, jaeger" in r.stderr
