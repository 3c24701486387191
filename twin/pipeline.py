"""The one reconfiguration pipeline: array + targets -> plan -> post-process -> 2D check.

:class:`Reconfiguration` is the object a user drives end to end, the role kaiju's
``RobotGrid`` plays for SDSS-V: it holds the array (robot spec, layout, collision
buffer, offline robots) and the planning options; :meth:`Reconfiguration.run` draws or
takes targets, plans (stepwise planners with deadlock resolution, or a potential
field), post-processes into firmware-ready trajectories (smoothing, time-optimal
timing, simplification, re-verification by the independent 2D checker that this
module hands to the planners) and returns a :class:`~rfp_twin.twin.outcome.Outcome` that writes
the run folder. The CLI's ``plan``, the studies, the tests' helpers and the benchmarks
all call it, so the chain is written once.

Units: mm, deg, s. Configurations are ``(n_robots, 2)`` arrays of (alpha, beta) in deg,
rows in layout order.

Example::

    rc = Reconfiguration.from_names("sdss-v", buffer_mm=2.0)
    outcome = rc.run(seed=1)
    outcome.write("out/run1")
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Callable

import numpy as np

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.errors import KindError, PlanningError, RfpError
from rfp_twin.models.kernel_cache import DELIVERY, preload_cached, warm_kernels
from rfp_twin.models.layout import Layout, default_layout_name, layout_by_name
from rfp_twin.models.options import declared, option, option_info, same_option
from rfp_twin.models.kinds import ALPHA_BETA
from rfp_twin.models.robot import RobotSpec, load_spec, preset_kind
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.planners.plan import (ALGORITHMS, DIRECTIONS, RESOLVERS, Plan, PlannerSettings,
                                      plan_reconfiguration)
from rfp_twin.planners.plan.kinds import require_planner_kind
from rfp_twin.planners.plan.offline import apply_offline
from rfp_twin.planners.plan.targets import random_targets
from rfp_twin.planners.postprocess import DEFAULT_BUDGET_MM, DEFAULT_MAX_POINTS, postprocess
from rfp_twin.planners.postprocess.timing import BACKENDS, DEFAULT_BACKEND
from rfp_twin.planners.stepwise import array_max_displacement
from rfp_twin.twin.outcome import Outcome
from rfp_twin.validation.checker2d import CheckReport, check_trajectory

if TYPE_CHECKING:                     # loaded on first use (a field planner, post-processing)
    from rfp_twin.planners.fields import ApfResult
    from rfp_twin.planners.postprocess import PostprocessReport

#: Planners that integrate a potential field (Makarem 2014 APF, Macktoobian 2019 CAPF).
FIELD_ALGORITHMS = ("apf", "capf")
#: Every planner the pipeline runs.
ALL_ALGORITHMS = ALGORITHMS + FIELD_ALGORITHMS
#: Deadlock resolution: the planners' resolvers, or none (stop after the first run).
RESOLUTIONS = RESOLVERS + ("none",)
#: Extra clearance (mm) beyond a field's barrier that random targets keep.
FIELD_TARGET_SLACK_MM = 0.5
#: The stepwise planners' kernel (it releases the GIL): once it is loaded and running, the
#: kernels that the plan's paths, post-processing and the 2D check call from Python (each
#: module registers its own: :func:`rfp_twin.models.kernel_cache.warm_up`) load from
#: numba's cache on another thread (:func:`rfp_twin.models.kernel_cache.preload_cached`).
PLANNER_KERNEL = "rfp_twin.planners.stepwise.kernel:run_stepwise_arrays"

__all__ = ["ALL_ALGORITHMS", "FIELD_ALGORITHMS", "RESOLUTIONS", "PlanOptions", "Reconfiguration",
           "Outcome", "check_trajectory"]


def _choice(name: str, value: str, allowed: tuple[str, ...]) -> None:
    if value not in allowed:
        raise RfpError(f"{name} {value!r}; allowed: {', '.join(allowed)}")


def _planner(name: str, **changes):
    """A PlanOptions field declared as PlannerSettings' ``name`` (help, unit, range)."""
    return same_option(PlannerSettings, name, **changes)


