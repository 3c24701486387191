"""Several robots calibrated side by side: :func:`compare_buffers` (mm, deg, s).

Every column is one :func:`rfp_twin.validation.buffer.calibrate_buffer` run on the same
spec (the same 2D model), layout, samples, draws and seed: the 3D meshes of each
geometry, and the 2D capsule model itself (the robot as the capsule of radius ``r``
around its beta segment; its ``b*`` is ``r`` by construction, so it shows what the 2D
model alone predicts, e.g. the angular-error share next to the paper's analytic 0.97 mm).
With an instrument every column also gets part (d), the metrology spread.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Callable, Optional, Sequence

from rfp_twin.models.geometry import RobotGeometry
from rfp_twin.models.layout import Layout
from rfp_twin.models.robot import RobotSpec
from rfp_twin.validation.buffer.calibrate import calibrate_buffer
from rfp_twin.validation.buffer.report import BufferCalibration

#: Share of one column's run time per stage (start, end), for progress reports.
STAGES = {"uniform samples": (0.0, 0.1), "boundary": (0.1, 0.2), "monte carlo": (0.2, 0.55),
          "metrology spread": (0.55, 0.95)}
#: The same without a metrology spread.
STAGES_NO_SPREAD = {"uniform samples": (0.0, 0.1), "boundary": (0.1, 0.2),
                    "monte carlo": (0.2, 0.95)}


def stage_fraction(stage: str, frac: float, spread: bool) -> float:
    """Fraction of one calibration done at ``frac`` of ``stage``."""
    lo, hi = (STAGES if spread else STAGES_NO_SPREAD).get(stage, (0.95, 1.0))
    return lo + (hi - lo) * frac


def describe_geometry(name: str, geometry: RobotGeometry) -> str:
    """Column label of a geometry: what its beta arm is, and where it came from."""
    p = geometry.params
    if p.meshes or p.collision:
        kind = "CAD meshes"
    elif p.beta_shape == "p1":
        kind = "P1 prototype (published)"
    else:
        kind = "estimate bar"
    return f"{kind}: {name}"


def slug(text: str) -> str:
    """A folder name for a column label."""
    return re.sub(r"[^A-Za-z0-9.]+", "-", text).strip("-").lower() or "column"


@dataclass
class BufferComparison:
    """Side-by-side calibrations (:func:`compare_buffers`).

    Attributes
    ----------
    spec_name : str
    instrument : str
        Metrology spread used in every column ("" if none).
    columns : list of BufferCalibration, in the order given (capsule model last)
    seconds : float
        Total wall time.
    """

    spec_name: str
    instrument: str
    columns: list = field(default_factory=list)
    seconds: float = 0.0

    @property
    def labels(self) -> list[str]:
        return [c.geometry for c in self.columns]

    def to_dict(self) -> dict:
        return {"spec_name": self.spec_name, "instrument": self.instrument,
                "seconds": self.seconds, "columns": [c.to_dict() for c in self.columns]}

    def rows(self) -> list[tuple[str, list[str]]]:
        """(quantity, one cell per column) of the summary table."""
        cols: Sequence[BufferCalibration] = self.columns
        spec_b = cols[0].spec_buffer_mm if cols else 0.0
        p = cols[0].probability if cols else 0.99
        out = [
            ("(a) b*: smallest safe 2D buffer, mm", [f"{c.safe_buffer_mm:.4f}" for c in cols]),
            ("envelope around the 2D segment, mm", [f"{c.envelope_mm:.4f}" for c in cols]),
            ("worst contact", [c.worst["links"] for c in cols]),
            ("3D-colliding share of configurations", [f"{c.colliding_fraction:.4f}" for c in cols]),
            (f"(b) wasted share of the 2D-forbidden space at {spec_b:g} mm",
             [f"{c.wasted_at(spec_b):.3f}" for c in cols]),
            (f"(c) b_{p:g}, angular errors only, mm", [f"{c.mc_buffer_mm:.4f}" for c in cols]),
            ("angular share b_p - b*, mm", [f"{c.mc_share_mm:.4f}" for c in cols]),
            ("worst corner (all errors at bounds), mm", [f"{c.corner_buffer_mm:.4f}" for c in cols]),
        ]
        if self.instrument:
            out += [(f"(d) b_{p:g}, angular errors + {self.instrument} metrology spread, mm",
                     [f"{c.spread_buffer_mm:.4f}" for c in cols]),
                    ("change from the spread, mm", [f"{c.spread_change_mm:+.4f}" for c in cols])]
        out.append(("run time s / FCL calls",
                    [f"{c.seconds.get('total', 0.0):.0f} / {c.n_fcl_calls}" for c in cols]))
        return out

    def table(self) -> str:
        """Terminal summary: a header, then per column its label and results."""
        p = self.columns[0].probability if self.columns else 0.99
        spread = f", metrology spread {self.instrument}" if self.instrument else ""
        lines = [f"buffer calibration side by side ({self.spec_name}, p = {p:g}{spread})"]
        for c in self.columns:
            lines.append(f"{c.geometry}:")
            lines.append(f"  (a) b* {c.safe_buffer_mm:.4f} mm (envelope {c.envelope_mm:.4f}, "
                         f"{c.worst['links']}); (b) wasted at {c.spec_buffer_mm:g} mm "
                         f"{c.wasted_at(c.spec_buffer_mm):.3f}")
            text = f"  (c) b_p {c.mc_buffer_mm:.4f} mm (angular errors)"
            if self.instrument:
                text += (f"; (d) b_p {c.spread_buffer_mm:.4f} mm with the spread "
                         f"({c.spread_change_mm:+.4f})")
            lines.append(text)
        return "\n".join(lines)


def compare_buffers(spec: RobotSpec, geometries: Sequence[tuple[str, RobotGeometry]],
                    layout: Layout | None = None, *, capsule_radius_mm: float | None = None,
                    instrument=None,
                    progress: Optional[Callable[[str, float], None]] = None,
                    **kwargs) -> BufferComparison:
    """Calibrate each geometry, then the capsule model, with the same settings.

    Parameters
    ----------
    spec : RobotSpec
        The 2D model (segment, preset buffer, angular errors) shared by every column.
    geometries : sequence of (label, RobotGeometry)
    layout : Layout, optional
    capsule_radius_mm : float, optional
        Add the 2D capsule model of this radius as the last column.
    instrument : str, optional
        Metrology spread for part (d) of every column (``sdss-v-apo``, ``sdss-v-lco``).
    progress : callable(stage, fraction of the whole comparison), optional
    **kwargs
        Passed to :func:`calibrate_buffer` (``n_samples``, ``n_draws``, ``seed``, ...).
    """
    import time

    clock = time.perf_counter()
    jobs = [dict(geometry=g, label=label) for label, g in geometries]
    if capsule_radius_mm is not None:
        jobs.append(dict(capsule_radius_mm=capsule_radius_mm))
    comp = BufferComparison(spec.name, str(instrument or ""))
    for k, job in enumerate(jobs):
        name = job.get("label") or "2D capsule model"

        def on_progress(stage, frac, k=k, name=name):
            if progress is not None:
                done = stage_fraction(stage, frac, instrument is not None)
                progress(f"{name}: {stage}", (k + done) / len(jobs))

        comp.columns.append(calibrate_buffer(spec, layout=layout, instrument=instrument,
                                             progress=on_progress, **job, **kwargs))
    comp.seconds = time.perf_counter() - clock
    return comp
