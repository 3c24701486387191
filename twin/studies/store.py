"""A study folder on disk: one Parquet row per finished trial, one writer, resume.

Layout of a study folder::

    study.toml                       a copy of the study definition
    results/part-<key>.parquet       one trial (columns: :data:`SCHEMA`), while running
    results/compact-*.parquet        many trials merged (at :data:`COMPACT_AT` files)
    results/trials.parquet           every trial, once the study is finished
    results/.lock                    flock of the run writing here
    coverage.parquet                 design studies: coverage per geometry (:mod:`.coverage`)

When a run leaves the study complete, :func:`consolidate_results` merges every data file
of ``results/`` into ``results/trials.parquet`` (row groups of :data:`ROW_GROUP_ROWS`,
sorted by point and trial), reads the written file back (row count and keys) and only
then removes the files it replaces: ``pyarrow.parquet.read_table(folder)``,
``pandas.read_parquet(folder)``, polars or DuckDB read the folder, or the one file, in one
call. A later run (more trials) reads it to know what is done, adds part files again and
consolidates again when complete.

Each finished trial is written as ``results/part-<key>.parquet`` (to a hidden temporary
name, then renamed: a kill never leaves half a row), and a run skips every key already
present in ``results/`` (read with ``pyarrow.dataset``; duplicates are dropped by key on
every read anyway). A killed study run again loses nothing and repeats nothing. Rows are
written by the client process, so Dask workers need no shared file system.
Units of the columns: mm, deg, s.
"""
from __future__ import annotations

import fcntl
import os
import socket
from datetime import datetime, timezone
from pathlib import Path
from typing import Callable

import numpy as np
import pyarrow as pa
import pyarrow.dataset as pads
import pyarrow.parquet as pq

from rfp_twin.twin.studies.spec import Study, StudyError

__all__ = ["SCHEMA", "RESULTS", "STUDY_COPY", "COMPACT_AT", "COMPACT_PREFIX", "CONSOLIDATED",
           "ROW_GROUP_ROWS", "default_out_dir", "results_dir", "write_row", "write_study_copy",
           "data_files", "read_results", "done_keys", "compact_results", "consolidate_results",
           "write_verified", "replace_atomically", "WriterLock"]

#: Part files in results/ at which a run merges them into one file (start and end).
COMPACT_AT = 1000
RESULTS = "results"
STUDY_COPY = "study.toml"
LOCK = ".lock"
PART_PREFIX = "part-"
COMPACT_PREFIX = "compact-"
#: The one file of a finished study's trials (in results/).
CONSOLIDATED = "trials.parquet"
#: Rows per row group of merged files (readers can skip groups by point and trial).
ROW_GROUP_ROWS = 8192