@dataclass(frozen=True)
class PlanOptions:
    """How to plan and what to deliver: every option of ``rfp-twin plan``.

    The stepwise planners' options are PlannerSettings' (declared there once, with help,
    unit and range); the field planners' and the delivery's are declared here. The CLI
    builds its options from these fields (:mod:`rfp_twin.twin.cli.options`)."""

    algorithm: str = _planner("algorithm", choices=ALL_ALGORITHMS, help=(
        "greedy | markov (stepwise, Sayres 2021) | roadmap (Sabater 2018 prioritized "
        "state-time planner on every robot; slow: minutes on 500 robots) | apf (Makarem "
        "2014 navigation function) | capf (Macktoobian 2019)"))
    step_deg: float = _planner("step_deg")
    greed: float | None = _planner("greed")
    phobia: float | None = _planner("phobia")
    tries: int = _planner("tries")
    direction: str = _planner("direction")
    resolve: str = _planner("resolve", choices=RESOLUTIONS, help=(
        option_info(PlannerSettings, "resolve").help + " | none"))
    max_steps: int | None = _planner("max_steps")
    max_rounds: int = _planner("max_rounds")
    reruns: int = _planner("reruns")
    beta_first: float = _planner("beta_first")
    fold_repairs: int = _planner("fold_repairs")
    apf_gain: float = option(1.0, "apf/capf: field gain u = -gain J^T grad psi", unit="1/s")
    lambda3: float = option(0.03, "capf: cooperative weight (Macktoobian Eq. 5)")
    raw: bool = option(False, "Write the stepwise paths (constant speed, infinite "
                       "acceleration) instead of firmware-ready trajectories; they are "
                       "checked at the planning buffer")
    budget_mm: float = option(DEFAULT_BUDGET_MM, "Buffer share of smoothing + simplification "
                              "(Eq. 12); trajectories are verified at buffer - budget", unit="mm")
    max_points: int = option(DEFAULT_MAX_POINTS, "Most (angle, time) points per axis "
                             "(firmware)")
    timing_backend: str = option(DEFAULT_BACKEND, "Time-optimal parametrisation: numba (our "
                                 "kernel of TOPP-RA) | toppra (the library: the same laws, a "
                                 "cross-check, ~10x slower)", choices=BACKENDS)

    def __post_init__(self) -> None:
        for name in ("algorithm", "resolve", "direction", "timing_backend"):
            _choice("--" + name.replace("_", "-"), getattr(self, name),
                    option_info(self, name).choices)
        self.planner_settings()   # range errors now, before anything is drawn or planned
        if not self.stepwise:
            self.field_settings()

    @property
    def stepwise(self) -> bool:
        """True for the stepwise planners (greedy, markov, mdp2, roadmap)."""
        return self.algorithm in ALGORITHMS

    def planner_settings(self) -> PlannerSettings:
        """The stepwise planner's settings (field planners: the greedy defaults, unused)."""
        shared = {f.name: getattr(self, f.name) for f in declared(PlannerSettings)
                  if f.name in self.__dataclass_fields__}
        shared["algorithm"] = self.algorithm if self.stepwise else "greedy"
        shared["resolve"] = "replace" if self.resolve == "none" else self.resolve
        return PlannerSettings(**shared)

    def field_settings(self):
        """ApfSettings / CapfSettings on the beta segments (field planners only).

        Alpha is held within the spec's limits: the pipeline delivers trajectories for the
        firmware, and a real robot stops at its alpha hard stops (the papers' robots have none).
        """
        from rfp_twin.planners.fields import ApfSettings, CapfSettings

        if self.algorithm == "capf":
            return CapfSettings(model="segment", gain=self.apf_gain, lambda3=self.lambda3,
                                enforce_alpha_limits=True)
        return ApfSettings(model="segment", gain=self.apf_gain, enforce_alpha_limits=True)


