"""What one post-processing run produced: :class:`PostprocessReport` and :class:`TimedPath`.

:class:`TimedPath` is the smooth, timed motion that the returned trajectory simplifies
(per group: a time law, a start offset and a slow-down); :class:`PostprocessReport`
holds every figure of the run (units in the field names), and :func:`build_report`
measures them on the returned trajectory and the groups that produced it.

Units: degrees, seconds, mm, plan steps.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np

from rfp_twin.planners.postprocess.groups import group_offsets
from rfp_twin.planners.postprocess.smoothing import SmoothPath, plan_deviation
from rfp_twin.planners.postprocess.timing import pl_kinematics

__all__ = ["TimedPath", "PostprocessReport", "build_report"]


@dataclass(frozen=True)
class TimedPath:
    """The smooth, timed motion that the returned trajectory simplifies.

    Robot ``i`` of group ``g = labels[i]`` is at ``path.evaluate(s)`` with ``s =
    laws[g].s_at((t - offsets[g]) / scales[g])`` at time ``t``.

    Attributes
    ----------
    path : SmoothPath
    labels : (n,) group of each robot
    laws, offsets, scales : dicts keyed by group: TimeLaw, start time (s), slow-down >= 1
    window_steps : (n,) smoothing window each robot ended with, plan steps
    tolerance_deg : (n,) RDP tolerance each robot ended with (largest of its axes), deg
    """

    path: SmoothPath
    labels: np.ndarray
    laws: dict
    offsets: dict
    scales: dict
    window_steps: np.ndarray
    tolerance_deg: np.ndarray

    def sample(self, times) -> np.ndarray:
        """Angles at the given times: (len(times), n, 2) deg."""
        times = np.atleast_1d(np.asarray(times, dtype=np.float64))
        out = np.empty((times.size, self.labels.size, 2))
        for g, law in self.laws.items():
            robots = np.flatnonzero(self.labels == g)
            s = law.s_at((times - self.offsets[g]) / self.scales[g])
            out[:, robots, :] = self.path.evaluate(s, robots, 0)
        return out

    def group_durations(self) -> dict:
        """Duration of each group's motion, s."""
        return {g: law.duration * self.scales[g] for g, law in self.laws.items()}


