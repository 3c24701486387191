"""The stepwise planners (greedy and Markov) with per-robot geometry and segment obstacles.

A layout's optional columns (``alpha_len_mm``, ``met_x_mm``, ``buffer_add_mm``; for
obstacles ``x2_mm``/``y2_mm`` and ``obstacle_buffer_mm``) give a robot its own collision
body and an obstacle its own shape. Each scenario here moves robot 0 of a tiny layout
from the fold to a destination that is clear for the nominal robot and not for the
per-robot one (or the other way round), so the kernel must read the per-robot value to
get it right. Every plan is then checked by a collision test written here in numpy from
the geometry (segments and distances computed afresh, not by the planner's code): at
every step state the step rule's threshold holds, and between steps (sub-sampled) no
capsules overlap.

Units: mm and deg; time in planner steps.
"""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.layout import Layout
from rfp_twin.models.robot import load_spec
from rfp_twin.planners.plan import build_paths
from rfp_twin.planners.plan import PlannerSettings, plan_reconfiguration
from rfp_twin.planners.stepwise import array_max_displacement, max_displacement, run_array
from rfp_twin.planners.plan.targets import random_targets

SPEC = load_spec("sdss-v")          # alpha 7.4 mm, beta 15 mm, segment 0..15 mm
BUFFER = 2.0
STEP = 0.5
FOLD = np.array([10.0, 170.0])
#: Robot 0's destination: both arms straight out along +x, tip at x = 22.4 mm (nominal).
REACH_OUT = np.array([0.0, 0.0])
MODES = [pytest.param(1.0, 0.0, id="greedy"), pytest.param(0.9, 0.3, id="markov")]


# -- the independent collision check ---------------------------------------------------
def _point_segment(p, a, b) -> float:
    """Distance from point p to segment a-b (2-vectors), mm; a == b is a point."""
    u = b - a
    den = float(u @ u)
    t = 0.0 if den == 0.0 else min(1.0, max(0.0, float((p - a) @ u) / den))
    return float(np.hypot(*(a + t * u - p)))


def _segment_distance(p0, p1, q0, q1) -> float:
    """Distance between segments p0-p1 and q0-q1, mm: 0 when they cross, else the least
    end-to-segment distance."""
    def side(a, b, c):
        return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
    d1, d2 = side(q0, q1, p0), side(q0, q1, p1)
    d3, d4 = side(p0, p1, q0), side(p0, p1, q1)
    if d1 * d2 < 0.0 and d3 * d4 < 0.0:
        return 0.0
    return min(_point_segment(p0, q0, q1), _point_segment(p1, q0, q1),
               _point_segment(q0, p0, p1), _point_segment(q1, p0, p1))


def _segments(geom: ArrayGeometry, angles: np.ndarray) -> np.ndarray:
    """(n, 2, 2) each robot's beta collision segment at ``angles`` (n, 2) deg, from its own
    alpha arm and segment start/end."""
    a = np.radians(angles[:, 0])
    ab = np.radians(angles[:, 0] + angles[:, 1])
    elbow = geom.base_xy + geom.alpha_len[:, None] * np.column_stack([np.cos(a), np.sin(a)])
    u = np.column_stack([np.cos(ab), np.sin(ab)])
    return np.stack([elbow + geom.seg_start[:, None] * u, elbow + geom.seg_end[:, None] * u],
                    axis=1)


def worst_clearance(geom: ArrayGeometry, angles: np.ndarray) -> float:
    """Least distance minus threshold over every robot pair and every (robot, obstacle),
    mm: thresholds buffer_i + buffer_j and buffer_i + obstacle buffer (per robot and per
    obstacle), obstacles as the segments fid_xy-fid_end_xy. Negative: a collision."""
    seg = _segments(geom, angles)
    n = geom.n_robots
    worst = np.inf
    for i in range(n):
        for j in range(i + 1, n):
            d = _segment_distance(seg[i, 0], seg[i, 1], seg[j, 0], seg[j, 1])
            worst = min(worst, d - geom.buffer[i] - geom.buffer[j])
        for f in range(geom.fid_xy.shape[0]):
            d = _segment_distance(seg[i, 0], seg[i, 1], geom.fid_xy[f], geom.fid_end_xy[f])
            worst = min(worst, d - geom.buffer[i] - geom.fid_buffer[f])
    return worst


def check_plan_clear(geom: ArrayGeometry, run, start: np.ndarray, md: float) -> None:
    """The run's paths keep every clearance > MD at step states and > 0 between them."""
    n = geom.n_robots
    ptr, steps, angles = build_paths(n, run.ev_robot, run.ev_step, run.ev_angles, start,
                                     run.final, run.n_steps)

    def at(t: float) -> np.ndarray:
        return np.array([[np.interp(t, steps[ptr[i]:ptr[i + 1]], angles[ptr[i]:ptr[i + 1], k])
                          for k in range(2)] for i in range(n)])

    for t in range(1, run.n_steps + 1):
        assert worst_clearance(geom, at(float(t))) > md, f"step {t}"
        for sub in (0.25, 0.5, 0.75):
            assert worst_clearance(geom, at(t - 1 + sub)) > 0.0, f"step {t - 1 + sub}"


