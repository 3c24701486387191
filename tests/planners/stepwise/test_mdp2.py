"""MDP2 kernel (planners/stepwise/mdp2.py): kaiju's rules on tiny arrays.

The rules checked (kaiju 1.4.1 ``pathGenMDP2`` / ``stepMDP2``): a watched robot never
enters beta < 41.2853 - 1.3085 alpha (encoder deg); a failed try nudges the robot with the
largest *encoder* beta among those away from home and not yet nudgers, and the next try
starts over; a robot at home that a neighbour encroaches (closer than 2B + 20 MD) becomes a
nudger; a converged plan keeps every pair farther than 2B + MD at every step.
"""
from __future__ import annotations

import numpy as np

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.layout import Layout
from rfp_twin.models.robot import load_spec
from rfp_twin.planners.plan import build_paths
from rfp_twin.planners.stepwise import array_max_displacement
from rfp_twin.planners.stepwise.mdp2 import ENCROACH_MD, FW_C0, FW_C1
from rfp_twin.planners.stepwise.mdp2_run import run_mdp2
from rfp_twin.validation.numerics import segment_distance_np

SPEC = load_spec("sdss-v-production")
STEP = 0.1


def _geom(xy) -> ArrayGeometry:
    xy = np.asarray(xy, dtype=np.float64)
    return ArrayGeometry(SPEC, Layout(np.arange(1, len(xy) + 1), xy, ["robot"] * len(xy),
                                      "mdp2-toy"), 2.0)


def _segments(geom, angles):
    """(k, n, 2) segment ends of every robot at angles (k, n, 2) deg, from our own formula."""
    a = np.deg2rad(angles[..., 0])
    ab = a + np.deg2rad(angles[..., 1])
    elbow = geom.base_xy + geom.alpha_len[:, None] * np.stack([np.cos(a), np.sin(a)], -1)
    u = np.stack([np.cos(ab), np.sin(ab)], -1)
    return elbow + geom.seg_start[:, None] * u, elbow + geom.seg_end[:, None] * u


def _states(geom, start, run):
    """(n_steps + 1, n, 2) deg: every robot's angles at every step of the run."""
    ptr, steps, ang = build_paths(geom.n_robots, run.ev_robot, run.ev_step, run.ev_angles,
                                  start, run.final, run.n_steps)
    grid = np.arange(run.n_steps + 1, dtype=np.float64)
    out = np.empty((grid.size, geom.n_robots, 2))
    for i in range(geom.n_robots):
        for ax in range(2):
            out[:, i, ax] = np.interp(grid, steps[ptr[i]:ptr[i + 1]], ang[ptr[i]:ptr[i + 1], ax])
    return out


def test_a_watched_robot_goes_around_the_forbidden_zone():
    geom = _geom([[0.0, 0.0]])
    md = array_max_displacement(geom, STEP)
    start, dest = np.array([[35.0, 0.0]]), np.array([[0.0, 60.0]])
    states = {}
    for watched in (False, True):
        run = run_mdp2(geom, start, dest, np.ones(1, bool), step_deg=STEP, max_steps=5000,
                       md=md, seed=3, watch=np.array([watched]))
        assert run.converged and run.tries == 1
        np.testing.assert_array_equal(run.final, dest)
        states[watched] = _states(geom, start, run)[:, 0]
    inside = {w: s[:, 1] < FW_C0 + FW_C1 * s[:, 0] for w, s in states.items()}
    assert inside[False].any()          # the straight path crosses the zone ...
    assert not inside[True].any()       # ... which a watched robot never enters


def test_the_zone_is_in_encoder_angles():
    geom = _geom([[0.0, 0.0]])
    md = array_max_displacement(geom, STEP)
    start, dest = np.array([[35.0, 0.0]]), np.array([[0.0, 60.0]])
    offsets = np.array([[0.0, 30.0]])             # encoder beta = model beta - 30
    run = run_mdp2(geom, start + [0.0, 30.0], dest + [0.0, 30.0], np.ones(1, bool),
                   step_deg=STEP, max_steps=5000, md=md, seed=3, watch=np.array([True]),
                   offsets=offsets)
    s = _states(geom, start + [0.0, 30.0], run)[:, 0] - offsets[0]
    assert run.converged and not (s[:, 1] < FW_C0 + FW_C1 * s[:, 0]).any()


