"""Passes of one field: each pass assigns what is left and starts where the last one ended."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.catalogue import SCIENCE, Disc, density_per_mm2, mock_catalogue
from rfp_twin.models.errors import RfpError
from rfp_twin.planners.assignment import AssignSettings
from rfp_twin.twin.passes import (DIRECT, FROM_FOLD, VIA_FOLD, check_passes, observe_passes,
                                  passes_summary, reconfigure_between)
from rfp_twin.twin.pipeline import Reconfiguration
from rfp_twin.validation.checker2d import check_trajectory


def field(n=19, per_patrol=3.0, seed=2, levels=2):
    rc = Reconfiguration.from_names("sdss-v", f"hex:{n}", buffer_mm=2.0)
    lo, hi = rc.spec.patrol_annulus_mm
    cat = mock_catalogue(np.random.default_rng(seed), Disc((0.0, 0.0), 60.0),
                         density_per_mm2(per_patrol, "patrol",
                                         patrol_area_mm2=np.pi * (hi * hi - lo * lo)),
                         priority_levels=levels)
    return rc, cat


@pytest.fixture(scope="module")
def three_passes():
    rc, cat = field()
    return rc, cat, observe_passes(rc, cat, AssignSettings(), 3, seed=1)


def test_each_pass_observes_new_targets_and_completeness_rises(three_passes):
    rc, cat, done = three_passes
    assert [p.index for p in done] == [1, 2, 3]
    ids = np.concatenate([p.observed for p in done])
    assert ids.size == np.unique(ids).size > 0                  # no target observed twice
    assert np.all(cat.kind[np.isin(cat.ids, ids)] == SCIENCE)
    s = passes_summary(cat, done)
    cum = [r["cumulative"] for r in s["passes"]]
    assert all(b >= a for a, b in zip(cum, cum[1:])) and cum[1] > cum[0]
    assert s["completeness"]["n_observed"] == ids.size
    assert abs(cum[-1] - ids.size / np.count_nonzero(cat.kind == SCIENCE)) < 1e-12
    for p, r in zip(done, s["passes"]):
        assert r["available_science"] == p.available
        # what a pass observed was assigned in it and kept by its plan
        a = p.run.assignment
        kept = set(a.target_ids[(a.target >= 0) & (p.run.outcome.plan.status == "reached")])
        assert set(p.observed.tolist()) <= kept and p.run.n_lost == 0
    left = [p.available for p in done]
    assert left[1] == left[0] - done[0].observed.size
    assert left[2] == left[1] - done[1].observed.size


def test_each_pass_starts_where_the_last_ended_and_passes_the_2d_check(three_passes):
    rc, cat, done = three_passes
    assert done[0].mode == FROM_FOLD
    assert np.allclose(done[0].motion.plan.start(), rc.spec.fold_deg)
    for prev, cur in zip(done, done[1:]):
        assert cur.mode in (DIRECT, VIA_FOLD)
        assert np.array_equal(cur.motion.plan.start(), prev.motion.plan.end())
        assert np.allclose(cur.motion.trajectory.start(), prev.motion.trajectory.end(), atol=1e-9)
        assert np.allclose(cur.motion.trajectory.end(), cur.run.assignment.angles, atol=1e-9)
    for p in done:
        traj = p.motion.trajectory
        assert check_trajectory(traj, rc.spec, rc.layout, rc.spec.buffer_mm - 0.5).ok


def test_via_the_fold_is_the_fold_then_the_unfold_and_direct_plans_between_poses():
    rc, cat = field(n=7, per_patrol=2.0)
    first = rc.run(seed=1, targets=rc.random_targets(np.random.default_rng(1)))
    B = first.plan.end().copy()
    B[0] = rc.spec.fold_deg                            # one robot goes home, nobody else moves
    second = rc.run(seed=2, targets=B)
    via, mode, _ = reconfigure_between(rc, first, second, direct=False)
    assert mode == VIA_FOLD
    assert via.trajectory.duration == pytest.approx(first.trajectory.duration
                                                    + second.trajectory.duration)
    assert via.check.ok and via.plan.n_steps == first.plan.n_steps + second.plan.n_steps
    assert np.allclose(via.trajectory.sample([first.trajectory.duration])[0], rc.spec.fold_deg)
    direct, mode, tried = reconfigure_between(rc, first, second)
    assert mode == DIRECT and tried["kept_all"]
    assert direct.trajectory.duration < via.trajectory.duration
    assert np.allclose(direct.trajectory.start(), first.plan.end(), atol=1e-9)
    assert np.allclose(direct.trajectory.end(), B, atol=1e-9)
    assert check_trajectory(direct.trajectory, rc.spec, rc.layout, rc.spec.buffer_mm - 0.5).ok


@pytest.mark.parametrize("bad", [0, -1, 101, 2.5, True])
def test_bad_pass_counts_are_one_line_errors(bad):
    with pytest.raises(RfpError, match=r"--passes .*; allowed: an integer in \[1, 100\]"):
        check_passes(bad)


def test_targets_within_reach_are_the_assigners_candidates(three_passes):
    from rfp_twin.twin.passes import within_reach

    rc, cat, done = three_passes
    near = within_reach(rc, cat, AssignSettings())
    s = passes_summary(cat, done, near)
    ids = np.concatenate([p.observed for p in done])
    assert np.all(near[np.isin(cat.ids, ids)])               # observed targets are reachable
    c = s["completeness"]
    assert c["within_reach"] == pytest.approx(ids.size / np.count_nonzero(near & (cat.kind == SCIENCE)))
    assert s["passes"][-1]["cumulative_within_reach"] == c["within_reach"]


def test_a_target_needing_two_exposures_is_observed_twice_and_complete_after_the_second():
    from rfp_twin.models.catalogue import Catalogue

    rc, cat = field(per_patrol=1.5, levels=1)
    exposures = np.where(np.arange(cat.n_targets) % 2 == 0, 2, 1)
    cat = Catalogue(cat.ids, cat.xy, cat.priority, cat.kind, cat.fiber, cat.source, exposures)
    done = observe_passes(rc, cat, AssignSettings(), 3, seed=1)
    ids = np.concatenate([p.observed for p in done])
    got = {int(t): int(n) for t, n in zip(*np.unique(ids, return_counts=True))}
    need = dict(zip(cat.ids.tolist(), cat.exposures.tolist()))
    assert all(n <= need[t] for t, n in got.items())             # never more than it needs
    assert any(n == 2 for n in got.values())                      # some had both exposures
    for p in done:
        assert p.observed.size == np.unique(p.observed).size      # once per pass
    s = passes_summary(cat, done)
    complete = sum(1 for t, n in got.items() if n >= need[t])
    assert s["completeness"]["n_observed"] == complete
    assert sum(r["completed_science"] for r in s["passes"]) == complete
    assert sum(r["observed_science"] for r in s["passes"]) == ids.size > complete


def test_a_catalogue_exposures_column_is_read_and_checked(tmp_path):
    from rfp_twin.models.catalogue import read_catalogue
    from rfp_twin.models.errors import CatalogueError

    f = tmp_path / "c.csv"
    f.write_text("id,x_mm,y_mm,exposures\n1,0,10,3\n2,0,-10,\n")
    assert read_catalogue(f).exposures.tolist() == [3, 1]
    f.write_text("id,x_mm,y_mm,exposures\n1,0,10,0\n")
    with pytest.raises(CatalogueError, match=r"c.csv:2: field 'exposures' = '0'; allowed: an "
                                             r"integer in \[1, 1000\]"):
        read_catalogue(f)
