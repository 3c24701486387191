"""Deadlock resolution by continuation (planners/continuation.py): the groups go on
alone with Markov moves of the real stepwise kernel, everyone else standing still."""
from __future__ import annotations

import numpy as np

from rfp_twin.models.kinematics import inverse
from rfp_twin.planners.continuation import ATTEMPTS, continue_groups
from rfp_twin.planners.stepwise import max_displacement
from rfp_twin.planners.stepwise.run import run_array
from tests.planners.conftest import make_geom

STEP = 0.5


def setup(max_steps: int = 3000):
    geom = make_geom(37, 2.0)
    spec = geom.spec
    md = max_displacement(spec.alpha_length_mm, spec.beta_length_mm, float(geom.seg_end.max()), STEP)
    fold = np.tile(np.asarray(spec.fold_deg, float), (geom.n_robots, 1))
    calls = []

    def run(start, dest, movable, greed, phobia, seed):
        calls.append((greed, phobia, seed, np.flatnonzero(movable).tolist()))
        return run_array(geom, start, dest, movable, step_deg=STEP, max_steps=max_steps, md=md,
                         greed=greed, phobia=phobia, seed=seed)
    return geom, fold, run, calls


def test_groups_that_arrive_get_paths_from_where_they_stood():
    geom, fold, run, calls = setup()
    c = int(np.argmin(np.hypot(*geom.base_xy.T)))
    far = int(np.argmax(np.hypot(*geom.base_xy.T)))
    final = fold.copy()
    final[c] = (200.0, 150.0)          # stretched out, clear of its folded neighbours
    final[far] = (100.0, 120.0)
    groups = [np.array([c]), np.array([far])]
    out = continue_groups(geom.n_robots, final, fold, groups, run, seed=11)
    assert out.solved == [0, 1] and out.attempts == 1
    assert calls == [(*ATTEMPTS[0], 11, sorted([c, far]))]    # only the groups move
    assert sorted(out.paths) == sorted([c, far])
    for i in (c, far):
        steps, angles = out.paths[i]
        assert steps[0] == 0.0
        np.testing.assert_allclose(angles[0], final[i])
        np.testing.assert_allclose(angles[-1], fold[i], atol=1e-9)


def test_a_group_that_cannot_arrive_uses_every_attempt():
    """An offline neighbour reaches into the centre robot's folded place: it never gets there."""
    geom, fold, run, calls = setup(max_steps=200)
    spec = geom.spec
    c = int(np.argmin(np.hypot(*geom.base_xy.T)))
    right = int(np.argmin(np.hypot(*(geom.base_xy - geom.base_xy[c] - [22.4, 0.0]).T)))
    final = fold.copy()
    final[c] = (180.0, 0.0)            # stretched away from the right neighbour
    final[right] = inverse(geom.base_xy[[right]], geom.base_xy[[c]] + [[3.0, 0.0]],
                           spec.alpha_length_mm, spec.beta_length_mm)[0]
    dest = fold.copy()
    dest[right] = final[right]
    out = continue_groups(geom.n_robots, final, dest, [np.array([c])], run, seed=3, attempts=3)
    assert out.solved == [] and out.paths == {} and out.attempts == 3
    assert [k[:3] for k in calls] == [(*ATTEMPTS[a], 3 + a) for a in range(3)]
    assert continue_groups(geom.n_robots, final, dest, [np.array([c])], run, 3, attempts=0).attempts == 0
