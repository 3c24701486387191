"""What the probe-arm planner returns: per-arm rows in the form of Sabater 2018 Tables 1-2.

Units: s, deg; steps are motion actions of ``dt_s``. A plan states each arm's
start-stop cycles (the MIRADAS controllers move along straight joint-space segments and
stop at each segment's end, Sect. 3.2.1).
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np


@dataclass
class ArmRow:
    """One arm's line of Tables 1-2.

    Attributes
    ----------
    arm, priority : int (priority n = planned first, 1 = last)
    est_travel_s : float, Eq. 5 estimate of the direct route, s
    path : str, route followed ("Start-end", "Start-A-end": A an intermediate vertex)
    steps : int, arrival time in steps (n dt); n_go / n_stop: steps moving / standing
    start_stop : int, start-stop cycles (vertex stops included)
    optimum_steps : int, the direct route at full speed, steps
    roadmap_routes : int, routes of the arm's roadmap before any is discarded
    roadmap_paths, roadmap_min_steps, roadmap_mean_steps : the arm's usable routes
        (within the travel-time limit, clear of the ZoA) and their step counts
    checks : int, collision queries Collision(q, t) against higher-priority arms
    seconds : float, planning time of this arm
    """

    arm: int
    priority: int
    est_travel_s: float
    optimum_steps: int
    roadmap_routes: int
    roadmap_paths: int
    roadmap_min_steps: int
    roadmap_mean_steps: float
    checks: int
    seconds: float
    path: str = "-"
    steps: int = -1
    n_go: int = 0
    n_stop: int = 0
    start_stop: int = 0


@dataclass
class ProbePlan:
    """Outcome of :func:`rfp_twin.planners.roadmap.probe.plan_probe_arms`.

    Attributes
    ----------
    kind : ProbeArmKind
    start, goal : (n_arms, 2) deg
    settings : ProbePlanSettings
    order : list of arm indices, highest priority first
    rows : list of ArmRow, in planning order (up to the failing arm)
    trajectories : {arm: ArmTrajectory} (times s, configs deg), every arm when success,
        the arms planned before the failing one otherwise
    success : bool; failed_arm : the arm with no trajectory, or None
    seconds : float, planning time of the whole plan (every pass)
    passes : int, prioritized passes run (1 + re-plans with another order)
    all_checks : int, collision queries of every pass
    """

    kind: object
    start: np.ndarray
    goal: np.ndarray
    settings: object
    order: list
    rows: list
    trajectories: dict
    success: bool
    failed_arm: int | None
    seconds: float
    passes: int = 1
    all_checks: int = 0

    @property
    def checks(self) -> int:
        return int(sum(r.checks for r in self.rows))

    @property
    def makespan_steps(self) -> int:
        """Arrival of the last arm, steps (-1 without a plan)."""
        return max((r.steps for r in self.rows), default=-1) if self.success else -1

    @property
    def makespan_s(self) -> float:
        return self.makespan_steps * self.settings.dt_s if self.success else float("nan")

    @property
    def max_start_stop(self) -> int:
        return max((r.start_stop for r in self.rows), default=0)

    def at(self, t: np.ndarray) -> np.ndarray:
        """(len(t), n_arms, 2) poses at times ``t`` s (each arm holds its goal after its
        end). Needs a successful plan."""
        t = np.atleast_1d(np.asarray(t, dtype=np.float64))
        out = np.empty((t.size, len(self.start), 2))
        for i, tr in self.trajectories.items():
            out[:, i] = tr.at(t)
        return out

    def breakpoints(self) -> dict[int, tuple[np.ndarray, np.ndarray]]:
        """{arm: (times (k,) s, configs (k, 2) deg)} of every arm."""
        return {i: (tr.times.copy(), tr.configs.copy()) for i, tr in sorted(self.trajectories.items())}

    def summary(self) -> dict:
        """Plain-data summary (JSON-ready)."""
        return {"success": self.success, "failed_arm": self.failed_arm,
                "seconds": self.seconds, "checks": self.checks, "passes": self.passes,
                "all_checks": self.all_checks,
                "makespan_steps": self.makespan_steps, "dt_s": self.settings.dt_s,
                "max_start_stop": self.max_start_stop,
                "rows": [asdict(r) for r in self.rows]}

    def tables(self) -> str:
        """Tables 1 and 2 of Sabater 2018 for this plan, as text."""
        t1 = ["Table 1 form: running time and collision checks",
              f"{'arm':>4} {'priority':>8} {'time (s)':>10} {'checks':>8}"]
        for r in self.rows:
            t1.append(f"{r.arm:>4} {r.priority:>8} {r.seconds:>10.3f} {r.checks:>8}")
        n = max(1, len(self.rows))
        t1.append(f"total time {self.seconds:.3f} s, average {self.seconds / n:.3f} s; "
                  f"total checks {self.checks}, average {self.checks / n:.0f}")
        t2 = ["Table 2 form: trajectories found (steps of "
              f"{self.settings.dt_s:g} s; routes: usable / in the roadmap)",
              f"{'arm':>4} {'prio':>4} {'est (s)':>8} {'path':>14} {'n':>3} {'go':>3} "
              f"{'stop':>4} {'ss':>3} {'opt':>4} {'routes':>7} {'min':>4} {'avg':>6}"]
        for r in self.rows:
            t2.append(f"{r.arm:>4} {r.priority:>4} {r.est_travel_s:>8.2f} {r.path:>14} "
                      f"{r.steps:>3} {r.n_go:>3} {r.n_stop:>4} {r.start_stop:>3} "
                      f"{r.optimum_steps:>4} {f'{r.roadmap_paths}/{r.roadmap_routes}':>7} "
                      f"{r.roadmap_min_steps:>4} "
                      f"{r.roadmap_mean_steps:>6.2f}")
        t2.append(f"makespan {self.makespan_steps} steps = {self.makespan_s:g} s; "
                  f"most start-stop cycles of an arm {self.max_start_stop}"
                  if self.success else f"failed at arm {self.failed_arm}")
        return "\n".join(t1 + [""] + t2)
