"""The probe-arm bench in MuJoCo along a plan: tracking, contacts, loop closure.

:func:`simulate_probe_plan` builds the bench of a plan's kind
(:func:`rfp_twin.models.mjcf.probe_bench.build_probe_bench`), starts every arm at its
start pose and steps it while the J1 / J2 servos follow the plan's breakpoints (held
after their ends). It reports the largest motor tracking error, every contact between
two arms (the parts of one arm never collide with each other) and the largest
violation of the closing constraint. Units: deg, mm, s.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import mujoco
import numpy as np

from rfp_twin.models.mjcf.options import collect_mujoco_warnings
from rfp_twin.models.mjcf.probe_bench import build_probe_bench


@dataclass
class ProbeSimReport:
    """What the simulation of a probe-arm plan saw.

    Attributes
    ----------
    duration_s : simulated time; steps : physics steps
    max_tracking_deg : largest |simulated - planned| motor angle, deg
    contacts : list of (t s, body 1, body 2, distance mm), first 20
    n_contact_steps : steps with at least one contact
    max_loop_gap_mm : largest violation of the closing (connect) constraint, mm
    warnings : MuJoCo warning messages
    wall_s : wall-clock time of the run
    """

    duration_s: float
    steps: int
    max_tracking_deg: float
    contacts: list = field(default_factory=list)
    n_contact_steps: int = 0
    max_loop_gap_mm: float = 0.0
    warnings: list = field(default_factory=list)
    wall_s: float = 0.0

    @property
    def ok(self) -> bool:
        return self.n_contact_steps == 0 and not self.warnings


def simulate_probe_plan(plan, *, settle_s: float = 1.0, duration_s: float | None = None) -> ProbeSimReport:
    """Simulate ``plan`` (a successful :class:`rfp_twin.planners.roadmap.probe.ProbePlan`) from its
    start to its end plus ``settle_s`` (or for ``duration_s``)."""
    clock = time.perf_counter()
    kind = plan.kind
    bench = build_probe_bench(kind)
    m = bench.model
    d = mujoco.MjData(m)
    end = plan.makespan_s + settle_s if duration_s is None else duration_s
    n_steps = int(round(end / m.opt.timestep))
    times = m.opt.timestep * np.arange(1, n_steps + 1)
    ref = plan.at(times)                                       # (T, n, 2) deg
    worst, loop, contacts, n_contact = 0.0, 0.0, [], 0
    with collect_mujoco_warnings() as messages:
        bench.set_pose(d, plan.start)
        for k in range(n_steps):
            bench.command(d, ref[k])
            mujoco.mj_step(m, d)
            worst = max(worst, float(np.abs(bench.motor_angles(d) - ref[k]).max()))
            if d.ne:
                loop = max(loop, float(np.abs(d.efc_pos[:d.ne]).max()))
            if d.ncon:
                n_contact += 1
                for c in d.contact[:d.ncon]:
                    if len(contacts) < 20:
                        contacts.append((float(d.time), m.body(m.geom_bodyid[c.geom1]).name,
                                         m.body(m.geom_bodyid[c.geom2]).name, float(c.dist)))
    return ProbeSimReport(end, n_steps, worst, contacts, n_contact, loop, list(messages),
                          time.perf_counter() - clock)
