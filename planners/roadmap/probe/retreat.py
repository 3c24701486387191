"""Retreat vertices of probe arms: poses where an arm can wait out of the others' way.

Sabater et al. 2018 (Sect. 9) propose a reserved "garage" location per arm for what
prioritized planning cannot solve; here each arm's roadmap gets a few such poses near its
own start and goal, drawn back out of the field. Units: deg.
"""
from __future__ import annotations

import numpy as np


#: Fractions of the direct route start -> goal added as vertices: the arm may pause there
#: (one start-stop cycle) while another arm passes.
STOPOVERS = (0.25, 0.5, 0.75)


def retreat_poses(kind, start: np.ndarray, goal: np.ndarray,
                  retreat_deg: tuple[float, ...]) -> np.ndarray | None:
    """(k, 2) deg, roadmap vertices where an arm can wait out of the others' way: its
    start and its goal with theta1 raised by each of ``retreat_deg`` (towards the park
    pose's theta1 = 180 deg, which draws the pick-off head back out of the field), and
    the larger of both theta1 raised the same way at the mean theta2; outside the joint
    ranges and the ZoA dropped. None without ``retreat_deg``."""
    if not retreat_deg:
        return None
    hi = kind.joint_limits_deg()[0, 1]
    t1_top = max(start[0], goal[0])
    rows = [(min(hi, base[0] + d), base[1]) for d in retreat_deg for base in (start, goal)]
    rows += [(min(hi, t1_top + d), 0.5 * (start[1] + goal[1])) for d in retreat_deg]
    rows += [tuple(start + f * (goal - start)) for f in STOPOVERS]
    out = np.array(rows, dtype=np.float64)
    return out[~kind.forbidden(out)]
