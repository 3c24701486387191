"""Interaction groups (planners/postprocess/timing/grouping.py): pairs that come close, components."""
from __future__ import annotations

import numpy as np

from rfp_twin.models.geometry2d import pair_distances
from rfp_twin.planners.postprocess.timing import interaction_groups, interaction_pairs
from tests.planners.conftest import make_geom, plan_random


def test_interaction_pairs_match_dense_sampling():
    geom = make_geom(37, 3.0)
    _, plan = plan_random(geom, 0, step_deg=0.1)
    margin = 1.5
    pairs, cl = interaction_pairs(plan, geom, margin)
    steps = np.arange(plan.n_steps + 1.0)
    ang = plan.angles_at(steps)
    spec = geom.spec
    dense = np.min([pair_distances(geom.base_xy, a, geom.pairs, spec.alpha_length_mm,
                                   spec.segment_start_mm, geom.seg_end) for a in ang],
                   axis=0) - 2 * geom.buffer_mm
    np.testing.assert_array_equal(pairs, geom.pairs)
    below = dense < margin
    assert below.any() and (~below).any()
    np.testing.assert_array_equal(cl < margin, below)
    assert np.all(cl[~below] >= dense[~below] - 1e-9)    # smallest samples: upper bounds


def test_interaction_groups_are_connected_components():
    labels = interaction_groups(6, np.array([[0, 1], [1, 2], [4, 5]]))
    assert labels[0] == labels[1] == labels[2]
    assert labels[4] == labels[5] != labels[0]
    assert len(set(labels.tolist())) == 3
    assert interaction_groups(3, np.zeros((0, 2))).tolist() == [0, 1, 2]
