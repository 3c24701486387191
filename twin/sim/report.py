"""What happened in one simulation: the sampled history and the summary report.

:class:`SimRecord` holds the sampled joint angles (k samples, n robots, 2 axes: alpha,
beta); :class:`SimReport` the per-robot tracking errors, the contacts, the faults and
MuJoCo's warnings, as JSON (:meth:`SimReport.to_json`) or a terminal table.

Units: angles in degrees, times in seconds (simulated, except ``wall_s``), lengths in mm.
Robots in layout order.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rfp_twin.models.errors import RfpError, UnknownRobotError
from rfp_twin.models.files import atomic_write_text
from rfp_twin.twin.sim.contacts import ContactLog


@dataclass
class SimRecord:
    """Sampled history: times (k,) s; angles (k, n, 2) true joint angles, deg;
    measured (k, n, 2) encoder readings, deg; reference (k, n, 2) nominal trajectory, deg."""

    times: np.ndarray
    angles: np.ndarray
    measured: np.ndarray
    reference: np.ndarray


@dataclass
class SimReport:
    """What happened in one simulation.

    Attributes
    ----------
    robot_ids : (n,) int64, layout robot order
    sim_s, trajectory_s : simulated time and trajectory duration, s
    timestep_s : physics step, s; n_steps : steps taken
    wall_s : wall time of the stepping loop, s; realtime_factor : sim_s / wall_s
    max_error_deg, rms_error_deg, final_error_deg : (n, 2) tracking error (true angle -
        nominal trajectory) per robot and axis; max and final are signed-at-max |.|
    final_fiber_error_mm : (n,) distance of the fiber from its nominal end position, mm
    reached : (n,) bool, final |error| <= reached_tol_deg on both axes
    contacts : ContactLog (robot-robot and robot-fiducial)
    faults : list of fault descriptions
    warnings : dict MuJoCo warning name -> count (empty when none)
    warning_messages : MuJoCo's warning texts raised during the run
    record : SimRecord or None
    """

    robot_ids: np.ndarray
    sim_s: float
    trajectory_s: float
    timestep_s: float
    n_steps: int
    wall_s: float
    max_error_deg: np.ndarray
    rms_error_deg: np.ndarray
    final_error_deg: np.ndarray
    final_fiber_error_mm: np.ndarray
    reached: np.ndarray
    contacts: ContactLog
    faults: list[str] = field(default_factory=list)
    warnings: dict[str, int] = field(default_factory=dict)
    warning_messages: list[str] = field(default_factory=list)
    record: SimRecord | None = None

    @property
    def realtime_factor(self) -> float:
        return self.sim_s / self.wall_s if self.wall_s > 0 else math.inf

    @property
    def robot_contacts(self) -> int:
        """Number of robot-robot contact rows."""
        return int(np.count_nonzero(self.contacts.robot_robot))

    @property
    def fiducial_contacts(self) -> int:
        return int(len(self.contacts) - self.robot_contacts)

    @property
    def collided(self) -> bool:
        return len(self.contacts) > 0

    @property
    def ok(self) -> bool:
        """No contact, no MuJoCo warning, every robot reached its end."""
        return (not self.collided and not self.warnings and not self.warning_messages
                and bool(np.all(self.reached)))

    def sampled_record(self, error: type[Exception] = RfpError) -> SimRecord:
        """The sampled record; raises ``error`` when the run kept none (a report from
        ``simulate(..., record=False)``) or it has no sample."""
        rec = self.record
        if rec is None or rec.times.size == 0:
            raise error("the simulation report has no sampled record; allowed: a report "
                        "from simulate(..., record=True)")
        return rec

    def error_of(self, robot_id: int) -> dict:
        """Max / rms / final error (alpha, beta) deg of one robot."""
        k = np.flatnonzero(self.robot_ids == robot_id)
        if k.size == 0:
            raise UnknownRobotError(f"robot {robot_id} is not in this report; allowed: "
                                    f"{int(self.robot_ids.min())}..{int(self.robot_ids.max())}")
        k = int(k[0])
        return {"max": self.max_error_deg[k].tolist(), "rms": self.rms_error_deg[k].tolist(),
                "final": self.final_error_deg[k].tolist()}

    def to_dict(self) -> dict:
        """JSON-ready summary (per-robot errors, contact pairs; not the sampled record)."""
        worst = int(np.argmax(np.abs(self.max_error_deg).max(axis=1))) if self.robot_ids.size else 0
        return {
            "ok": self.ok, "robots": int(self.robot_ids.size), "sim_s": self.sim_s,
            "trajectory_s": self.trajectory_s, "timestep_s": self.timestep_s,
            "n_steps": self.n_steps, "wall_s": self.wall_s,
            "realtime_factor": self.realtime_factor,
            "robot_contact_rows": self.robot_contacts,
            "fiducial_contact_rows": self.fiducial_contacts,
            "contact_pairs": self.contacts.pairs(),
            "max_depth_mm": float(self.contacts.depth_mm.max()) if len(self.contacts) else 0.0,
            "not_reached": [int(r) for r in self.robot_ids[~self.reached]],
            "worst_robot": int(self.robot_ids[worst]) if self.robot_ids.size else None,
            "faults": list(self.faults), "warnings": dict(self.warnings),
            "warning_messages": list(self.warning_messages),
            "per_robot": {str(int(r)): {"max_error_deg": self.max_error_deg[k].tolist(),
                                        "rms_error_deg": self.rms_error_deg[k].tolist(),
                                        "final_error_deg": self.final_error_deg[k].tolist(),
                                        "final_fiber_error_mm": float(self.final_fiber_error_mm[k])}
                          for k, r in enumerate(self.robot_ids)},
        }

    def to_json(self, path: str | Path) -> None:
        """Write :meth:`to_dict` atomically (temp file + rename)."""
        atomic_write_text(path, json.dumps(self.to_dict(), indent=1))

    def table(self):
        """A rich Table for the terminal."""
        from rich.table import Table

        d = self.to_dict()
        t = Table(title="simulation", show_header=False)
        t.add_column("what")
        t.add_column("value")
        t.add_row("robots", str(d["robots"]))
        t.add_row("simulated / wall", f"{self.sim_s:.2f} s / {self.wall_s:.2f} s "
                                      f"({self.realtime_factor:.2g}x real time)")
        t.add_row("steps", f"{self.n_steps} x {self.timestep_s * 1e3:g} ms")
        pairs = [p for p in d["contact_pairs"] if "robot_b" in p]
        t.add_row("robot-robot contacts", f"{len(pairs)} pairs, max depth {d['max_depth_mm']:.3f} mm"
                  if pairs else "none")
        fpairs = [p for p in d["contact_pairs"] if "fiducial" in p]
        t.add_row("robot-fiducial contacts", f"{len(fpairs)} pairs" if fpairs else "none")
        err = np.abs(self.max_error_deg).max() if self.robot_ids.size else 0.0
        t.add_row("max tracking error", f"{err:.3f} deg (robot {d['worst_robot']})")
        t.add_row("not reached", ", ".join(map(str, d["not_reached"][:20])) or "none")
        t.add_row("faults", "; ".join(self.faults) or "none")
        t.add_row("MuJoCo warnings", ", ".join(f"{k} x{v}" for k, v in self.warnings.items()) or "none")
        return t
