"""Plan: the output of a stepwise planner, on a common step clock.

Each robot's path is a list of breakpoints (step index, alpha deg, beta deg); linear
interpolation between them on the step clock is exactly the stepwise motion. Paths are
stored as CSR arrays so a 500-robot plan is three numpy arrays.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from numba import njit

from rfp_twin.models.kernel_cache import DELIVERY, warm_up

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

    The kernel writes each robot's breakpoints in step order, so a counting sort by robot
    keeps each robot's points in time order. Returns path_ptr (n+1,), path_step (m,), path_angles (m, 2).
    """
    return _build_paths(n, np.ascontiguousarray(ev_robot, dtype=np.int64),
                        np.ascontiguousarray(ev_step, dtype=np.int64),
                        np.ascontiguousarray(ev_angles, dtype=np.float64),
                        np.ascontiguousarray(start, dtype=np.float64),
                        np.ascontiguousarray(end, dtype=np.float64), int(n_steps))


@njit(cache=True)
def _build_paths(n, ev_robot, ev_step, ev_angles, start, end, n_steps):
    count = np.ones(n, dtype=np.int64) * 2          # start and end point
    for e in range(ev_robot.shape[0]):
        count[ev_robot[e]] += 1
    ptr = np.zeros(n + 1, dtype=np.int64)
    for i in range(n):
        ptr[i + 1] = ptr[i] + count[i]
    steps = np.empty(ptr[n])
    angles = np.empty((ptr[n], 2))
    fill = ptr[:-1].copy()
    for i in range(n):
        steps[fill[i]] = 0.0
        angles[fill[i], 0] = start[i, 0]
        angles[fill[i], 1] = start[i, 1]
        fill[i] += 1
    for e in range(ev_robot.shape[0]):
        i = ev_robot[e]
        k = fill[i]
        if ev_step[e] == steps[k - 1]:
            k -= 1                                   # same step as the previous point
        steps[k] = ev_step[e]
        angles[k, 0] = ev_angles[e, 0]
        angles[k, 1] = ev_angles[e, 1]
        fill[i] = k + 1
    for i in range(n):
        k = fill[i]
        if steps[k - 1] == n_steps:
            k -= 1
        steps[k] = n_steps
        angles[k, 0] = end[i, 0]
        angles[k, 1] = end[i, 1]
        fill[i] = k + 1
    # compact away the slots freed by merged duplicates
    out_ptr = np.zeros(n + 1, dtype=np.int64)
    for i in range(n):
        out_ptr[i + 1] = out_ptr[i] + (fill[i] - ptr[i])
    out_steps = np.empty(out_ptr[n])
    out_angles = np.empty((out_ptr[n], 2))
    for i in range(n):
        m = fill[i] - ptr[i]
        out_steps[out_ptr[i]:out_ptr[i] + m] = steps[ptr[i]:ptr[i] + m]
        out_angles[out_ptr[i]:out_ptr[i] + m] = angles[ptr[i]:ptr[i] + m]
    return out_ptr, out_steps, out_angles


# called from Python once the planner has run (loaded ahead from numba's cache)
warm_up(DELIVERY, _build_paths)