# -- layouts -----------------------------------------------------------------------------
def two_robots(extra: dict | None = None) -> ArrayGeometry:
    """Robot 0 at the origin, robot 1 one pitch away on +x (it stays at (0, 90): its
    segment runs from (29.8, 0) to (29.8, 15), 7.4 mm beyond robot 0's nominal tip)."""
    layout = Layout(np.array([0, 1]), np.array([[0.0, 0.0], [SPEC.pitch_mm, 0.0]]),
                    ["robot", "robot"], name="t", extra=extra or {})
    return ArrayGeometry(SPEC, layout, BUFFER)


def one_robot_and(kind: str, xy, extra: dict | None = None) -> ArrayGeometry:
    """Robot 0 at the origin and one obstacle (``kind``) at ``xy`` mm."""
    layout = Layout(np.array([0, 100]), np.array([[0.0, 0.0], xy], dtype=float),
                    ["robot", kind], name="t", extra=extra or {})
    return ArrayGeometry(SPEC, layout, BUFFER)


def reach_out(geom: ArrayGeometry, greed: float, phobia: float, md: float | None = None):
    """Robot 0 from the fold to REACH_OUT; any other robot stays at (0, 90).
    Returns (run, start, md); ``md`` defaults to the array's own margin."""
    n = geom.n_robots
    start = np.tile([0.0, 90.0], (n, 1))
    dest = start.copy()
    start[0], dest[0] = FOLD, REACH_OUT
    movable = np.zeros(n, bool)
    movable[0] = True
    md = array_max_displacement(geom, STEP) if md is None else md
    run = run_array(geom, start, dest, movable, step_deg=STEP, max_steps=1500, md=md,
                    greed=greed, phobia=phobia, seed=3)
    return run, start, md


def reached(run) -> bool:
    return bool(np.allclose(run.final[0], REACH_OUT, atol=1e-9))


# -- per-robot values block (or free) a move ---------------------------------------------
@pytest.mark.parametrize("greed, phobia", MODES)
@pytest.mark.parametrize("column, values, check", [
    # robot 0's alpha arm 11 mm: its tip would stop 3.8 mm from robot 1's segment (< 4)
    ("alpha_len_mm", ["11.0", ""], lambda g: g.alpha_len[0] == 11.0),
    # robot 1's buffer 5.5 mm: 7.4 mm is less than 2 + 5.5 (+ MD)
    ("buffer_add_mm", ["", "3.5"], lambda g: g.buffer[1] == 5.5),
    # robot 0's fibers 4 mm farther out: its segment runs 0..19 mm, the tip 3.4 mm away
    ("met_x_mm", ["18.314", ""], lambda g: g.seg_start[0] == 0.0 and g.seg_end[0] > 18.99),
], ids=["alpha_len", "buffer_add", "segment_shift"])
def test_per_robot_value_blocks_a_move_the_nominal_robot_makes(column, values, check,
                                                               greed, phobia):
    nominal, per_robot = two_robots(), two_robots({column: values})
    assert nominal.uniform and not per_robot.uniform and check(per_robot)
    md = array_max_displacement(per_robot, STEP)
    # the same margin for both: only the geometry differs
    nom_run, start, _ = reach_out(nominal, greed, phobia, md)
    run, start, _ = reach_out(per_robot, greed, phobia, md)
    assert reached(nom_run)
    # the nominal plan's end collides with the per-robot geometry ...
    assert worst_clearance(per_robot, nom_run.final) < 0.0
    # ... so the per-robot plan stops short of it, and is collision-free
    assert not reached(run)
    check_plan_clear(per_robot, run, start, md)
    check_plan_clear(nominal, nom_run, start, md)


@pytest.mark.parametrize("greed, phobia", MODES)
def test_shifted_fibers_keep_the_segment_from_the_beta_axis(greed, phobia):
    """An obstacle beside robot 0's elbow (6, -3) blocks the nominal segment (0..15 mm
    from the elbow). Fibers measured 4 mm farther out extend the segment to 0..19 mm;
    they do not move its start off the elbow (the production planner keeps every robot's
    segment from its beta axis), so the obstacle blocks the shifted robot as well."""
    nominal = one_robot_and("fiducial", (6.0, -3.0))
    shifted = one_robot_and("fiducial", (6.0, -3.0), {"met_x_mm": ["18.314", ""]})
    assert shifted.seg_start[0] == 0.0 and shifted.seg_end[0] == pytest.approx(19.0)
    md = array_max_displacement(shifted, STEP)
    nom_run, start, _ = reach_out(nominal, greed, phobia, md)
    run, _, _ = reach_out(shifted, greed, phobia, md)
    assert not reached(nom_run) and not reached(run)
    assert worst_clearance(shifted, REACH_OUT[None]) < 0.0
    check_plan_clear(nominal, nom_run, start, md)
    check_plan_clear(shifted, run, start, md)


