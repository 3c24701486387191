"""Cutting the detours robots make after arriving (planners/deadlocks/search/trim.py)."""
from __future__ import annotations

import numpy as np

from rfp_twin.models.kinematics import inverse
from rfp_twin.planners.roadmap.alpha_beta.paths import PathSet
from rfp_twin.planners.deadlocks.search.trim import trim_tails
from rfp_twin.planners.stepwise import max_displacement
from tests.planners.conftest import make_geom


def test_detours_after_arriving_are_cut_only_where_safe():
    """trim_tails: a robot that arrives, steps aside and comes back holds its
    destination instead, unless a neighbour passes through that place meanwhile."""
    geom = make_geom(7, 2.0)
    spec = geom.spec
    step = 0.5
    md = max_displacement(spec.alpha_length_mm, spec.beta_length_mm, float(geom.seg_end.max()), step)
    n = geom.n_robots
    fold = np.tile(np.asarray(spec.fold_deg, float), (n, 1))
    c = int(np.argmin(np.hypot(*geom.base_xy.T)))
    right = int(np.argmin(np.hypot(*(geom.base_xy - geom.base_xy[c] - [22.4, 0.0]).T)))

    def paths_with(right_path):
        steps = [np.array([0.0])] * n
        angles = [fold[i][None, :] for i in range(n)]
        # the centre robot arrives at step 10, leaves (alpha + 20 deg) and is back at 90
        steps[c] = np.array([0.0, 10.0, 50.0, 90.0])
        angles[c] = np.array([[30.0, 170.0], fold[c], [30.0, 170.0], fold[c]])
        if right_path is not None:
            steps[right], angles[right] = right_path
        return PathSet(list(steps), list(angles))

    skip = np.zeros(n, dtype=bool)
    quiet = paths_with(None)
    assert trim_tails(geom, quiet, fold, skip, md) == [c]
    np.testing.assert_allclose(quiet.sample(c, np.arange(10.0, 91.0)), np.tile(fold[c], (81, 1)))
    # the right neighbour reaches into the centre robot's folded place at steps 40-60
    reach = inverse(geom.base_xy[[right]], geom.base_xy[[c]] + [[3.0, 0.0]],
                    spec.alpha_length_mm, spec.beta_length_mm)[0]
    busy = paths_with((np.array([0.0, 40.0, 60.0, 100.0]),
                       np.array([fold[right], reach, reach, fold[right]])))
    keep_right = np.eye(n, dtype=bool)[right]          # (its own detour is not the point)
    assert trim_tails(geom, busy, fold, keep_right, md) == []
    assert trim_tails(geom, paths_with(None), fold, np.eye(n, dtype=bool)[c], md) == []


def test_skipping_far_configurations_gives_the_every_step_answer():
    """held_meets skips the configurations a bound proves far; over 3,000 random
    neighbour motions (many grazing the threshold) it answers as testing every step
    does; the thresholds lie around each motion's closest approach, so both answers
    come often (and the test fails if the skips are tripled)."""
    from rfp_twin.models.geometry2d import beta_segment
    from rfp_twin.planners.roadmap.alpha_beta.kernels import pair_conflict, segments_at
    from rfp_twin.planners.deadlocks.search.trim import held_meets

    rng = np.random.default_rng(7)
    l_alpha, s0, s1 = 7.4, 0.0, 15.0
    answers = []
    for case in range(3000):
        held = beta_segment(0.0, 0.0, *rng.uniform([0, 0], [360, 180]), l_alpha, s0, s1)
        bx, by = 22.4 * np.cos(rng.uniform(0, 2 * np.pi)), 22.4 * np.sin(rng.uniform(0, 2 * np.pi))
        knots = np.cumsum(rng.uniform(0.0, 40.0, (4, 2)) * rng.choice([-1, 1], (4, 2)), axis=0)
        steps = np.concatenate([[0.0], np.sort(rng.uniform(1, 300, 3))])
        ks = np.arange(0.0, 301.0)
        alpha = np.interp(ks, steps, knots[:, 0] + rng.uniform(0, 360))
        beta = np.interp(ks, steps, np.clip(knots[:, 1] + 90.0, 0, 180))
        seg = segments_at(bx, by, np.column_stack([alpha, beta]), l_alpha, s0, s1)
        d = min(float(np.hypot(*(0.5 * (seg[:, :2] + seg[:, 2:]) - 0.5 * (np.array(held[:2]) + held[2:])).T).min()), 99.0)
        th = max(0.1, d * rng.uniform(0.3, 1.0))       # thresholds around the closest approach
        every = pair_conflict(np.tile(held, (ks.size, 1)), seg, th)
        assert held_meets(*held, alpha, beta, bx, by, l_alpha, s0, s1, th) == every, case
        answers.append(every)
    assert 0.2 < np.mean(answers) < 0.8