#: One Parquet row per trial.
SCHEMA = pa.schema([
    ("key", pa.string()),              # resume key: hash(point, base seed, trial index)
    ("study", pa.string()),
    ("point_id", pa.string()),         # hash of the resolved grid point
    ("trial", pa.int32()),             # trial index at this point
    ("base_seed", pa.int64()),
    ("seed", pa.int64()),              # numpy default_rng seed of this trial
    ("preset", pa.string()),
    ("layout", pa.string()),
    ("n_robots", pa.int32()),
    ("n_fiducials", pa.int32()),
    ("pitch_mm", pa.float64()),
    ("alpha_length_mm", pa.float64()),
    ("beta_length_mm", pa.float64()),
    ("reach_mm", pa.float64()),        # alpha + beta
    ("pitch_over_reach", pa.float64()),
    ("segment_end_mm", pa.float64()),
    ("fold_alpha_deg", pa.float64()),  # the folded state planned to / from
    ("fold_beta_deg", pa.float64()),
    ("buffer_mm", pa.float64()),
    ("step_deg", pa.float64()),
    ("algorithm", pa.string()),
    ("greed", pa.float64()),
    ("phobia", pa.float64()),
    ("resolution", pa.string()),
    ("direction", pa.string()),
    ("max_rounds", pa.int32()),
    ("max_steps", pa.int32()),
    ("status", pa.string()),           # ok | deadlocked (left after max_rounds) | error
    ("error", pa.string()),            # the RfpError message of a failed trial
    ("efficiency", pa.float64()),      # Sayres 2021 Eq. 11
    ("convergence", pa.float64()),     # first planner run
    ("fold_time_s", pa.float64()),
    ("tau_pg_s", pa.float64()),
    ("tau_sr_s", pa.float64()),
    ("n_replaced", pa.int32()),
    ("n_deadlocked", pa.int32()),
    ("rounds", pa.int32()),
    ("n_steps", pa.int32()),
    ("checked", pa.bool_()),
    ("collisions", pa.int32()),        # collisions found by checker2d (null: not checked)
    ("min_clearance_mm", pa.float64()),
    ("check_s", pa.float64()),
    ("wall_s", pa.float64()),          # whole trial on the worker
    ("cpu_s", pa.float64()),           # CPU time of the worker thread in the trial
    ("worker", pa.string()),           # host:pid
    ("finished_utc", pa.timestamp("ms", tz="UTC")),
    # design studies (null in older rows, which pyarrow fills in when it reads them)
    ("family", pa.string()),           # [[family]] name (null: no families)
    ("design_id", pa.string()),        # hash of the point but its resolution: search / replace pairs
    ("geometry_id", pa.string()),      # hash of layout + pitch + arms: key of coverage.parquet
    ("arm_ratio", pa.float64()),       # alpha / beta
    ("n_rafts", pa.int32()),           # raft layouts only
    ("kept", pa.float64()),            # robots at their own target / movable robots
    ("targets_hash", pa.string()),     # SHA-256 of the drawn targets (equal: the same targets)
    ("plan_s", pa.float64()),          # wall time of planning (runs, searches, replacements)
    ("search_s", pa.float64()),        # of which in the deadlock search (resolution "search")
    ("fold_fw_s", pa.float64()),       # firmware-ready fold: path delay + trajectory (study.firmware)
    ("firmware_error", pa.string()),   # why post-processing failed (the plan's columns are kept)
    # yield studies (grid key catalogue; null otherwise): twin/studies/yield_trial.py
    ("catalogue", pa.string()),        # uniform | clustered
    ("density", pa.float64()),         # science targets per density_unit
    ("density_unit", pa.string()),     # robot | patrol | deg2
    ("priority_levels", pa.int32()),
    ("assign_rounds", pa.int32()),     # assign -> plan rounds allowed
    ("catalogue_text", pa.string()),   # rfp-twin plan --catalogue TEXT --seed SEED replays it
    ("n_targets", pa.int32()),         # science targets drawn in the field
    ("n_available", pa.int32()),       # of which within reach of a robot (a fiber accepts it)
    ("targets_per_robot", pa.float64()),  # n_available / robots
    ("n_assigned", pa.int32()),        # science targets assigned by the last round
    ("targets_per_pointing", pa.int32()),  # science targets assigned and kept by the plan
    ("completeness", pa.float64()),    # targets_per_pointing / n_available
    ("completeness_top", pa.float64()),  # the same for the highest priority level
    ("completeness_by_priority", pa.string()),  # JSON {level: completeness}
    ("reconfig_s", pa.float64()),      # fold -> targets: firmware-ready (path delay + trajectory)
    ("exposure_s", pa.float64()),
    ("targets_per_hour", pa.float64()),  # 3600 targets_per_pointing / (reconfig_s + exposure_s)
    ("loop_rounds", pa.int32()),       # assign -> plan rounds run
    ("loop_lost", pa.int32()),         # assigned targets the plan lost, over all rounds
    ("n_lost", pa.int32()),            # of which in the last round (0: every target kept)
    ("assign_s", pa.float64()),        # assignment wall time, all rounds
    ("assign_status", pa.string()),    # optimal | feasible | heuristic (last round)
    ("assign_gap", pa.float64()),      # (bound - objective) / bound, last round
    ("missed_busy", pa.int32()),       # targets within reach not taken: every robot busy
    ("missed_parked", pa.int32()),     # blocked only by parked neighbours' parking poses
    ("missed_neighbour", pa.int32()),  # blocked by a neighbour on another target
    ("missed_other", pa.int32()),      # none of these (forbidden by the loop, time limit)
])



def replace_atomically(dest: Path, write: Callable[[Path], object]) -> Path:
    """``write(tmp)`` to a hidden temporary beside ``dest`` (``.NAME.PID.tmp``), then rename
    it to ``dest``: readers and killed runs never see half a file."""
    tmp = dest.with_name(f".{dest.name}.{os.getpid()}.tmp")
    write(tmp)
    os.replace(tmp, dest)
    return dest


def default_out_dir(study: Study) -> Path:
    """``out/studies/<name>``: where a study runs when no folder is given."""
    return Path("out") / "studies" / study.name


def results_dir(study_dir: str | Path) -> Path:
    """The Parquet dataset folder of a study folder (or the folder itself if it is one)."""
    d = Path(study_dir)
    return d if d.name == RESULTS and not (d / RESULTS).is_dir() else d / RESULTS


def write_row(results: Path, row: dict) -> Path:
    """Write one trial as ``part-<key>.parquet``: temporary hidden name, then rename."""
    table = pa.Table.from_pylist([{k: row.get(k) for k in SCHEMA.names}], schema=SCHEMA)
    return replace_atomically(results / f"{PART_PREFIX}{row['key']}.parquet",
                              lambda tmp: pq.write_table(table, tmp))


def data_files(results: Path) -> list[Path]:
    """The Parquet files of ``results/`` (hidden temporaries and set-aside files left out)."""
    if not results.is_dir():
        return []
    return sorted(p for p in results.iterdir()
                  if p.suffix == ".parquet" and not p.name.startswith((".", "_")))


def _dedupe(table: pa.Table) -> pa.Table:
    """The first row of each key, in file order."""
    keys = table.column("key").to_numpy()
    _, first = np.unique(keys, return_index=True)
    return table if first.size == len(keys) else table.take(pa.array(np.sort(first)))


