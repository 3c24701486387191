"""A full 2D check and later re-checks of some pairs as one report
(validation/checker2d/merge.py), compared with a full check of the changed trajectory."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.layout import Layout
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.validation.checker2d import check_trajectory, merge_reports
from tests.validation.conftest import PITCH, SPEC

BUF = 2.5


def row_layout() -> Layout:
    """Robots 0, 1, 2 in a row at the pitch, fiducial 9 beyond robot 2."""
    return Layout([0, 1, 2, 9], [[0.0, 0.0], [PITCH, 0.0], [2 * PITCH, 0.0], [2 * PITCH + 20.0, 0.0]],
                  ["robot", "robot", "robot", "fiducial"], name="row+fid")


def moves(beta0: float, beta2: float) -> Trajectory:
    """Robots 0 and 2 swing their beta arms from folded to ``beta0`` / ``beta2`` and back
    (alpha 0: beta 0 points at robot 1 / the fiducial); robot 1 is folded facing robot 0
    (alpha 180, beta 180)."""
    return Trajectory.from_breakpoints(
        [0, 1, 2],
        [[0.0, 1.0], [0.0, 1.0], [0.0, 1.0]], [[0.0, 0.0], [180.0, 180.0], [0.0, 0.0]],
        [[0.0, 0.5, 1.0], [0.0, 1.0], [0.0, 0.5, 1.0]],
        [[180.0, beta0, 180.0], [180.0, 180.0], [180.0, beta2, 180.0]])


def as_dict(ids, dist) -> dict:
    return dict(zip(map(tuple, np.sort(np.asarray(ids), axis=1).tolist()), np.asarray(dist).tolist()))


def test_merged_rechecks_equal_a_full_check_of_the_changed_trajectory():
    layout = row_layout()
    first = check_trajectory(moves(0.0, 0.0), SPEC, layout, BUF)
    # robot 0 reaches into robot 1, robot 2 into the fiducial: both collide
    assert {(c.kind, c.robot_a, c.other) for c in first.collisions} == {("robot", 0, 1),
                                                                       ("fiducial", 2, 9)}
    # robot 0 now stays clear; only its pairs are re-checked
    changed = moves(150.0, 0.0)
    again = check_trajectory(changed, SPEC, layout, BUF, focus_ids=[0])
    assert again.n_pairs == 2 and again.n_fiducial_pairs == 0 and again.ok
    merged = merge_reports(first, again)
    full = check_trajectory(changed, SPEC, layout, BUF)
    # robot 2's fiducial collision was not re-checked: it stands, as in the full check
    assert [(c.kind, c.robot_a, c.other) for c in merged.collisions] == \
        [(c.kind, c.robot_a, c.other) for c in full.collisions] == [("fiducial", 2, 9)]
    assert merged.n_pairs == full.n_pairs and merged.n_fiducial_pairs == full.n_fiducial_pairs
    for ids, dist, fids, fdist in ((merged.pair_ids, merged.pair_min_distance_mm,
                                    full.pair_ids, full.pair_min_distance_mm),
                                   (merged.fiducial_pair_ids, merged.fiducial_min_distance_mm,
                                    full.fiducial_pair_ids, full.fiducial_min_distance_mm)):
        mine, theirs = as_dict(ids, dist), as_dict(fids, fdist)
        assert mine.keys() == theirs.keys()
        for key, d in theirs.items():
            assert mine[key] == pytest.approx(d, abs=0.005 + 0.01 * d)
    assert merged.min_clearance_mm == pytest.approx(full.min_clearance_mm, abs=0.005)
    assert merged.n_samples == first.n_samples + again.n_samples
    assert first.merged_with(again).collisions == merged.collisions
    # once robot 2 is re-checked clear too, the merged report is clear
    clear = check_trajectory(moves(150.0, 150.0), SPEC, layout, BUF, focus_ids=[2])
    done = merged.merged_with(clear)
    assert done.ok and done.min_clearance_mm > 0.0
    assert done.min_clearance_mm == pytest.approx(
        check_trajectory(moves(150.0, 150.0), SPEC, layout, BUF).min_clearance_mm, abs=0.005)


def test_reports_of_different_buffers_or_without_thresholds_are_refused():
    layout = row_layout()
    a = check_trajectory(moves(150.0, 150.0), SPEC, layout, BUF)
    b = check_trajectory(moves(150.0, 150.0), SPEC, layout, 2.0, focus_ids=[0])
    with pytest.raises(ValueError, match="buffers differ"):
        merge_reports(a, b)
    bare = check_trajectory(moves(150.0, 150.0), SPEC, layout, BUF, focus_ids=[0])
    bare.pair_threshold_mm = np.empty(0)
    with pytest.raises(ValueError, match="newer report has no per-pair thresholds"):
        merge_reports(a, bare)