def test_a_failed_try_nudges_the_largest_encoder_beta_and_starts_over():
    geom = _geom([[0.0, 0.0], [100.0, 0.0], [200.0, 0.0]])       # no neighbours
    md = array_max_displacement(geom, STEP)
    start = np.array([[10.0, 100.0], [10.0, 120.0], [10.0, 140.0]])
    dest = np.tile([10.0, 170.0], (3, 1))
    offsets = np.array([[0.0, 0.0], [0.0, 0.0], [0.0, 30.0]])    # encoder betas 100, 120, 110
    # 5 steps cannot reach the fold: every try fails
    run = run_mdp2(geom, start, dest, np.ones(3, bool), step_deg=STEP, max_steps=5, md=md,
                   seed=1, tries=2, offsets=offsets)
    assert run.tries == 2 and not run.converged and run.n_steps == 5
    np.testing.assert_array_equal(run.nudged, [False, True, False])
    # the last try started again from the start: 5 steps of 0.1 deg each
    np.testing.assert_allclose(run.final[:, 1], start[:, 1] + 0.5)
    run = run_mdp2(geom, start, dest, np.ones(3, bool), step_deg=STEP, max_steps=5, md=md,
                   seed=1, tries=3, offsets=offsets)
    np.testing.assert_array_equal(run.nudged, [False, True, True])


def test_an_encroached_robot_at_home_becomes_a_nudger_and_keeps_its_distance():
    geom = _geom([[0.0, 0.0], [40.0, 0.0]])
    md = array_max_displacement(geom, STEP)
    thr = 4.0 + md
    # robot 1 waits at home pointing at robot 2; robot 2 turns its beta towards it and
    # stops between the collision and the encroachment distances
    home1 = np.array([0.0, 0.0])
    betas = np.arange(0.0, 60.0, 0.1)
    cand = np.stack([np.full_like(betas, 180.0), betas], -1)
    p0, p1 = _segments(geom, np.stack([np.tile(home1, (betas.size, 1)), cand], 1))
    d = segment_distance_np(p0[:, 0], p1[:, 0], p0[:, 1], p1[:, 1])
    ok = (d > thr + 0.3) & (d < 4.0 + ENCROACH_MD * md - 0.3)
    beta2 = betas[np.flatnonzero(ok)[0]]
    start = np.array([home1, [180.0, 60.0]])
    dest = np.array([home1, [180.0, beta2]])
    run = run_mdp2(geom, start, dest, np.ones(2, bool), step_deg=STEP, max_steps=2000, md=md,
                   seed=2, tries=1)
    states = _states(geom, start, run)
    # robot 1 became a nudger and left its destination although it started there: two
    # destinations closer than the encroachment distance keep both moving (kaiju's MDP2
    # cannot converge at 3 mm for this reason)
    assert run.nudged[0]
    assert np.any(states[:, 0] != home1)
    p0, p1 = _segments(geom, states)
    dist = segment_distance_np(p0[:, 0], p1[:, 0], p0[:, 1], p1[:, 1])
    assert dist.min() >= thr


def test_offline_robots_never_move_and_count_as_home():
    geom = _geom([[0.0, 0.0], [22.4, 0.0]])
    md = array_max_displacement(geom, STEP)
    start = np.array([[30.0, 150.0], [200.0, 150.0]])
    dest = np.tile([10.0, 170.0], (2, 1))
    run = run_mdp2(geom, start, dest, np.array([True, False]), step_deg=STEP, max_steps=3000,
                   md=md, seed=4)
    assert run.converged
    np.testing.assert_array_equal(run.final, [[10.0, 170.0], [200.0, 150.0]])