def _read_files(files: list[Path], columns: list[str] | None = None) -> pa.Table:
    if not files:
        return SCHEMA.empty_table() if columns is None else \
            pa.schema([SCHEMA.field(c) for c in columns]).empty_table()
    try:
        return pads.dataset([str(f) for f in files], format="parquet",
                            schema=SCHEMA).to_table(columns=columns)
    except (pa.ArrowInvalid, OSError):
        # a damaged file (e.g. a disk that filled up): read the others, set it aside
        parts = []
        for f in files:
            try:
                parts.append(pq.read_table(f, schema=SCHEMA, columns=columns))
            except (pa.ArrowInvalid, OSError):
                f.rename(f.with_name(f".damaged-{f.name}"))
        return pa.concat_tables(parts) if parts else _read_files([], columns)


def read_results(study_dir: str | Path) -> pa.Table:
    """Every trial row of a study folder (or of its ``results/``), one row per key."""
    return _dedupe(_read_files(data_files(results_dir(study_dir))))


def done_keys(study_dir: str | Path) -> set[str]:
    """Keys of the trials already written."""
    t = _read_files(data_files(results_dir(study_dir)), columns=["key"])
    return set(t.column("key").to_pylist())


def compact_results(study_dir: str | Path) -> Path | None:
    """Merge every data file of ``results/`` into one ``compact-*.parquet`` (deduplicated).

    The merged file is renamed into place before the files it replaces are removed, so a
    kill at any moment leaves each trial at least once (and reads dedupe by key).
    """
    results = results_dir(study_dir)
    files = data_files(results)
    if len(files) < 2:
        return None
    table = read_results(results)
    stamp = datetime.now(timezone.utc).strftime("%Y%m%dT%H%M%S%f")
    final = replace_atomically(results / f"{COMPACT_PREFIX}{stamp}-{table.num_rows}.parquet",
                               lambda tmp: pq.write_table(table, tmp))
    for f in files:
        if f != final:
            f.unlink(missing_ok=True)
    return final


def write_verified(dest: Path, table: pa.Table, *, sort: bool = True) -> Path:
    """Write ``table`` to ``dest`` (hidden temporary, read back, then renamed).

    The temporary must hold ``table.num_rows`` rows and the same set of keys, or a
    StudyError is raised and ``dest`` is left as it was. ``sort``: rows by point and trial.
    """
    if sort and table.num_rows:
        table = table.sort_by([("point_id", "ascending"), ("trial", "ascending")])
    tmp = dest.with_name(f".{dest.name}.{os.getpid()}.tmp")
    try:
        pq.write_table(table, tmp, row_group_size=ROW_GROUP_ROWS)
        n_back = pq.ParquetFile(tmp).metadata.num_rows
        keys_back = pq.read_table(tmp, columns=["key"]).column("key").to_pylist()
        if n_back != table.num_rows or set(keys_back) != set(table.column("key").to_pylist()):
            raise StudyError(f"{dest}: the merged file read back has {n_back} rows, "
                             f"{table.num_rows} were written; the per-trial files are kept")
        os.replace(tmp, dest)
    finally:
        tmp.unlink(missing_ok=True)
    return dest


def consolidate_results(study_dir: str | Path) -> Path | None:
    """Merge every data file of ``results/`` into ``results/trials.parquet`` (verified),
    then remove the others. Returns the file (None when there are no rows); a folder that
    is already one consolidated file is left alone."""
    results = results_dir(study_dir)
    files = data_files(results)
    if not files:
        return None
    final = results / CONSOLIDATED
    if files == [final]:
        return final
    write_verified(final, read_results(results))
    for f in files:
        if f != final:
            f.unlink(missing_ok=True)
    return final


class WriterLock:
    """An exclusive flock on ``results/.lock``: one writer per study folder (a second run
    gets a StudyError naming the first). A killed process releases it."""

    def __init__(self, results: Path):
        self.path = results / LOCK
        self.fh = None

    def __enter__(self):
        self.fh = open(self.path, "a+")
        try:
            fcntl.flock(self.fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            self.fh.seek(0)
            who = self.fh.read().strip() or "another process"
            self.fh.close()
            raise StudyError(f"{self.path.parent}: another run of this study is writing here "
                             f"({who}); allowed: one run per output folder at a time") from None
        self.fh.seek(0)
        self.fh.truncate()
        self.fh.write(f"pid {os.getpid()} on {socket.gethostname()}\n")
        self.fh.flush()
        return self

    def __exit__(self, *exc):
        fcntl.flock(self.fh, fcntl.LOCK_UN)
        self.fh.close()


def write_study_copy(out: Path, study: Study) -> None:
    """``out/study.toml``: the study's text (rewritten only when it changed)."""
    dest = out / STUDY_COPY
    text = study.text or ""
    if dest.is_file() and dest.read_text(encoding="utf-8") == text:
        return
    replace_atomically(dest, lambda tmp: tmp.write_text(text, encoding="utf-8"))

