"""One trial -> one row (twin/studies/runner.py): the pipeline on a grid point."""
from __future__ import annotations

import pytest

from tests.twin.studies.builders import DETERMINISTIC, TINY, study_file
from rfp_twin.twin.pipeline import PlanOptions, Reconfiguration
from rfp_twin.twin.studies import SCHEMA, parse_study, run_trial


def test_trial_is_the_pipeline_run_its_seed_replays(tmp_path):
    study = study_file(TINY, tmp_path)
    t = study.trial_list()[3]
    p = t.point
    r1 = run_trial(p, t.index, study.seed, check=True, study="tiny")
    r2 = run_trial(p, t.index, study.seed, check=True)
    for k in DETERMINISTIC:
        assert r1[k] == r2[k], k
    assert r1["seed"] == t.seed and r1["key"] == t.key and r1["study"] == "tiny"
    assert set(r1) <= set(SCHEMA.names) and r1["checked"] and r1["error"] is None
    # `rfp-twin plan --layout hex:19 --buffer B --step D --algorithm A --seed SEED --raw`
    rc = Reconfiguration.from_names("sdss-v", "hex:19", buffer_mm=p.buffer_mm, options=PlanOptions(
        algorithm=p.algorithm, step_deg=p.step_deg, greed=p.greed, phobia=p.phobia,
        resolve="replace", raw=True))
    outcome = rc.run(seed=t.seed)
    m = outcome.plan.metrics
    for k in ("efficiency", "convergence", "fold_time_s", "n_replaced", "n_deadlocked", "rounds",
              "n_steps"):
        assert r1[k] == m[k], k
    assert r1["collisions"] == len(outcome.check.collisions) == 0
    assert r1["min_clearance_mm"] == pytest.approx(outcome.check.min_clearance_mm)


def test_unchecked_trials_plan_the_same_and_skip_the_check(tmp_path):
    study = study_file(TINY, tmp_path)
    t = study.trial_list()[1]
    checked = run_trial(t.point, t.index, study.seed, check=True)
    fast = run_trial(t.point, t.index, study.seed, check=False)
    assert not fast["checked"]
    assert fast.get("collisions") is None and fast.get("check_s") is None
    for k in DETERMINISTIC:
        if k != "collisions":
            assert fast[k] == checked[k], k


def test_infeasible_points_are_recorded_not_raised():
    # pitch 16 mm with a 3.5 mm buffer: the folded state (10, 170) already collides
    study = parse_study("[grid]\nn_robots = 7\npitch_mm = 16.0\nbuffer_mm = 3.5\n")
    t = study.trial_list()[0]
    row = run_trial(t.point, 0, study.seed)
    assert row["status"] == "error" and "folded state" in row["error"]
    assert row.get("efficiency") is None and row["wall_s"] >= 0


def test_field_planners_run_as_study_algorithms(tmp_path):
    """apf / capf trials: checked, no replacement, efficiency = converged fraction."""
    text = TINY.replace('algorithm = ["GC", "MC"]', 'algorithm = ["apf", "capf"]').replace(
        "buffer_mm = [1.5, 3.0]", "buffer_mm = 2.0").replace("trials = 2", "trials = 1")
    study = study_file(text, tmp_path)
    rows = [run_trial(t.point, t.index, study.seed) for t in study.trial_list()]
    assert {r["algorithm"] for r in rows} == {"apf", "capf"}
    for r in rows:
        assert r["status"] in ("ok", "deadlocked") and r["error"] is None
        assert r["n_replaced"] == 0 and r["rounds"] == 0 and r["collisions"] == 0
        assert r["efficiency"] == pytest.approx(1 - r["n_deadlocked"] / 19)
        assert 0.0 < r["fold_time_s"] < 60.0
