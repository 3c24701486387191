"""The buffer a trajectory actually kept: the largest 2D buffer at which it would pass.

Under the 2D capsule rule robots ``i, j`` pass when their beta segments stay more than
``buffer_i + buffer_j`` apart, with ``buffer_i = b + add_i`` (the run's buffer ``b`` plus
the robot's ``buffer_add_mm``); a robot and an obstacle when their distance stays above
``b + add_i + obstacle_buffer``. From a 2D check's per-pair smallest distances ``d``:

    robot pairs:     b_kept = min (d_ij - add_i - add_j) / 2
    obstacle pairs:  b_kept = min (d_if - add_i - obstacle_buffer_f)

and the trajectory's kept buffer is the smaller of the two. When the segment itself depends
on the buffer (SDSS-V's production rule: its far end is ``16.2 - (sqrt(b^2 + 0.3^2) -
0.55)`` mm, shorter for a larger buffer) the distances move with ``b``; the kept buffer is
then the fixed point, found by re-checking the closest pairs of each kind at the value just
found (distances change by at most the change of the segment end, which is at most the
change of ``b``, so pairs farther than that from their kind's minimum cannot become it). The distances are
the 2D check's sampled minima, within its refinement tolerance (0.005 mm for close pairs).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rfp_twin.models.errors import RfpError
from rfp_twin.models.layout import Layout
from rfp_twin.models.robot import RobotSpec
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.validation.checker2d import CheckReport, check_trajectory

#: The fixed point is settled when two rounds differ by less than this, mm.
SETTLED_MM = 1e-4
#: Rounds of re-checks at most.
MAX_ROUNDS = 6


@dataclass(frozen=True)
class KeptBuffer:
    """The largest buffer at which a trajectory passes the 2D rule, mm.

    Attributes
    ----------
    buffer_mm : float
        ``min(robot_mm, obstacle_mm)``.
    robot_mm, obstacle_mm : float
        From robot-robot pairs and from robot-obstacle pairs (``inf`` with none), both
        with the segment at ``buffer_mm``.
    robot_pair, obstacle_pair : tuple of int
        The pair that sets each (robot ids; robot id and obstacle id).
    rounds : int
        2D re-checks made for the fixed point (0 when the segment does not depend on the
        buffer).
    """

    buffer_mm: float
    robot_mm: float
    obstacle_mm: float
    robot_pair: tuple[int, int] | None
    obstacle_pair: tuple[int, int] | None
    rounds: int = 0

    def to_dict(self) -> dict:
        def num(v: float):
            return float(v) if math.isfinite(v) else None
        return {"buffer_mm": num(self.buffer_mm), "robot_mm": num(self.robot_mm),
                "obstacle_mm": num(self.obstacle_mm),
                "robot_pair": list(self.robot_pair) if self.robot_pair else None,
                "obstacle_pair": list(self.obstacle_pair) if self.obstacle_pair else None,
                "rounds": int(self.rounds)}


def pair_kept(report: CheckReport) -> tuple[np.ndarray, np.ndarray]:
    """Per robot pair and per obstacle pair, the buffer ``b`` at which that pair's smallest
    distance equals its threshold, mm: ``(robot (p,), obstacle (q,))``."""
    b = float(report.buffer_mm)
    robot = (np.asarray(report.pair_min_distance_mm)
             - (np.asarray(report.pair_threshold_mm) - 2.0 * b)) / 2.0
    obstacle = (np.asarray(report.fiducial_min_distance_mm)
                - (np.asarray(report.fiducial_threshold_mm) - b))
    return robot, obstacle


def _settled(report: CheckReport) -> KeptBuffer:
    robot, obstacle = pair_kept(report)
    r = int(np.argmin(robot)) if robot.size else -1
    o = int(np.argmin(obstacle)) if obstacle.size else -1
    r_mm = float(robot[r]) if r >= 0 else math.inf
    o_mm = float(obstacle[o]) if o >= 0 else math.inf
    return KeptBuffer(min(r_mm, o_mm), r_mm, o_mm,
                      tuple(int(v) for v in report.pair_ids[r]) if r >= 0 else None,
                      tuple(int(v) for v in report.fiducial_pair_ids[o]) if o >= 0 else None)


def kept_buffer(traj: Trajectory, spec: RobotSpec, layout: Layout,
                report: CheckReport) -> KeptBuffer:
    """The largest buffer at which ``traj`` passes the 2D rule of ``spec`` (module docstring),
    from ``report`` (the 2D check of ``traj`` at any buffer) and, under a buffer-dependent
    segment, a few re-checks of the closest pairs."""
    kept = _settled(report)
    if spec.segment_end(1.0) == spec.segment_end(2.0) or not math.isfinite(kept.buffer_mm):
        return kept
    rounds = 0
    current = report
    while rounds < MAX_ROUNDS:
        b = kept.buffer_mm
        if b <= 0.0 or abs(b - current.buffer_mm) < SETTLED_MM:
            break
        robot, obstacle = pair_kept(current)
        margin = abs(b - current.buffer_mm) + 0.01
        near = np.concatenate([current.pair_ids[robot <= kept.robot_mm + margin].reshape(-1),
                               current.fiducial_pair_ids[obstacle <= kept.obstacle_mm + margin][:, 0]])
        try:
            again = check_trajectory(traj, spec, layout, b, focus_ids=np.unique(near))
        except RfpError:          # a buffer the checker does not take (e.g. >= pitch / 2)
            break
        rounds += 1
        current = again
        new = _settled(again)
        settled = abs(new.buffer_mm - b) < SETTLED_MM
        kept = KeptBuffer(new.buffer_mm, new.robot_mm, new.obstacle_mm, new.robot_pair,
                          new.obstacle_pair, rounds)
        if settled:
            break
    return kept