@dataclass
class PostprocessReport:
    """Every figure of one post-processing run (units in the names).

    ``max_speed_deg_s`` / ``max_accel_deg_s2`` are measured on the returned
    piecewise-linear trajectory (slope; three-point acceleration, see
    :func:`rfp_twin.planners.postprocess.timing.pl_kinematics`), per axis (alpha, beta).
    ``stage_seconds`` holds smooth, group, time, simplify, verify and total (retries
    included in each stage). ``max_slowdown`` is the largest uniform slow-down applied to
    a group to keep its piecewise-linear output within the limits (1 = none; a value
    much above 1 would mean the time law and the path disagree). ``retries`` counts
    verification rounds after the first, ``merges`` group merges, ``tightened`` robots
    whose window and tolerance were halved. ``max_smoothing_deviation_deg`` is the
    largest |smoothed - stepwise| angle at equal plan step (large where robots are free,
    by design), ``max_simplify_deviation_deg`` the largest RDP error (<= the tolerance).
    """

    buffer_mm: float
    budget_mm: float
    verify_buffer_mm: float
    smoothing: str
    window_steps: float
    min_window_steps: float
    tolerance_deg: float
    max_tolerance_used_deg: float
    max_points: int
    sample_s: float
    interaction_mm: float
    align: str
    backend: str
    n_robots: int
    n_groups: int
    largest_group: int
    n_grouped_robots: int
    duration_s: float
    plan_duration_s: float
    speed_limit_deg_s: list
    accel_limit_deg_s2: list
    max_speed_deg_s: list
    max_accel_deg_s2: list
    points_per_axis_median: float
    points_per_axis_max: int
    points_per_axis_mean: float
    max_smoothing_deviation_deg: float
    max_simplify_deviation_deg: float
    verified: bool
    min_clearance_mm: float
    check_rounds: int
    max_slowdown: float
    retries: int
    merges: int
    tightened: int
    collisions_repaired: int
    timing_solvers: dict = field(default_factory=dict)
    timing_fallbacks: int = 0
    presimplify_deg: float = 0.0
    #: Robots pre-simplified at the wiggle tolerance (their paths turn back often).
    n_wiggly_robots: int = 0
    plan_breakpoints: int = 0
    smoothed_breakpoints: int = 0
    stage_seconds: dict = field(default_factory=dict)
    #: Firmware-ready duration / stepwise plan duration.
    duration_ratio: float = math.nan
    #: The groups that set the end, longest first (at most :data:`N_SLOWEST`): robot ids,
    #: their timed duration and the stepwise time at which their last robot stops, s,
    #: and how many of them had their window narrowed around a collision.
    slowest_groups: list = field(default_factory=list)
    #: The smooth timed motion behind the trajectory (not serialised).
    timed: TimedPath | None = field(default=None, repr=False, compare=False)
    #: The verifier's report on the whole returned trajectory, when its last round
    #: checked all of it (not serialised); else None.
    final_check: Any = field(default=None, repr=False, compare=False)

    def to_dict(self) -> dict:
        """JSON-ready figures (everything but ``timed``; non-finite numbers become None)."""
        d = {f.name: getattr(self, f.name) for f in fields(self) if f.name not in ("timed", "final_check")}
        d["stage_seconds"] = dict(d["stage_seconds"])
        d["timing_solvers"] = dict(d["timing_solvers"])
        for k, v in d.items():
            if isinstance(v, float) and not math.isfinite(v):
                d[k] = None
        return d

    def table(self) -> str:
        st = self.stage_seconds
        lines = [
            f"post-processing: {'verified' if self.verified else 'NOT VERIFIED'} at "
            f"{self.verify_buffer_mm:.3f} mm (buffer {self.buffer_mm:.3f} - budget "
            f"{self.budget_mm:.3f} mm), min clearance {self.min_clearance_mm:.4f} mm",
            f"  fold time {self.duration_s:.2f} s (stepwise plan {self.plan_duration_s:.2f} s, "
            f"x {self.duration_ratio:.3f}); "
            f"groups {self.n_groups} (largest {self.largest_group}, "
            f"{self.n_grouped_robots} robots grouped)",
            f"  max |v| {self.max_speed_deg_s[0]:.2f} / {self.max_speed_deg_s[1]:.2f} deg/s "
            f"(limit {self.speed_limit_deg_s[0]:g}), max |a| {self.max_accel_deg_s2[0]:.1f} / "
            f"{self.max_accel_deg_s2[1]:.1f} deg/s^2 (limit {self.accel_limit_deg_s2[0]:g})",
            f"  points per axis median {self.points_per_axis_median:.0f}, max "
            f"{self.points_per_axis_max} (<= {self.max_points}); tolerance "
            f"{self.tolerance_deg:g} deg; retries {self.retries}",
            f"  breakpoints {self.plan_breakpoints} -> {self.smoothed_breakpoints} smoothed "
            f"(pre-simplified within {self.presimplify_deg:g} deg; "
            f"{self.n_wiggly_robots} wiggly robots at the wiggle tolerance)",
            f"  timing: {self.backend} backend, groups by solver "
            + ", ".join(f"{k} {v}" for k, v in sorted(self.timing_solvers.items()))
            + f"; fallbacks {self.timing_fallbacks}",
            "  stages " + ", ".join(f"{k} {v:.3f} s" for k, v in st.items()),
        ]
        for g in self.slowest_groups:
            lines.append(f"  group {g['robots']}: {g['duration_s']:.2f} s (stepwise "
                         f"{g['stepwise_s']:.2f} s, {g['narrowed_robots']} narrowed)")
        return "\n".join(lines)


#: Plan steps between the samples of ``max_smoothing_deviation_deg`` (every step cost
#: 0.26 s on a 500-robot fold). Plan and smoothed path each move at most one step
#: (``step_deg``) per plan step, so the figure can be below the true maximum by at most
#: ``DEVIATION_STRIDE * step_deg`` (0.4 deg at 0.1 deg; a diagnostic, not a check).
DEVIATION_STRIDE = 4
#: Groups listed in :attr:`PostprocessReport.slowest_groups`.
N_SLOWEST = 3


def slowest_groups(plan, groups: dict, narrowed: set, n: int = N_SLOWEST) -> list:
    """The ``n`` longest groups (``groups``: TimedGroup by label; ``narrowed``: robot
    indices whose window was narrowed somewhere), as JSON-ready dicts."""
    out = []
    for g in sorted(groups.values(), key=lambda g: -g.duration)[:n]:
        last = 0.0
        for i in g.robots:
            st, ang = plan.path(int(i))
            moved = np.flatnonzero(np.any(np.diff(ang, axis=0) != 0.0, axis=1))
            if moved.size:
                last = max(last, float(st[moved[-1] + 1]))
        out.append({"robots": [int(r) for r in plan.robot_ids[g.robots]],
                    "duration_s": float(g.duration), "stepwise_s": last * plan.step_s,
                    "narrowed_robots": int(sum(int(i) in narrowed for i in g.robots))})
    return out


