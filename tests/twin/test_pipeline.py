"""The one pipeline (twin/pipeline.py, twin/outcome.py): targets -> plan -> deliver -> check."""
from __future__ import annotations

import json

import numpy as np
import pytest

from rfp_twin.models.errors import RfpError
from rfp_twin.models.layout import Layout
from rfp_twin.models.robot import load_spec
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.planners.postprocess.timing import pl_kinematics
from rfp_twin.twin.pipeline import PlanOptions, Reconfiguration, folded_clearance_error, plan_random
from rfp_twin.validation.checker2d import check_trajectory


def small(options: PlanOptions | None = None, n: int = 19, buffer_mm: float = 2.0, **kw):
    return Reconfiguration.from_names("sdss-v", f"hex:{n}", buffer_mm=buffer_mm,
                                      options=options, **kw)


def test_run_delivers_a_checked_firmware_ready_trajectory():
    rc = small()
    out = rc.run(seed=3)
    assert out.ok and out.post is not None and out.n_deadlocked == 0
    # the check handed back is the independent checker's, on the delivered trajectory
    again = check_trajectory(out.trajectory, rc.spec, rc.layout, out.post.verify_buffer_mm)
    assert again.ok and out.check.buffer_mm == pytest.approx(rc.spec.buffer_mm - 0.03)
    assert out.check.min_clearance_mm == pytest.approx(again.min_clearance_mm)
    # limits of the spec (1 %), fold -> targets exactly
    for ax in range(2):
        for t, a in zip(out.trajectory.times[ax], out.trajectory.angles[ax]):
            v, acc = pl_kinematics(t, a)
            assert np.all(np.abs(v) <= rc.spec.max_speed_deg_s[ax] * 1.01)
    np.testing.assert_allclose(out.trajectory.end(), out.plan.end())
    assert set(out.seconds) == {"targets", "plan", "deliver", "total"}


def test_same_seed_same_plan_and_targets_differ_by_seed():
    a, b, c = small().run(seed=5), small().run(seed=5), small().run(seed=6)
    np.testing.assert_array_equal(a.targets, b.targets)
    np.testing.assert_array_equal(a.plan.path_step, b.plan.path_step)
    assert not np.array_equal(a.targets, c.targets)


def test_raw_delivery_is_the_stepwise_plan_checked_at_the_planning_buffer():
    out = small(PlanOptions(raw=True)).run(seed=2)
    assert out.post is None and out.check.buffer_mm == pytest.approx(2.0)
    ref = Trajectory.from_plan(out.plan)
    assert out.trajectory.duration == pytest.approx(ref.duration)


def test_plan_random_is_the_run_sequence():
    rc = small(PlanOptions(raw=True))
    targets, plan, field = plan_random(rc.geom, 4, rc.options)
    out = rc.run(seed=4)
    assert field is None
    np.testing.assert_array_equal(targets, out.targets)
    np.testing.assert_array_equal(plan.path_step, out.plan.path_step)


def test_field_planner_runs_through_the_same_pipeline():
    rc = small(PlanOptions(algorithm="apf"), n=7)
    out = rc.run(seed=1)
    assert out.field is not None and out.ok
    # the firmware robots have alpha stops: the field planner is held within them
    for ax, (lo, hi) in enumerate((rc.spec.alpha_limits_deg, rc.spec.beta_limits_deg)):
        for a in out.trajectory.angles[ax]:
            assert lo <= a.min() and a.max() <= hi
    assert out.summary()["direction"] == "direct (fold -> targets)"


def test_offline_robots_keep_their_angles():
    rc = small(offline={5: (30.0, 160.0)})
    out = rc.run(seed=1)
    k = rc.layout.robot_index(5)
    np.testing.assert_allclose(out.targets[k], (30.0, 160.0))
    for ax, ang in enumerate((30.0, 160.0)):
        assert np.all(out.trajectory.angles[ax][k] == ang)


def test_outcome_writes_a_run_folder_with_its_summary(tmp_path):
    out = small(n=7).run(seed=2)
    folder = out.write(tmp_path / "run", summary=out.summary(layout="hex:7", command="test"))
    summary = json.loads((folder / "summary.json").read_text())
    assert summary["command"] == "test" and summary["layout"] == "hex:7"
    assert summary["check2d"]["ok"] and summary["postprocess"]["verified"]
    with pytest.raises(RfpError, match="exists"):
        out.write(folder)


@pytest.mark.parametrize("field, value", [("algorithm", "astar"), ("resolve", "maybe"),
                                          ("direction", "sideways"), ("timing_backend", "cvx")])
def test_options_name_the_bad_field(field, value):
    with pytest.raises(RfpError, match=f"{value!r}; allowed: "):
        PlanOptions(**{field: value})


def test_options_check_ranges_before_anything_runs():
    with pytest.raises(RfpError, match="greed"):
        PlanOptions(algorithm="markov", greed=2.0)


def test_folded_clearance_error_names_an_infeasible_design():
    spec = load_spec("sdss-v").with_overrides(buffer_mm=2.0)
    from rfp_twin.models.array import ArrayGeometry

    ok = ArrayGeometry(spec, Layout.hex_grid_positions(7, spec.pitch_mm), 2.0)
    assert folded_clearance_error(ok) is None
    tight = ArrayGeometry(spec, Layout.hex_grid_positions(7, 8.0), 2.0)
    err = folded_clearance_error(tight)
    assert err is not None and "infeasible" in str(err)


def test_run_reports_the_post_processing_progress_over_every_group():
    rc = Reconfiguration.from_names("sdss-v", "hex:91", buffer_mm=2.0)
    calls = []
    out = rc.run(seed=3, on_progress=lambda stage, done, total: calls.append((stage, done, total)))
    assert calls and {c[0] for c in calls} == {"post-processing"}
    first_round = [c for c in calls if c[2] == calls[0][2]]
    assert first_round[-1][1] == first_round[-1][2] >= out.post.n_groups > 0
    assert all(0 < d <= t for _, d, t in calls)
