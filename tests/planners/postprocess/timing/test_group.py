"""Timing one group (planners/postprocess/timing/group.py): limits held continuously, arguments checked."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.errors import SpecError
from rfp_twin.planners.postprocess.smoothing import SmoothPath, smooth_plan
from rfp_twin.planners.postprocess.timing import interaction_groups, interaction_pairs, time_group
from tests.planners.conftest import make_geom, plan_random
from tests.planners.path_builders import A, CORNER, V, numeric_kinematics, real_groups


@pytest.mark.parametrize("window", [10.0, 60.0, 200.0])
def test_smoothed_path_respects_limits_continuously(window):
    sp = smooth_plan(CORNER, window_steps=window)
    law = time_group(sp, [0], (V, V), (A, A))
    vm, am = numeric_kinematics(sp, [0], law)
    assert vm <= V * 1.001 and am <= A * 1.01
    assert vm >= 0.95 * V                                 # and uses them
    # at rest at both ends, at the plan's start and end configurations
    np.testing.assert_allclose(sp.evaluate(law.s_at([0.0, law.duration]))[:, 0],
                               [CORNER.start()[0], CORNER.end()[0]], atol=1e-9)
    # the reversal costs time: wider windows are faster
    assert law.duration > 40.0 / V


def test_wider_windows_are_faster_on_a_real_group():
    geom = make_geom(37, 2.5)
    _, plan = plan_random(geom, 2, step_deg=0.1)
    pairs, cl = interaction_pairs(plan, geom, 1.0)
    labels = interaction_groups(geom.n_robots, pairs[cl < 1.0])
    sizes = np.bincount(labels)
    robots = np.flatnonzero(labels == np.argmax(sizes))
    assert robots.size >= 2
    durations = []
    for w in (5.0, 50.0, 200.0):
        sp = smooth_plan(plan, window_steps=w)
        law = time_group(sp, robots, (V, V), (A, A))
        vm, am = numeric_kinematics(sp, robots, law, dt=5e-4)
        assert vm <= V * 1.001 and am <= A * 1.01
        durations.append(law.duration)
    assert durations[0] > durations[1] > durations[2]


def test_groups_above_the_toppra_size_cap_go_to_the_kernel():
    """toppra_max_robots: a group larger than the cap is timed by the kernel (solver
    "numba-large"), with the same law the library gives it without the cap."""
    sp, groups = real_groups()
    robots = max(groups, key=len)
    assert robots.size >= 2
    capped = time_group(sp, robots, (V, V), (A, A), backend="toppra",
                        toppra_max_robots=robots.size - 1)
    free = time_group(sp, robots, (V, V), (A, A), backend="toppra", toppra_max_robots=None)
    ker = time_group(sp, robots, (V, V), (A, A), backend="numba")
    assert capped.solver == "numba-large" and free.solver == "toppra"
    assert capped.duration == ker.duration
    assert free.duration == pytest.approx(capped.duration, rel=1e-4)
    at_cap = time_group(sp, robots, (V, V), (A, A), backend="toppra",
                        toppra_max_robots=robots.size)
    assert at_cap.solver == "toppra"


@pytest.mark.parametrize("kwargs,field", [
    ({"backend": "ruckig"}, "backend"),
    ({"grid_steps": 0.0}, "grid_steps"),
    ({"straight_steps": -1.0}, "straight_steps"),
    ({"sd_cap": np.inf}, "sd_cap"),
])
def test_bad_arguments_name_the_field(kwargs, field):
    sp = smooth_plan(CORNER, window_steps=10)
    with pytest.raises(SpecError, match=field):
        time_group(sp, [0], (V, V), (A, A), **kwargs)


def _ends_on_its_last_interval() -> SmoothPath:
    """The last 44 steps of a robot of a Markov fold (500-robot SDSS-V, 2.5 mm, seed 3)
    whose smoothed motion ends exactly on the domain's end, with q'' != 0 there."""
    knots = np.array([0.0, 8.0, 16.0, 25.0, 32.0, 37.0, 40.0, 44.0])
    c1c2 = [((1.0e-02, -6.25e-05), (-8.0e-03, 6.25e-05)),
            ((9.0e-03, -2.5e-04), (-7.0e-03, 2.1875e-04)),
            ((5.0e-03, 2.77777778e-05), (-3.5e-03, -5.55555556e-05)),
            ((5.5e-03, -2.5e-04), (-4.5e-03, 2.5e-04)),
            ((2.0e-03, -5.0e-05), (-1.0e-03, 5.0e-05)),
            ((1.5e-03, 8.33333333e-05), (-5.0e-04, -2.5e-04)),
            ((2.0e-03, -2.5e-04), (-2.0e-03, 2.5e-04)),
            ((0.0, 0.0), (0.0, 0.0))]
    coef = np.zeros((8, 2, 4))
    value = np.array([247.708315, 153.514573])
    for k, axes in enumerate(c1c2):
        for ax, (c1, c2) in enumerate(axes):
            coef[k, ax, :3] = value[ax], c1, c2
        if k + 1 < 8:
            h = knots[k + 1] - knots[k]
            value = value + [a[0] * h + a[1] * h * h for a in axes]
    return SmoothPath(np.array([1]), "average", np.array([200.0]), 0.0, 44.0,
                      np.array([0, 8]), knots, coef)


@pytest.mark.parametrize("backend", ["numba", "toppra"])
def test_an_interval_crossed_at_rest_is_refined_away(backend, monkeypatch):
    """TOPP-RA's greedy forward pass can leave x = 0 at both ends of the last interval
    (the kernel: infinite time, the library: ~1800 s); time_group refines the grid
    there and both backends give the same short law."""
    from rfp_twin.planners.postprocess.timing import group

    sp = _ends_on_its_last_interval()
    law = time_group(sp, [0], (30.0, 30.0), (45.0, 45.0), backend=backend)
    assert law.duration < 0.3 and law.s.size > 14
    assert law.sd[0] == 0.0 and law.sd[-1] == 0.0
    monkeypatch.setattr(group, "_MAX_REFINE", 0)
    raw = time_group(sp, [0], (30.0, 30.0), (45.0, 45.0), backend=backend)
    assert raw.duration > 1000.0