class Reconfiguration:
    """An array to reconfigure: spec, layout, buffer, offline robots and plan options.

    Parameters
    ----------
    geom : ArrayGeometry (spec, layout and the planning buffer)
    options : PlanOptions
    offline : {robot_id: (alpha, beta) deg}: robots that never move, at these angles
    """

    def __init__(self, geom: ArrayGeometry, options: PlanOptions | None = None, *,
                 offline: dict[int, tuple[float, float]] | None = None) -> None:
        self.geom = geom
        self.options = options if options is not None else PlanOptions()
        self.offline = dict(offline or {})
        self._field = None if self.options.stepwise else self.options.field_settings()

    @classmethod
    def from_names(cls, preset: str | RobotSpec = "sdss-v", layout: str | Layout | None = None, *,
                   buffer_mm: float | None = None, fiducial_ids: tuple[int, ...] = (),
                   options: PlanOptions | None = None,
                   offline: dict[int, tuple[float, float]] | None = None) -> "Reconfiguration":
        """From a preset name / robot TOML (or a RobotSpec) and a layout name (see
        :func:`rfp_twin.models.layout.layout_by_name`; default: the preset's instrument)."""
        if not isinstance(preset, RobotSpec):
            _require_alpha_beta(preset, (options or PlanOptions()).algorithm)
        spec = preset if isinstance(preset, RobotSpec) else load_spec(preset)
        if buffer_mm is not None:
            spec = spec.with_overrides(buffer_mm=buffer_mm)
        if not isinstance(layout, Layout):
            layout = layout_by_name(layout or default_layout_name(spec), spec.pitch_mm, fiducial_ids)
        return cls(ArrayGeometry(spec, layout, spec.buffer_mm), options, offline=offline)

    @property
    def spec(self) -> RobotSpec:
        return self.geom.spec

    @property
    def layout(self) -> Layout:
        return self.geom.layout

    @property
    def field_settings(self):
        """ApfSettings / CapfSettings of a field planner, None for the stepwise planners."""
        return self._field

    # ------------------------------------------------------------------------ targets
    def target_margin_mm(self) -> float:
        """Clearance beyond Eq. 3 that random targets keep (mm): the stepwise planners'
        maximum displacement per step (Sayres 2021 step rule), or the field's barrier."""
        if self._field is not None:
            from rfp_twin.planners.fields import apf_target_margin_mm

            return apf_target_margin_mm(self.geom, self._field) + FIELD_TARGET_SLACK_MM
        return array_max_displacement(self.geom, self.options.step_deg)

    def random_targets(self, rng: np.random.Generator) -> np.ndarray:
        """Seeded random right-armed targets, mutually clear, (n_robots, 2) deg; offline
        robots keep their parked angles."""
        initial = np.zeros((self.geom.n_robots, 2))
        movable = apply_offline(self.geom, self.offline, initial)
        return random_targets(self.geom, rng, fixed=~movable, initial=initial,
                              margin_mm=self.target_margin_mm())

    def read_targets(self, path: str | Path) -> np.ndarray:
        """Targets from a CSV file (see :func:`rfp_twin.twin.targets_csv.read_targets_csv`)."""
        from rfp_twin.twin.targets_csv import read_targets_csv

        return read_targets_csv(path, self.geom)

    # ----------------------------------------------------------------------- the steps
    def plan(self, targets: np.ndarray, rng: np.random.Generator, *,
             on_round: Callable[[int, int], None] | None = None,
             start: np.ndarray | None = None) -> tuple[Plan, ApfResult | None]:
        """Plan fold -> targets, or ``start`` ((n, 2) deg, clear poses) -> targets.
        Returns ``(Plan, ApfResult or None)``.

        ``on_round(round, n_stuck)`` is called after each stepwise planner run."""
        if self._field is not None:
            from rfp_twin.planners.fields import plan_apf_reconfiguration

            return plan_apf_reconfiguration(self.geom, targets, self._field, offline=self.offline,
                                            algorithm=self.options.algorithm, start=start)
        o = self.options
        plan = plan_reconfiguration(self.geom, targets, o.planner_settings(), rng,
                                    offline=self.offline, resolve=o.resolve != "none",
                                    progress=on_round, start=start)
        return plan, None

    def deliver(self, plan: Plan, progress: Callable[[int, int], None] | None = None
                ) -> tuple[Trajectory, PostprocessReport | None, CheckReport]:
        """Firmware-ready trajectory (or the raw stepwise one), its post-processing report
        (None when raw) and the independent 2D check of what is delivered:
        ``(Trajectory, PostprocessReport | None, CheckReport)``.

        Post-processed trajectories are checked at buffer - budget, raw ones at the
        planning buffer; the post-processing's own checks (the first of the whole
        trajectory, each re-check of the pairs that changed merged in) are that check:
        the whole trajectory is not checked twice. ``progress(groups_timed, groups_to_time)``
        follows the post-processing's timing of the groups."""
        o = self.options
        if o.raw:
            traj = Trajectory.from_plan(plan)
            return traj, None, check_trajectory(traj, self.spec, self.layout, self.spec.buffer_mm)
        traj, post = postprocess(plan, self.geom, budget_mm=o.budget_mm, max_points=o.max_points,
                                 backend=o.timing_backend, verifier=check_trajectory,
                                 progress=progress)
        return traj, post, post.final_check

    def run(self, *, seed: int = 0, targets: np.ndarray | None = None,
            on_round: Callable[[int, int], None] | None = None,
            on_stage: Callable[[str], None] | None = None,
            on_progress: Callable[[str, int, int], None] | None = None,
            start: np.ndarray | None = None) -> Outcome:
        """Targets (given, or drawn from ``seed``), plan, post-process and check; the
        motion starts folded, or at ``start`` ((n, 2) deg: where the robots stand).

        The random sequence is the one of ``rfp-twin plan --seed SEED``: the same
        generator draws the targets and then drives the planner.
        ``on_stage(name)`` is called as each stage starts: "targets", "planning",
        "post-processing" (or "checking" when raw); ``on_progress(stage, done, total)``
        follows the post-processing ("post-processing", groups timed of the round's)."""
        stage = on_stage or (lambda name: None)
        clock = time.perf_counter()
        seconds: dict[str, float] = {}
        rng = np.random.default_rng(seed)
        t0 = time.perf_counter()
        stage("targets")
        tg = self.random_targets(rng) if targets is None else np.asarray(targets, dtype=np.float64)
        seconds["targets"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        stage("planning")
        # the next stage's kernels load from numba's cache beside the planner's nogil runs
        preload = None if self.options.raw else preload_cached(warm_kernels(DELIVERY),
                                                               after=PLANNER_KERNEL)
        try:
            plan, field = self.plan(tg, rng, on_round=on_round, start=start)
            if preload is not None:
                preload.release()       # a planner without that kernel: load them now
            seconds["plan"] = time.perf_counter() - t0
            t0 = time.perf_counter()
            stage("checking" if self.options.raw else "post-processing")
            follow = None if on_progress is None else \
                (lambda done, total: on_progress("post-processing", done, total))
            traj, post, check = self.deliver(plan, progress=follow)
        finally:
            if preload is not None:
                preload.join()          # no thread left loading (a caller may fork)
        seconds["deliver"] = time.perf_counter() - t0
        seconds["total"] = time.perf_counter() - clock
        return Outcome(self, seed, tg, plan, field, traj, post, check, seconds)


def _require_alpha_beta(preset: str | Path, algorithm: str) -> None:
    """The planner must support the preset's robot kind (one-line KindError naming both),
    and this pipeline delivers alpha/beta trajectories: probe arms are planned by
    :func:`rfp_twin.twin.probe_run.plan_probe_bench`."""
    kind = preset_kind(preset)
    require_planner_kind(algorithm, kind)
    if kind != ALPHA_BETA:
        raise KindError(f"preset {preset}: robot kind {kind!r} is planned by "
                        "rfp_twin.twin.probe_run (rfp-twin plan --algorithm roadmap); allowed "
                        f"here: {ALPHA_BETA!r}")


def plan_random(geom: ArrayGeometry, seed: int, options: PlanOptions | None = None) -> tuple:
    """Seeded random targets and the (stepwise or field) plan, without post-processing:
    ``(targets (n, 2) deg, Plan, ApfResult or None)``; the random sequence of ``run``."""
    rc = Reconfiguration(geom, options)
    rng = np.random.default_rng(seed)
    targets = rc.random_targets(rng)
    plan, field = rc.plan(targets, rng)
    return targets, plan, field


def folded_clearance_error(geom: ArrayGeometry) -> PlanningError | None:
    """A PlanningError when every robot folded already collides (an infeasible design),
    else None."""
    spec = geom.spec
    fold = np.tile(np.asarray(spec.fold_deg, dtype=np.float64), (geom.n_robots, 1))
    clear = geom.pair_clearance(fold)
    if clear.size and clear.min() <= 0.0:
        return PlanningError(f"folded state {tuple(spec.fold_deg)} deg collides (clearance "
                             f"{clear.min():.3f} mm at pitch {spec.pitch_mm:g} mm, buffer "
                             f"{spec.buffer_mm:g} mm): infeasible")
    return None
