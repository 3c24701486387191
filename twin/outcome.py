"""What one pipeline run produced, its summary, and the run folder it writes.

:class:`Outcome` holds the targets ``(n_robots, 2)`` deg, the plan, the delivered
trajectory (firmware-ready, or the raw stepwise paths), the post-processing report,
the independent 2D check and the wall seconds of each stage. ``summary()`` is the
``summary.json`` of a run folder; ``write()`` writes the folder atomically
(:func:`rfp_twin.twin.run_dir.write_run`).
"""
from __future__ import annotations

import dataclasses
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from rfp_twin.models.trajectory import Trajectory
from rfp_twin.planners.plan import DEADLOCKED, Plan
from rfp_twin.twin.run_dir import write_run
from rfp_twin.validation.checker2d import CheckReport

if TYPE_CHECKING:                     # imported at run time by the modules that make them
    from rfp_twin.planners.fields import ApfResult
    from rfp_twin.planners.postprocess import PostprocessReport
    from rfp_twin.twin.pipeline import Reconfiguration


@dataclass
class Outcome:
    """One run of :meth:`rfp_twin.twin.pipeline.Reconfiguration.run`.

    Attributes
    ----------
    reconfiguration : the Reconfiguration that ran (array, options, offline robots)
    seed : seed of the targets and the planner's random moves
    targets : (n_robots, 2) deg, as asked (before any replacement)
    plan : Plan in the executed direction (fold -> targets)
    field : ApfResult of a field planner, else None
    trajectory : what is delivered (firmware-ready, or stepwise when raw)
    post : PostprocessReport, None when raw
    check : the independent 2D check of ``trajectory`` (rfp_twin.validation.checker2d report)
    seconds : wall seconds per stage: targets, plan, deliver, total
    """

    reconfiguration: Reconfiguration
    seed: int
    targets: np.ndarray
    plan: Plan
    field: ApfResult | None
    trajectory: Trajectory
    post: PostprocessReport | None
    check: CheckReport
    seconds: dict[str, float] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        """True when the independent 2D check found no collision."""
        return bool(self.check.ok)

    @property
    def n_deadlocked(self) -> int:
        return int(np.sum(self.plan.status == DEADLOCKED))

    def summary(self, *, layout: str = "", command: str | None = None) -> dict:
        """Every parameter, metric and check figure of the run (``summary.json``).

        ``layout`` is the layout's name as given; ``command`` the command line
        [default: this process's]."""
        rc = self.reconfiguration
        o, spec, geom = rc.options, rc.spec, rc.geom
        traj, post = self.trajectory, self.post
        field_settings = rc.field_settings
        counts = traj.point_counts()
        return {
            "command": command if command is not None else " ".join(["rfp-twin"] + sys.argv[1:]),
            "spec": spec.source, "robot": spec.name, "layout": layout or rc.layout.name,
            "n_robots": geom.n_robots, "n_fiducials": rc.layout.n_fiducials,
            "n_gfa": int(np.sum(rc.layout.kinds == "gfa")),
            "buffer_mm": spec.buffer_mm,
            "segment_mm": [spec.segment_start_mm, spec.segment_end(spec.buffer_mm)],
            "step_deg": o.step_deg if o.stepwise else None, "algorithm": o.algorithm,
            "greed": o.planner_settings().greed if o.algorithm in ("markov", "mdp2") else 1.0,
            "phobia": o.planner_settings().phobia if o.algorithm in ("markov", "mdp2") else 0.0,
            "seed": self.seed,
            "direction": o.direction if o.stepwise else "direct (fold -> targets)",
            "resolve": o.resolve if o.stepwise else "none",
            "max_steps": o.planner_settings().steps_limit if o.stepwise else None,
            "field": dataclasses.asdict(field_settings) if field_settings is not None else None,
            "offline": sorted(rc.offline),
            "fold_deg": list(spec.fold_deg), "speed_deg_s": list(spec.max_speed_deg_s),
            "metrics": dict(self.plan.metrics), "duration_s": traj.duration,
            "path_delay_s": spec.path_delay_s, "fold_s": spec.path_delay_s + traj.duration,
            "stepwise_fold_s": self.plan.n_steps * self.plan.step_s if o.stepwise else None,
            "duration_ratio": post.duration_ratio if post is not None else None,
            "slowest_groups": post.slowest_groups if post is not None else None,
            "points_per_axis_median": float(np.median(counts)),
            "points_per_axis_max": int(counts.max()),
            "trajectories": "stepwise (raw)" if post is None else "firmware-ready (postprocessed)",
            "postprocess": post.to_dict() if post is not None else None,
            "check2d": self.check.to_dict(),
            "wall_time_s": self.seconds.get("total", 0.0),
        }

    def write(self, out: str | Path, *, summary: dict | None = None, overwrite: bool = False,
              extra: dict[str, str] | None = None) -> Path:
        """Write the run folder (atomically; an existing ``out`` only with ``overwrite``;
        ``extra``: more files {name: text})."""
        rc = self.reconfiguration
        summary = summary if summary is not None else self.summary()
        return write_run(Path(out), spec=rc.spec, layout=rc.layout, plan=self.plan,
                         trajectory=self.trajectory, summary=summary, check2d=summary["check2d"],
                         overwrite=overwrite, extra=extra)
