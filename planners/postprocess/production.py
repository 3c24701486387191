"""SDSS-V production's post-processing of a stepwise plan: what its controller sends.

SDSS-V's controller (jaeger) turns kaiju's stepwise paths into firmware trajectories with
kaiju's ``getPathPair`` and these settings (jaeger ``etc/jaeger_APO.yml``, the same at
LCO): output speed 2 RPM (12 deg/s on both axes), ``smooth_points`` 21, RDP epsilon
``epsilon_factor`` 2 x the 0.1 deg step, ``path_delay`` 1 s, ``collision_shrink`` 0.08 mm
(passed, but kaiju 1.4.1 does not re-check the smoothed paths). Per robot and axis:

1. the angle at every planner step, padded with ``smooth_points`` copies of its first
   and last value at each end;
2. a Savitzky-Golay filter, window ``smooth_points``, cubic (:func:`scipy.signal.savgol_filter`);
3. Ramer-Douglas-Peucker on the points (step, angle), perpendicular distance,
   ``epsilon`` in those units (the ``simplification`` package, as kaiju uses);
4. time = step x step_deg / speed; the path delay is added by the firmware's start.

The planner's direction matters: kaiju plans targets -> fold (``toDestination``) and
jaeger sends its reverse (``fromDestination``: time ``t_end - t``, points reversed) to
unfold. :func:`production_trajectories` takes the plan in the direction it was planned
and returns both. No clearance is guaranteed: the smoothing moves the arms off the
planned, checked paths, and the RDP keeps no angle bound tighter than ``epsilon``;
the independent checker measures what is left.

Units: deg, s, planner steps. Trajectories start at t = 0 (the path delay is a
separate figure, as every trajectory of the twin).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import savgol_filter
from simplification.cutil import simplify_coords_idx

from rfp_twin.models.errors import SpecError
from rfp_twin.models.trajectory import Trajectory


@dataclass(frozen=True)
class ProductionSettings:
    """jaeger's ``kaiju`` settings for ``getPathPair`` (defaults: APO and LCO).

    speed_rpm : output speed of both axes, RPM (2 RPM = 12 deg/s)
    smooth_points : Savitzky-Golay window and end padding, points (odd, >= 5)
    epsilon_factor : RDP epsilon in planner steps (epsilon = factor x step_deg)
    path_delay_s : time before the first point, s
    collision_shrink_mm : buffer shrink jaeger passes for a check of the smoothed paths
    """

    speed_rpm: float = 2.0
    smooth_points: int = 21
    epsilon_factor: float = 2.0
    path_delay_s: float = 1.0
    collision_shrink_mm: float = 0.08

    def __post_init__(self) -> None:
        if not (np.isfinite(self.speed_rpm) and 0.0 < self.speed_rpm <= 3.0):
            raise SpecError(f"production speed_rpm {self.speed_rpm!r}; allowed: (0, 3] RPM "
                            "(the robots' maximum output speed)")
        if self.smooth_points < 5 or self.smooth_points % 2 == 0:
            raise SpecError(f"production smooth_points {self.smooth_points!r}; allowed: an odd "
                            "integer >= 5 (cubic Savitzky-Golay window)")
        if not (np.isfinite(self.epsilon_factor) and self.epsilon_factor >= 0.0):
            raise SpecError(f"production epsilon_factor {self.epsilon_factor!r}; allowed: >= 0")

    @property
    def speed_deg_s(self) -> float:
        """Output speed, deg/s."""
        return self.speed_rpm * 360.0 / 60.0


def production_axis(angles: np.ndarray, step_deg: float, settings: ProductionSettings
                    ) -> tuple[np.ndarray, np.ndarray]:
    """One axis: (n_steps + 1,) angles at every planner step, deg -> kept
    ``(times s, angles deg)`` of the smoothed and simplified path (steps 1-4 above)."""
    k = settings.smooth_points
    padded = np.concatenate([np.full(k, angles[0]), angles, np.full(k, angles[-1])])
    steps = np.arange(padded.size, dtype=np.float64)
    smooth = savgol_filter(padded, k, polyorder=3)
    idx = np.asarray(simplify_coords_idx(np.column_stack([steps, smooth]),
                                         settings.epsilon_factor * step_deg), dtype=np.int64)
    return steps[idx] * step_deg / settings.speed_deg_s, smooth[idx]


def production_trajectories(plan, settings: ProductionSettings | None = None
                            ) -> tuple[Trajectory, Trajectory]:
    """``(to_destination, from_destination)`` of a plan given in the direction it was
    planned (:class:`rfp_twin.planners.plan.Plan`; kaiju: targets -> fold), as jaeger
    builds them. Robots that do not move keep one constant point pair."""
    settings = settings or ProductionSettings()
    n_steps = int(plan.n_steps)
    grid = np.arange(n_steps + 1, dtype=np.float64)
    to_t, to_a, back_t, back_a = ([], []), ([], []), ([], []), ([], [])
    for i in range(plan.n_robots):
        steps, ang = plan.path(i)
        for ax in (0, 1):
            dense = np.interp(grid, steps, ang[:, ax])
            t, a = production_axis(dense, plan.step_deg, settings)
            to_t[ax].append(t)
            to_a[ax].append(a)
            back_t[ax].append(np.abs(t - t[-1])[::-1])
            back_a[ax].append(a[::-1])
    to = Trajectory.from_breakpoints(plan.robot_ids, to_t[0], to_a[0], to_t[1], to_a[1])
    back = Trajectory.from_breakpoints(plan.robot_ids, back_t[0], back_a[0], back_t[1], back_a[1])
    return to, back
