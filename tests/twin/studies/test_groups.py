"""Rows grouped by grid point (twin/studies/groups.py)."""
from __future__ import annotations

import math

from tests.twin.studies.builders import TINY, made_row
from rfp_twin.twin.studies import RESULTS, parse_study, write_row
from rfp_twin.twin.studies.groups import load_groups, make_series, series_label, varied_params


def _folder(tmp_path, rows_of):
    study = parse_study(TINY)
    out = tmp_path / "out"
    (out / RESULTS).mkdir(parents=True)
    (out / "study.toml").write_text(TINY)
    for t in study.trial_list():
        write_row(out / RESULTS, made_row(study, t, **rows_of(t)))
    return out, study


def test_groups_count_errors_deadlocks_and_collisions(tmp_path):
    def rows_of(t):
        if t.index == 1 and t.point.algorithm == "greedy":
            return dict(status="error", error="TargetError: no room", efficiency=None)
        if t.index == 1:
            return dict(status="deadlocked", n_deadlocked=2, efficiency=0.9, collisions=1)
        return dict(efficiency=1.0)

    out, study = _folder(tmp_path, rows_of)
    groups, info = load_groups(out)
    assert info["rows"] == 8 and info["ignored_rows"] == 0 and info["hosts"] == ["host"]
    assert len(groups) == 4 and info["study"].name == "tiny"
    for g in groups:
        assert g.n == 2
        if g.alg == "greedy":
            assert g.n_error == 1 and g.errors == ["TargetError: no room"]
            assert g.v("efficiency").tolist() == [1.0] and math.isnan(g.ci95("efficiency")[0])
        else:
            assert g.n_error == 0 and g.n_deadlocked == 1
            assert (g.n_checked, g.collisions, g.n_collision_trials) == (2, 1, 1)
            assert g.mean("efficiency") == 0.95
            # targets kept: deadlocked robots count as lost (2 of 19)
            assert sorted(g.v("kept").tolist()) == [0.9 - 2 / 19, 1.0]
    assert varied_params(groups) == ["buffer_mm"]
    series = make_series(groups, "buffer_mm", ["buffer_mm", "algorithm"])
    assert list(series) == [("markov", ()), ("greedy", ())]      # MC first, as the paper
    assert [g.params["buffer_mm"] for g in series[("markov", ())]] == [1.5, 3.0]
    assert series_label("markov", (("step_deg", 0.5),)) == "MC, step 0.5"


def test_rows_of_points_no_longer_in_the_study_are_left_out(tmp_path):
    out, study = _folder(tmp_path, lambda t: {})
    (out / "study.toml").write_text(TINY.replace("buffer_mm = [1.5, 3.0]", "buffer_mm = 1.5"))
    groups, info = load_groups(out)
    assert len(groups) == 2 and info["ignored_rows"] == 4
    assert len(load_groups(out, all_points=True)[0]) == 4
