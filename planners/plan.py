"""Plan: the output of a stepwise planner, on a common step clock.

Each robot's path is a list of breakpoints (step index, alpha deg, beta deg); linear
interpolation between them on the step clock is exactly the stepwise motion. Paths are
stored as CSR arrays so a 500-robot plan is three numpy arrays.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

#: Per-robot outcome of planning.
REACHED = "reached"        # kept its target and the plan reaches it
REPLACED = "replaced"      # its target was replaced to resolve a deadlock
DEADLOCKED = "deadlocked"  # never reached its destination
OFFLINE = "offline"        # does not move; the others plan around it
STATUSES = (REACHED, REPLACED, DEADLOCKED, OFFLINE)


@dataclass(frozen=True)
class Plan:
    """Per-robot stepwise paths on a common step clock, in the executed direction.

    Attributes
    ----------
    robot_ids : (n,) int64
    step_deg : float, planner angular step, deg
    step_s : float, duration of one step at the robot speed, s
    n_steps : int, length of the plan in steps
    path_ptr : (n + 1,) int64, CSR offsets into the breakpoint arrays
    path_step : (m,) float64, step index of each breakpoint (non-decreasing per robot)
    path_angles : (m, 2) float64, (alpha, beta) deg at each breakpoint
    status : (n,) str, one of STATUSES
    targets : (n, 2) deg, the targets the plan serves (after replacements)
    original_targets : (n, 2) deg, the targets asked for
    metrics : dict, efficiency, convergence, timings ...
    """

    robot_ids: np.ndarray
    step_deg: float
    step_s: float
    n_steps: int
    path_ptr: np.ndarray
    path_step: np.ndarray
    path_angles: np.ndarray
    status: np.ndarray
    targets: np.ndarray
    original_targets: np.ndarray
    metrics: dict = field(default_factory=dict)

    @property
    def n_robots(self) -> int:
        return int(self.robot_ids.shape[0])

    @property
    def complete(self) -> bool:
        """True when every robot that can move reaches its destination."""
        return not np.any(self.status == DEADLOCKED)

    def path(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        """Breakpoints of robot index i: steps (k,), angles (k, 2)."""
        s = slice(self.path_ptr[i], self.path_ptr[i + 1])
        return self.path_step[s], self.path_angles[s]

    def start(self) -> np.ndarray:
        """(n, 2) configuration at step 0, deg."""
        return self.path_angles[self.path_ptr[:-1]]

    def end(self) -> np.ndarray:
        """(n, 2) configuration at the last step, deg."""
        return self.path_angles[self.path_ptr[1:] - 1]

    def reversed(self) -> Plan:
        """The same motion played backwards (step s -> n_steps - s)."""
        steps = np.empty_like(self.path_step)
        angles = np.empty_like(self.path_angles)
        for i in range(self.n_robots):
            s = slice(self.path_ptr[i], self.path_ptr[i + 1])
            steps[s] = self.n_steps - self.path_step[s][::-1]
            angles[s] = self.path_angles[s][::-1]
        return replace(self, path_step=steps, path_angles=angles)

    def angles_at(self, steps: np.ndarray) -> np.ndarray:
        """Configurations at (possibly fractional) steps: (len(steps), n, 2) deg."""
        steps = np.asarray(steps, dtype=np.float64)
        out = np.empty((steps.size, self.n_robots, 2))
        for i in range(self.n_robots):
            st, ang = self.path(i)
            out[:, i, 0] = np.interp(steps, st, ang[:, 0])
            out[:, i, 1] = np.interp(steps, st, ang[:, 1])
        return out


def build_paths(n: int, ev_robot: np.ndarray, ev_step: np.ndarray, ev_angles: np.ndarray,
                start: np.ndarray, end: np.ndarray, n_steps: int):
    """CSR paths from kernel breakpoints, adding each robot's start and end points.

    Returns path_ptr (n+1,), path_step (m,), path_angles (m, 2).
    """
    order = np.lexsort((ev_step, ev_robot))
    ev_robot = ev_robot[order]
    ev_step = ev_step[order].astype(np.float64)
    ev_angles = ev_angles[order]
    # every robot gets (0, start) and (n_steps, end); drop duplicates of those
    robots = np.concatenate([np.arange(n), ev_robot, np.arange(n)])
    steps = np.concatenate([np.zeros(n), ev_step, np.full(n, float(n_steps))])
    angles = np.concatenate([start, ev_angles, end])
    rank = np.concatenate([np.zeros(n), np.ones(ev_robot.size), np.full(n, 2.0)])
    order = np.lexsort((rank, steps, robots))
    robots, steps, angles = robots[order], steps[order], angles[order]
    keep = np.ones(robots.size, dtype=bool)
    same = (robots[1:] == robots[:-1]) & (steps[1:] == steps[:-1])
    keep[1:] &= ~same
    robots, steps, angles = robots[keep], steps[keep], angles[keep]
    keep = _drop_collinear(robots, steps, angles)
    robots, steps, angles = robots[keep], steps[keep], angles[keep]
    ptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(np.bincount(robots, minlength=n), out=ptr[1:])
    return ptr, steps, angles


def _drop_collinear(robots: np.ndarray, steps: np.ndarray, angles: np.ndarray,
                    tol: float = 1e-9) -> np.ndarray:
    """Mask that keeps first/last points per robot and points where the slope changes."""
    keep = np.ones(robots.size, dtype=bool)
    if robots.size < 3:
        return keep
    inner = (robots[1:-1] == robots[:-2]) & (robots[1:-1] == robots[2:])
    dt0 = steps[1:-1] - steps[:-2]
    dt1 = steps[2:] - steps[1:-1]
    s0 = (angles[1:-1] - angles[:-2]) / np.maximum(dt0, 1e-300)[:, None]
    s1 = (angles[2:] - angles[1:-1]) / np.maximum(dt1, 1e-300)[:, None]
    straight = np.all(np.abs(s0 - s1) <= tol, axis=1) & (dt0 > 0) & (dt1 > 0)
    keep[1:-1] = ~(inner & straight)
    return keep