# -- obstacles: segments and their own buffers -----------------------------------------
@pytest.mark.parametrize("greed, phobia", MODES)
def test_gfa_segment_blocks_where_a_point_at_its_first_end_does_not(greed, phobia):
    """A guide-camera edge from (25.5, 10) to (25.5, -10) passes 3.1 mm beyond robot 0's
    tip at REACH_OUT (< 2 + 1.5): blocked. A fiducial at (25.5, 10) is 10.5 mm away."""
    point = one_robot_and("fiducial", (25.5, 10.0))
    edge = one_robot_and("gfa", (25.5, 10.0), {"x2_mm": ["", "25.5"], "y2_mm": ["", "-10"]})
    np.testing.assert_array_equal(edge.fid_end_xy, [[25.5, -10.0]])
    md = array_max_displacement(edge, STEP)
    point_run, start, _ = reach_out(point, greed, phobia, md)
    run, _, _ = reach_out(edge, greed, phobia, md)
    assert reached(point_run) and not reached(run)
    assert worst_clearance(edge, point_run.final) < 0.0
    check_plan_clear(edge, run, start, md)
    check_plan_clear(point, point_run, start, md)


@pytest.mark.parametrize("greed, phobia", MODES)
def test_obstacle_buffer_of_the_obstacle_is_used(greed, phobia):
    """A fiducial at (25.5, -4) is 5.06 mm from robot 0's tip at REACH_OUT: clear with the
    spec's keep-out radius 1.5 mm, not with its own 3.5 mm."""
    plain = one_robot_and("fiducial", (25.5, -4.0))
    wide = one_robot_and("fiducial", (25.5, -4.0), {"obstacle_buffer_mm": ["", "3.5"]})
    md = array_max_displacement(wide, STEP)
    plain_run, start, _ = reach_out(plain, greed, phobia, md)
    run, _, _ = reach_out(wide, greed, phobia, md)
    assert reached(plain_run) and not reached(run)
    check_plan_clear(wide, run, start, md)


# -- nominal values in columns change nothing; the margin --------------------------------
@pytest.mark.parametrize("greed, phobia", MODES)
def test_columns_at_the_spec_values_give_the_nominal_run(greed, phobia):
    """Columns that repeat the spec make a uniform geometry and the very same run."""
    base = Layout.hex_grid_positions(19, SPEC.pitch_mm)
    n = base.n_robots
    cols = Layout(base.ids, base.xy, base.kinds, name="t",
                  extra={"alpha_len_mm": [str(SPEC.alpha_length_mm)] * n,
                         "buffer_add_mm": ["0"] * n})
    geoms = [ArrayGeometry(SPEC, lay, BUFFER) for lay in (base, cols)]
    assert geoms[1].uniform
    md = array_max_displacement(geoms[0], STEP)
    targets = random_targets(geoms[0], np.random.default_rng(2), margin_mm=md)
    fold = np.tile(FOLD, (n, 1))
    runs = [run_array(g, targets, fold, np.ones(n, bool), step_deg=STEP, max_steps=1500,
                      md=md, greed=greed, phobia=phobia, seed=4) for g in geoms]
    assert runs[0].ev_robot.size > n
    for name in ("final", "ev_robot", "ev_step", "ev_angles"):
        np.testing.assert_array_equal(getattr(runs[0], name), getattr(runs[1], name))
    assert runs[0].n_steps == runs[1].n_steps


def test_array_margin_covers_the_longest_arm():
    nominal = two_robots()
    spec = SPEC
    assert array_max_displacement(nominal, STEP) == max_displacement(
        spec.alpha_length_mm, spec.beta_length_mm, float(nominal.seg_end.max()), STEP)
    longer = two_robots({"alpha_len_mm": ["", "11.0"]})
    shifted = two_robots({"met_x_mm": ["", "18.314"]})
    assert array_max_displacement(longer, STEP) == pytest.approx(
        max_displacement(11.0, spec.beta_length_mm, 15.0, STEP))
    assert array_max_displacement(shifted, STEP) == pytest.approx(
        max_displacement(spec.alpha_length_mm, spec.beta_length_mm, 19.0, STEP))
    assert array_max_displacement(longer, STEP) > array_max_displacement(nominal, STEP)


def test_solver_plans_with_the_array_margin():
    """plan_reconfiguration uses (and reports) the margin of the longest arm."""
    geom = two_robots({"alpha_len_mm": ["9.0", ""]})
    targets = np.array([[0.0, 60.0], [180.0, 60.0]])
    assert worst_clearance(geom, targets) > 1.0
    settings = PlannerSettings(algorithm="greedy", step_deg=STEP, resolve="replace")
    plan = plan_reconfiguration(geom, targets, settings, np.random.default_rng(0))
    md = array_max_displacement(geom, STEP)
    assert plan.metrics["max_displacement_mm"] == md
    assert md > array_max_displacement(two_robots(), STEP)
    assert plan.metrics["n_deadlocked"] == 0