def build_report(plan, traj, groups, labels, path, check, spec, buffer_mm, budget_mm,
                 verify_buffer, smoothing, window_steps, window, tolerance_deg, max_points,
                 sample_s, interaction_mm, align, backend, rounds, retries, merges, tightened,
                 repaired, stages, clock) -> PostprocessReport:
    """The report of a finished run (``groups``: :class:`rfp_twin.planners.postprocess.groups.TimedGroup`
    by label; ``check``: the verifier's report on the whole trajectory (re-checks
    merged in), or None when nothing was verified; ``clock``: ``time.perf_counter()`` at the start)."""
    vm = np.zeros(2)
    am = np.zeros(2)
    for ax in range(2):
        for i in range(traj.n_robots):
            v, a = pl_kinematics(traj.times[ax][i], traj.angles[ax][i])
            vm[ax] = max(vm[ax], v)
            am[ax] = max(am[ax], a)
    counts = traj.point_counts()
    sizes = np.bincount(np.unique(labels, return_inverse=True)[1])
    simp_dev = 0.0
    tol_used = 0.0
    for g in groups.values():
        tol_used = max(tol_used, float(g.tol_used.max()) if g.tol_used.size else 0.0)
        for c in range(g.Y.shape[1]):
            m = g.keep[:, c]
            if m.sum() < g.t.size:
                simp_dev = max(simp_dev, float(np.max(np.abs(
                    np.interp(g.t, g.t[m], g.Y[m, c]) - g.Y[:, c]))))
    smooth_dev = float(plan_deviation(plan, path, DEVIATION_STRIDE).max()) if plan.n_robots else 0.0
    tol_robot = np.zeros(plan.n_robots)
    for g in groups.values():
        tol_robot[g.robots] = g.tol_used.reshape(-1, 2).max(axis=1)
    timed = TimedPath(path, labels.copy(), {k: g.law for k, g in groups.items()},
                      group_offsets(groups, align), {k: g.scale for k, g in groups.items()},
                      window.copy(), tol_robot)
    solvers: dict = {}
    for g in groups.values():
        solvers[g.law.solver] = solvers.get(g.law.solver, 0) + 1
    stages = dict(stages)
    stages["total"] = time.perf_counter() - clock
    return PostprocessReport(
        buffer_mm=float(buffer_mm), budget_mm=float(budget_mm), verify_buffer_mm=float(verify_buffer),
        smoothing=smoothing, window_steps=float(window_steps), min_window_steps=float(window.min()),
        tolerance_deg=float(tolerance_deg), max_tolerance_used_deg=tol_used,
        max_points=int(max_points), sample_s=float(sample_s), interaction_mm=float(interaction_mm),
        align=align, backend=backend, n_robots=int(plan.n_robots), n_groups=int(sizes.size),
        largest_group=int(sizes.max()) if sizes.size else 0,
        n_grouped_robots=int(sizes[sizes > 1].sum()),
        duration_s=float(traj.duration), plan_duration_s=float(plan.n_steps * plan.step_s),
        duration_ratio=(float(traj.duration) / (plan.n_steps * plan.step_s)
                        if plan.n_steps > 0 else math.nan),
        speed_limit_deg_s=[float(v) for v in spec.max_speed_deg_s],
        accel_limit_deg_s2=[float(v) for v in spec.max_accel_deg_s2],
        max_speed_deg_s=vm.tolist(), max_accel_deg_s2=am.tolist(),
        points_per_axis_median=float(np.median(counts)) if counts.size else 0.0,
        points_per_axis_max=int(counts.max()) if counts.size else 0,
        points_per_axis_mean=float(counts.mean()) if counts.size else 0.0,
        max_smoothing_deviation_deg=smooth_dev, max_simplify_deviation_deg=simp_dev,
        verified=bool(check is not None and check.ok),
        min_clearance_mm=float(check.min_clearance_mm) if check is not None else math.nan,
        check_rounds=rounds,
        max_slowdown=max((g.scale for g in groups.values()), default=1.0),
        retries=retries, merges=merges, tightened=tightened, collisions_repaired=repaired,
        timing_solvers=solvers, timing_fallbacks=int(solvers.get("fallback", 0)),
        stage_seconds=stages, timed=timed)

