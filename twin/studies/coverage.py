"""Coverage of each design geometry of a study, measured once (not per trial).

Coverage depends on the focal-plane geometry only (layout, robot count, pitch, arm
lengths), not on the buffer, the planner or the trial, so a study with ``coverage =
true`` measures it once per :attr:`~rfp_twin.twin.studies.spec.StudyPoint.geometry_id`
with :func:`rfp_twin.models.coverage.measure_coverage` (grid spacing pitch / 20) and keeps
one row per geometry in ``<study>/coverage.parquet`` (:data:`COVERAGE_SCHEMA`). A rerun
measures only the geometries missing from it; the file is rewritten whole (temporary,
read back, renamed). Measured in the client process before the trials go out (no
cluster needed): a 547-position hex grid or 6 rafts take ~5 ms, 204 rafts (12,852
robots) ~0.3 s once the numba kernels are compiled.

Fractions refer to the focal plane of :mod:`rfp_twin.models.coverage` (the convex hull of
the robot bases): on small layouts the rim, where fewer neighbours reach, weighs more
than on a full focal plane. Units: mm, mm^2, s.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from rfp_twin.twin.studies.spec import Study, StudyPoint, point_layout
from rfp_twin.twin.studies.store import replace_atomically

__all__ = ["COVERAGE_FILE", "COVERAGE_SCHEMA", "coverage_row", "read_coverage",
           "update_coverage"]

COVERAGE_FILE = "coverage.parquet"

#: One row per design geometry.
COVERAGE_SCHEMA = pa.schema([
    ("geometry_id", pa.string()),      # StudyPoint.geometry_id (trial rows carry it too)
    ("family", pa.string()),
    ("preset", pa.string()),
    ("layout", pa.string()),
    ("n_robots", pa.int32()),
    ("n_rafts", pa.int32()),
    ("pitch_mm", pa.float64()),
    ("alpha_length_mm", pa.float64()),
    ("beta_length_mm", pa.float64()),
    ("reach_mm", pa.float64()),
    ("pitch_over_reach", pa.float64()),
    ("arm_ratio", pa.float64()),       # alpha / beta
    ("cover_1", pa.float64()),         # share of the focal plane reached by >= 1 fiber
    ("cover_2", pa.float64()),         # >= 2 fibers
    ("cover_3", pa.float64()),         # >= 3 fibers
    ("area_1_mm2", pa.float64()),      # area reached by >= 1 fiber, anywhere
    ("area_2_mm2", pa.float64()),
    ("area_3_mm2", pa.float64()),
    ("focal_plane_mm2", pa.float64()), # convex hull of the bases, as the grid measures it
    ("raft_fraction_mean", pa.float64()),   # instrumented share of a raft's triangle (rafts)
    ("raft_fraction_min", pa.float64()),
    ("spacing_mm", pa.float64()),
    ("seconds", pa.float64()),
])


def coverage_row(point: StudyPoint) -> dict:
    """Measure the coverage of ``point``'s geometry; a :data:`COVERAGE_SCHEMA` row."""
    from rfp_twin.models.coverage import measure_coverage

    layout = point_layout(point.layout, point.n_robots, point.pitch_mm, point.n_rafts)
    cov = measure_coverage(layout, point.spec)
    frac = cov.fraction or {}
    rafts = [r.fraction for r in cov.rafts if r.fraction is not None]
    return {
        "geometry_id": point.geometry_id, "family": point.family, "preset": point.preset,
        "layout": point.layout, "n_robots": point.n_robots, "n_rafts": point.n_rafts,
        "pitch_mm": point.pitch_mm, "alpha_length_mm": point.alpha_length_mm,
        "beta_length_mm": point.beta_length_mm, "reach_mm": point.reach_mm,
        "pitch_over_reach": point.pitch_mm / point.reach_mm,
        "arm_ratio": point.alpha_length_mm / point.beta_length_mm,
        **{f"cover_{k}": frac.get(str(k)) for k in (1, 2, 3)},
        **{f"area_{k}_mm2": cov.area_mm2[str(k)] for k in (1, 2, 3)},
        "focal_plane_mm2": cov.focal_plane_area_mm2,
        "raft_fraction_mean": float(np.mean(rafts)) if rafts else None,
        "raft_fraction_min": float(np.min(rafts)) if rafts else None,
        "spacing_mm": cov.spacing_mm, "seconds": cov.seconds,
    }


def read_coverage(study_dir: str | Path) -> pa.Table:
    """The coverage table of a study folder (empty when it has none)."""
    path = Path(study_dir) / COVERAGE_FILE
    if not path.is_file():
        return COVERAGE_SCHEMA.empty_table()
    return pq.read_table(path, schema=COVERAGE_SCHEMA)


def update_coverage(study: Study, study_dir: str | Path, progress=None) -> int:
    """Measure every geometry of ``study`` not yet in ``coverage.parquet``; returns how many.

    ``progress(done, total)`` is called after each measurement."""
    out = Path(study_dir)
    have = read_coverage(out)
    done = set(have.column("geometry_id").to_pylist())
    todo: dict[str, StudyPoint] = {}
    for p in study.points:
        if p.geometry_id not in done:
            todo.setdefault(p.geometry_id, p)
    if not todo:
        return 0
    rows = have.to_pylist()
    for k, p in enumerate(todo.values(), start=1):
        rows.append(coverage_row(p))
        if progress is not None:
            progress(k, len(todo))
    table = pa.Table.from_pylist(rows, schema=COVERAGE_SCHEMA)

    def write(tmp: Path) -> None:
        pq.write_table(table, tmp)
        back = pq.ParquetFile(tmp).metadata.num_rows
        if back != table.num_rows:   # pragma: no cover (a full disk)
            raise OSError(f"{tmp}: {back} rows read back, {table.num_rows} written")

    replace_atomically(out / COVERAGE_FILE, write)
    return len(todo)

