"""Completeness of a catalogue's science targets, overall and by priority."""
from __future__ import annotations

import numpy as np

from rfp_twin.models.catalogue import Catalogue
from rfp_twin.planners.assignment.completeness import completeness, observed_rows


def test_completeness_counts_science_targets_by_priority():
    cat = Catalogue(ids=[10, 11, 12, 13, 14, 15], xy=np.zeros((6, 2)),
                    priority=[2, 2, 1, 1, 1, 5], kind=[0, 0, 0, 0, 0, 1], fiber=[0] * 6)
    seen = observed_rows(cat, np.array([11, 12, 15, -1]))
    assert seen.tolist() == [False, True, True, False, False, True]
    c = completeness(cat, seen)
    assert c["n_science"] == 5 and c["n_observed"] == 2       # the sky target does not count
    assert c["science"] == 2 / 5
    assert list(c["by_priority"]) == ["2", "1"]                 # most valuable first
    assert c["by_priority"]["2"] == {"n": 2, "observed": 1, "completeness": 0.5}
    assert c["by_priority"]["1"]["completeness"] == 1 / 3


def test_a_catalogue_without_science_has_no_completeness():
    cat = Catalogue(ids=[1], xy=[[0.0, 0.0]], priority=[1], kind=[1], fiber=[0])
    c = completeness(cat, np.array([True]))
    assert c["science"] is None and c["by_priority"] == {}


def test_completeness_within_reach_counts_only_reachable_science():
    cat = Catalogue(ids=[1, 2, 3, 4], xy=np.zeros((4, 2)), priority=[1] * 4, kind=[0, 0, 0, 2],
                    fiber=[0] * 4)
    c = completeness(cat, np.array([True, False, False, True]),
                     reachable=np.array([True, True, False, True]))
    assert c["science"] == 1 / 3 and c["n_within_reach"] == 2 and c["within_reach"] == 0.5
