"""Toy robots for the roadmap planner tests (tests/planners/roadmap/test_*.py).

Points on a line (1 joint) or in the plane (2 joints), with obstacles given directly as
regions of state-time: nothing here knows alpha/beta arms. Units: joint units and time
units of the toys (speed 1 per time unit).
"""
from __future__ import annotations

import numpy as np

from rfp_twin.planners.roadmap import Arm, ArmTrajectory, RoadmapSettings

RNG = np.random.default_rng
#: Two toy robots in the plane collide when their points are closer than this.
R_TOY = 1.0


def never(q):
    return np.zeros(len(q), dtype=bool)


def line_arm(collides, start=0.0, goal=10.0, t_static=30.0, **kw) -> Arm:
    """A point on a line, speed 1 per time unit: one action moves it by one unit. Its
    roadmap grid is the goal alone, so with ``direct_only`` it has one path, one edge."""
    return Arm(start=np.array([start]), goal=np.array([goal]), vmax=np.array([1.0]),
               forbidden=never, collides=collides, lower=np.array([goal]), upper=np.array([goal]),
               t_static=t_static, **kw)


def direct_only(**kw) -> RoadmapSettings:
    """One straight edge (see ``line_arm``)."""
    base = dict(dt=1.0, grid=(1,), n_random_edges=0, max_paths=1)
    base.update(kw)
    return RoadmapSettings(**base)


def actions(tr: ArmTrajectory, dt: float = 1.0) -> str:
    """The motion of each dt as a string: F forward, S stop, B backward (1-D)."""
    t = np.arange(tr.times[0], tr.t_end + 1e-9, dt)
    d = np.diff(tr.at(t)[:, 0])
    return "".join("F" if x > 1e-9 else "B" if x < -1e-9 else "S" for x in d)


def region(q_lo, q_hi, t_lo, t_hi):
    """Obstacle-time region: the points q_lo <= q <= q_hi collide for t_lo <= t <= t_hi."""
    def hit(q, t):
        return (q[:, 0] >= q_lo) & (q[:, 0] <= q_hi) & (t >= t_lo) & (t <= t_hi)
    return hit


def union(*fs):
    return lambda q, t: np.any([f(q, t) for f in fs], axis=0)


def fig10_world():
    """A wall ahead until t = 12 (q >= 5) and a blocker sweeping q in [3, 4] at t 6-8:
    an arm waiting in front of the wall must back off and come again (Sabater 2018 Fig. 10)."""
    return union(region(5.0, 10.0, 0.0, 11.5), region(3.0, 4.0, 6.0, 8.0))


def plane_arm(start, goal, collides=None, forbidden=never, **kw) -> Arm:
    return Arm(start=np.asarray(start, float), goal=np.asarray(goal, float),
               vmax=np.array([1.0, 1.0]), forbidden=forbidden,
               collides=collides or (lambda q, t: np.zeros(len(q), bool)),
               lower=np.array([0.0, 0.0]), upper=np.array([10.0, 10.0]), **kw)


def vertex_trap():
    """One path, (0, 0) -> (5, 5) -> (10, 0) (the direct line is forbidden). Past x = 5.5
    everything is blocked until t = 15 and the vertex itself is hit at t 7-12: arriving
    at the vertex at t = 5 and waiting there is fatal. Returns (arm, collides)."""
    def hit(q, t):
        at_vertex = (np.hypot(q[:, 0] - 5.0, q[:, 1] - 5.0) < 0.5) & (t >= 7) & (t <= 12)
        return at_vertex | ((q[:, 0] > 5.5) & (t < 15))

    arm = Arm(start=np.zeros(2), goal=np.array([10.0, 0.0]), vmax=np.ones(2),
              forbidden=lambda q: (q[:, 1] < 1.0) & (q[:, 0] > 3.0) & (q[:, 0] < 7.0),
              collides=hit, lower=np.array([10.0, 0.0]), upper=np.array([10.0, 0.0]),
              t_static=15.0, extra_vertices=np.array([[5.0, 5.0]]))
    return arm, hit


def toy_world(tasks):
    """Point robots in the plane: ``make_arm(i, planned)`` gives arm i, whose collides()
    sees the trajectories in ``planned`` (holding their ends) as moving obstacles."""
    def make_arm(i, planned):
        start, goal = tasks[i]

        def collides(q, t):
            hit = np.zeros(len(q), dtype=bool)
            for tr in planned.values():
                hit |= np.hypot(*(q - tr.at(t)).T) < R_TOY
            return hit
        ends = [tr.t_end for tr in planned.values()]
        return plane_arm(start, goal, collides, t_static=max(ends, default=0.0))
    return make_arm


def min_distance(trs, t):
    return min(np.hypot(*(a.at(t) - b.at(t)).T).min()
               for k, a in enumerate(trs) for b in trs[k + 1:])
