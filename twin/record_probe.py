"""A Rerun recording (.rrd) of a probe-arm plan (MIRADAS, Sabater et al. 2018).

What the file holds (world frame in mm, field centre at the origin, z up; timeline
``sim_time``, a duration in seconds of plan time), as :mod:`rfp_twin.twin.record` does
for alpha/beta runs:

``arms/<k>``
    arm k's five bodies (crank, rocker, collimator cabinet, long tube, pick-off head) as
    ``Capsules3D`` in the arms' plane, logged every ``dt_s`` while the arm moves (an arm
    at rest costs nothing).
``traces/tips``
    the path of every arm's pick-off mirror over the whole plan (static line strips).
``field``
    the instrument field as a circle (static).
``contacts``
    the simulation's contacts between two arms, when a MuJoCo report is given: points at
    the first joint of each arm in contact, on the times they happened.
``summary``
    a markdown summary (static).

The bodies come from :meth:`rfp_twin.models.kinds.ProbeArmKind.bodies` (the capsules the
planner and the MuJoCo bench use). The file is written to a temp file beside the
destination and renamed onto it when complete. Units: mm, deg, s.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import rerun as rr

from rfp_twin.models.errors import RfpError
from rfp_twin.twin.rrd_file import write_recording

TIMELINE = "sim_time"
#: Colours (rgba 0-255) of crank, rocker, cabinet, tube, head.
BODY_RGBA = ((77, 102, 153, 255), (77, 102, 153, 255), (140, 140, 153, 255),
             (217, 217, 204, 255), (230, 153, 38, 255))
TRACE_RADIUS_MM = 0.8
#: A pose is logged again when a motor moved more than this since the last one, deg.
POSE_EPS_DEG = 1e-6


def _capsules(kind, arm: int, q: np.ndarray) -> rr.Capsules3D:
    """The five capsules of arm ``arm`` at pose ``q`` (2,) deg in the world."""
    caps = kind.bodies(q[None, :])[0]                                 # (5, 5) arm frame
    p0 = kind.to_world(arm, caps[:, 0:2])
    p1 = kind.to_world(arm, caps[:, 2:4])
    d = p1 - p0
    lengths = np.hypot(d[:, 0], d[:, 1])
    # rerun's capsule runs along its local +z: turn z onto the segment (in the plane)
    quats = []
    for dx, dy in d:
        phi = math.atan2(dy, dx)
        # rotation about z by phi after a quarter turn about y (z -> x), as xyzw
        qy = np.array([0.0, math.sin(math.pi / 4), 0.0, math.cos(math.pi / 4)])
        qz = np.array([0.0, 0.0, math.sin(phi / 2), math.cos(phi / 2)])
        quats.append(_mul_xyzw(qz, qy))
    return rr.Capsules3D(lengths=lengths, radii=caps[:, 4],
                         translations=np.column_stack([p0, np.zeros(5)]),
                         quaternions=np.array(quats), colors=BODY_RGBA)


def _mul_xyzw(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Quaternion product a * b, both xyzw."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return np.array([aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz])


def record_probe_plan(plan, out_rrd: str | Path, *, dt_s: float = 0.5, sim_report=None) -> Path:
    """Write ``out_rrd``: the plan (a ProbePlan or a loaded probe run: ``kind``, ``at``,
    ``makespan_s``) sampled every ``dt_s`` s (see the module docstring); ``sim_report`` a
    :class:`rfp_twin.twin.sim.probe.ProbeSimReport` whose contacts are added. Returns the
    path."""
    if not (math.isfinite(dt_s) and dt_s > 0):
        raise RfpError(f"--dt {dt_s}; allowed: a finite number > 0 s")
    kind = plan.kind
    n_t = int(math.ceil(plan.makespan_s / dt_s - 1e-9)) + 1
    times = np.minimum(dt_s * np.arange(n_t), plan.makespan_s)
    poses = plan.at(times)                                            # (T, n, 2)

    def log(rec: rr.RecordingStream) -> None:
        rec.log("/", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        phi = np.linspace(0.0, 2 * np.pi, 121)
        r = kind.spec.field_radius_mm
        rec.log("field", rr.LineStrips3D([np.column_stack([r * np.cos(phi), r * np.sin(phi),
                                                          np.zeros_like(phi)])]), static=True)
        tips = np.stack([kind.tips_world(poses[k]) for k in range(n_t)])   # (T, n, 2)
        rec.log("traces/tips", rr.LineStrips3D(
            [np.column_stack([tips[:, a], np.zeros(n_t)]) for a in range(kind.n_arms)],
            radii=TRACE_RADIUS_MM, labels=[f"arm {a}" for a in range(kind.n_arms)]), static=True)
        last = np.full((kind.n_arms, 2), np.nan)
        for k, t in enumerate(times):
            rec.set_time(TIMELINE, duration=float(t))
            for a in range(kind.n_arms):
                if not np.all(np.abs(poses[k, a] - last[a]) <= POSE_EPS_DEG):
                    rec.log(f"arms/{a}", _capsules(kind, a, poses[k, a]))
                    last[a] = poses[k, a]
        if sim_report is not None:
            bases = kind.bases()
            for t, b1, b2, _dist in sim_report.contacts:
                arms = [int(name[1:].split("_")[0]) for name in (b1, b2)]
                rec.set_time(TIMELINE, duration=float(t))
                rec.log("contacts", rr.Points3D(np.column_stack([bases[arms], np.zeros(2)]),
                                                radii=8.0, colors=[(255, 25, 12, 255)]))
        lines = [f"# {kind.spec.name}: {kind.n_arms} probe arms",
                 f"- makespan {plan.makespan_s:g} s, sampled every {dt_s:g} s"]
        if sim_report is not None:
            lines.append(f"- MuJoCo: {sim_report.n_contact_steps} contact steps, tracking <= "
                         f"{sim_report.max_tracking_deg:.3f} deg")
        rec.log("summary", rr.TextDocument("\n".join(lines), media_type=rr.MediaType.MARKDOWN),
                static=True)

    return write_recording(out_rrd, log)
