"""Small hand-built inputs shared by the twin tests (sim, render, record).

Angles in degrees (alpha, beta), times in seconds, robots by layout id.
"""
from __future__ import annotations

import numpy as np

from rfp_twin.models.layout import Layout
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.twin.sim import simulate

#: The SDSS-V folded configuration (alpha, beta), deg.
FOLD = (10.0, 170.0)


def centre_robot(layout: Layout) -> int:
    """Id of the robot nearest the layout centre."""
    return int(layout.robot_ids[np.argmin(np.hypot(*layout.robot_xy.T))])


def right_neighbour(layout: Layout, pitch_mm: float = 22.4) -> int:
    """Id of the robot (or fiducial) nearest (pitch_mm, 0) mm: the centre's +x neighbour."""
    return int(layout.ids[np.argmin(np.hypot(layout.xy[:, 0] - pitch_mm, layout.xy[:, 1]))])


def moves_trajectory(layout: Layout, moves: dict) -> Trajectory:
    """Everyone holds the fold except ``moves``: id -> (times s, alpha list, beta list)."""
    ta, aa, tb, ab = [], [], [], []
    for rid in layout.robot_ids:
        t, a, b = moves.get(int(rid), ([0.0], [FOLD[0]], [FOLD[1]]))
        ta.append(t)
        aa.append(a)
        tb.append(t)
        ab.append(b)
    return Trajectory.from_breakpoints(layout.robot_ids, ta, aa, tb, ab)


def colliding_trajectory(layout: Layout) -> Trajectory:
    """The centre robot unfolds straight towards its +x neighbour (22.4 mm away) in 6 s,
    (10, 170) -> (0, 0) deg; the neighbour's folded beta arm lies across the path."""
    return moves_trajectory(layout, {centre_robot(layout): ([0.0, 6.0], [10.0, 0.0],
                                                            [170.0, 0.0])})


def swing_trajectory(layout: Layout) -> tuple[int, Trajectory]:
    """(centre id, trajectory): the centre robot turns alpha 10 -> 100 deg in 3 s
    (30 deg/s), beta folded; the others hold the fold."""
    c = centre_robot(layout)
    return c, moves_trajectory(layout, {c: ([0.0, 3.0], [10.0, 100.0], [170.0, 170.0])})


def colliding_run(twin):
    """(trajectory, SimReport with its record) of :func:`colliding_trajectory` on ``twin``
    (a :class:`rfp_twin.models.mjcf.TwinModel`)."""
    traj = colliding_trajectory(twin.layout)
    return traj, simulate(twin, traj)
