"""Small hand-built inputs shared by the twin tests (sim, render, record)."""
from __future__ import annotations

import numpy as np

from models.layout import Layout
from models.trajectory import Trajectory

#: The SDSS-V folded configuration (alpha, beta), deg.
FOLD = (10.0, 170.0)


def centre_robot(layout: Layout) -> int:
    """Id of the robot nearest the layout centre."""
    return int(layout.robot_ids[np.argmin(np.hypot(*layout.robot_xy.T))])


def moves_trajectory(layout: Layout, moves: dict) -> Trajectory:
    """Everyone holds the fold except ``moves``: id -> (times, alpha list, beta list)."""
    ta, aa, tb, ab = [], [], [], []
    for rid in layout.robot_ids:
        t, a, b = moves.get(int(rid), ([0.0], [FOLD[0]], [FOLD[1]]))
        ta.append(t)
        aa.append(a)
        tb.append(t)
        ab.append(b)
    return Trajectory.from_breakpoints(layout.robot_ids, ta, aa, tb, ab)
