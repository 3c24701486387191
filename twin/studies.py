"""Design studies: grids of simulated reconfigurations, run on Dask, stored as Parquet.

Instrument teams choose pitch, arm lengths and collision buffers from thousands of
simulated reconfigurations (Sayres 2021 ran 36,000 trials for its Fig. 10). A *study* is
a TOML file that names a parameter grid, a number of trials per grid point and a base
seed; every trial is one seeded random target draw + one reverse-planned reconfiguration
(``planners.solver.plan_reconfiguration``) + optionally the independent dense 2D check
(``validation.checker2d.check_trajectory``). Trials run as tasks on ``dask.distributed``
and each finished trial is written at once as one Parquet row.

Study file
----------
::

    [study]
    name = "sim1-small"           # output folder name; default: the file name
    description = "..."
    reference = "Sayres 2021 Table 1, Figs. 10-14"
    trials = 6                    # trials per grid point
    seed = 2021                   # base seed
    check = true                  # run checker2d on every trial (false: faster)
    batch = "auto"                # trials per Dask task ("auto" or an integer)

    [grid]                        # each key: one value or a list; the study is the product
    preset = "sdss-v"             # robot preset name, or a robot TOML path (relative to this file)
    layout = "hex"                # "hex": centred hex grid of n_robots | "sdss-v-fps":
                                  # the real 500 robots + 60 fiducials
    n_robots = 547                # centred hex count 1 + 3r(r+1): 37, 91, 169, 271, 397, 547, ...
    pitch_mm = 22.4               # default: the preset's
    alpha_length_mm = 7.4         # default: the preset's
    beta_length_mm = 15.0         # default: the preset's
    segment_end_mm = 15.0         # beta collision segment end; default: the preset's
                                  # rule (following beta_length_mm when the preset's
                                  # segment ends at the fiber)
    fold_alpha_deg = 10.0         # the folded state planned to / from; default: the preset's
    fold_beta_deg = 170.0
    buffer_mm = [1.5, 2.5, 3.5]   # sigma_cb; default: the preset's
    step_deg = 0.1
    algorithm = ["greedy", "markov"]   # "GC" / "MC" accepted; also "apf", "capf" (fields)
    greed = 0.9                   # Markov only (greedy points use greed 1, phobia 0)
    phobia = 0.3
    resolution = "replace"        # deadlock resolution: "replace" (Sayres 2021 Sect. 5.2)
                                  # | "search" (state-time search keeps targets, replaces
                                  # where it fails) | "none" (first planner run only)
    direction = "reverse"         # "reverse" | "forward"
    max_rounds = 50               # resolution rounds
    max_steps = 10000             # default: 1000 deg / step_deg (the paper's rule)

Unknown tables or keys and bad values raise :class:`StudyError` naming the file, the key
and the allowed values. Shipped studies live in ``twin/study_files/*.toml`` (``sim1``,
``sim2``, ``sim3``: the paper's Simulations 1-3 at full size (Tables 1, 2, 4); ``*-small``:
versions that finish in minutes on a laptop; ``density*``: pitch / reach x buffer maps).

Trials, seeds, resume
---------------------
A trial is (grid point, trial index). Its seed comes from ``numpy.random.SeedSequence``
with the base seed as entropy and (a stable SHA-256 hash of the point, the index) as spawn
key, so reruns, other machines and other worker counts reproduce every trial. The seed
is stored: ``rfp-twin plan --layout hex:N --buffer B --step D --algorithm A --seed SEED``
replays a hex-grid trial exactly. The trial key (hash of point, base seed, index) is the
resume key: each finished trial is written as ``results/part-<key>.parquet`` (written to
a hidden temporary name, then renamed: a kill never leaves half a row), and a run skips
every key already present in ``results/`` (read with ``pyarrow.dataset``; duplicates are
dropped by key on every read anyway). A killed study run again loses nothing and repeats
nothing. Rows are written by the client process, so Dask workers need no shared file
system; a batch of a few small-grid trials comes back, and is written, together.

Where trials run
----------------
By default on a ``LocalCluster`` sized to the machine (one single-threaded worker process
per core: the numba kernels hold the GIL). ``scheduler="tcp://HOST:8786"`` (CLI:
``--scheduler``) sends the same study to any running Dask cluster whose workers have
rfp-twin installed (same version). On a SLURM cluster use dask-jobqueue::

    # on the login node, e.g. in a Python session kept open (or a script with input())
    from dask_jobqueue import SLURMCluster
    cluster = SLURMCluster(cores=1, processes=1, memory="2GB", walltime="04:00:00",
                           job_extra_directives=["--partition=short"])
    cluster.scale(jobs=64)                 # or cluster.adapt(maximum_jobs=64)
    print(cluster.scheduler_address)       # tcp://10.0.0.5:8786

    $ rfp-twin study run sim1 --scheduler tcp://10.0.0.5:8786

or from Python: ``run_study(load_study("sim1"), client=Client(cluster))``. The client
(login node) writes the Parquet rows; kill it and run it again to resume.

Columns of a row: see :data:`SCHEMA`.
"""
from __future__ import annotations

import fcntl
import functools
import hashlib
import itertools
import json
import math
import os
import re
import socket
import time
import tomllib
from dataclasses import dataclass, field
from datetime import datetime, timezone
from importlib import resources
from pathlib import Path
from typing import Any, Callable

import numpy as np
import pyarrow as pa
import pyarrow.dataset as pads
import pyarrow.parquet as pq

from models.errors import PlanningError, RfpError
from models.layout import Layout, _nearest_hex_counts, hex_rings
from models.robot import RobotSpec, list_presets, load_spec

__all__ = [
    "StudyError", "Study", "StudyPoint", "Trial", "RunSummary", "SCHEMA", "GRID_KEYS",
    "STUDY_KEYS", "list_studies", "study_path", "load_study", "parse_study", "run_trial",
    "run_study", "read_results", "done_keys", "write_row", "compact_results",
    "results_dir", "default_out_dir",
]


class StudyError(RfpError):
    """A study file is malformed, has an unknown key or a bad value, or a run cannot start."""


# =====================================================================================
# Constants: keys, allowed values, defaults
# =====================================================================================
#: Keys of the [study] table and what they hold.
STUDY_KEYS = {
    "name": "a folder-safe name (letters, digits, . _ -)",
    "description": "a string",
    "reference": "a string",
    "trials": "an integer >= 1 (trials per grid point)",
    "seed": "an integer >= 0 (base seed)",
    "check": "true | false (run the 2D checker on every trial)",
    "batch": "\"auto\" or an integer >= 1 (trials per Dask task)",
}
#: Keys of the [grid] table and what they hold.
GRID_KEYS = {
    "preset": "a robot preset name or a path to a robot TOML",
    "layout": "\"hex\" | \"sdss-v-fps\"",
    "n_robots": "a centred hex count 1 + 3r(r+1) (7, 19, 37, 61, 91, ..., 547, ...)",
    "pitch_mm": "a number > 0 (mm)",
    "alpha_length_mm": "a number > 0 (mm)",
    "beta_length_mm": "a number > 0 (mm)",
    "segment_end_mm": "a number >= 0 (mm)",
    "fold_alpha_deg": "a number (deg) within the preset's alpha limits",
    "fold_beta_deg": "a number (deg) within the preset's beta limits",
    "buffer_mm": "a number > 0 (mm), below pitch / 2",
    "step_deg": "a number in [0.001, 10] (deg)",
    "algorithm": "greedy | markov (GC / MC accepted) | apf | capf",
    "greed": "a number in [0, 1]",
    "phobia": "a number in [0, 1]",
    "resolution": "replace | search | none",
    "direction": "reverse | forward",
    "max_rounds": "an integer >= 0",
    "max_steps": "an integer >= 1",
}
LAYOUTS = ("hex", "sdss-v-fps")
RESOLUTIONS = ("replace", "search", "none")
ALGORITHM_ALIASES = {"greedy": "greedy", "gc": "greedy", "markov": "markov", "mc": "markov",
                     "apf": "apf", "capf": "capf"}
#: Potential-field planners (planners/apf.py): direct fold -> targets, segment model,
#: gain 1, lambda3 0.03 (capf); step, direction, resolution and greed do not apply.
FIELD_ALGORITHMS = ("apf", "capf")
#: Extra target clearance beyond the field barrier, mm (as `rfp-twin plan`).
FIELD_TARGET_SLACK_MM = 0.5
DIRECTIONS = ("reverse", "forward")
GRID_DEFAULTS = {
    "preset": "sdss-v", "layout": "hex", "n_robots": 547, "pitch_mm": None,
    "alpha_length_mm": None, "beta_length_mm": None, "segment_end_mm": None,
    "fold_alpha_deg": None, "fold_beta_deg": None, "buffer_mm": None, "step_deg": 0.1,
    "algorithm": "greedy", "greed": 0.9, "phobia": 0.3, "resolution": "replace", "direction": "reverse", "max_rounds": 50, "max_steps": None,
}
NAME_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]*$")
#: Robots per Dask task when ``batch = "auto"`` (a 547-grid trial is its own task).
AUTO_BATCH_ROBOTS = 300
AUTO_BATCH_MAX = 32
#: Part files in results/ at which a run merges them into one file (start and end).
COMPACT_AT = 1000
RESULTS = "results"
STUDY_COPY = "study.toml"
LOCK = ".lock"
PART_PREFIX = "part-"
COMPACT_PREFIX = "compact-"

#: Parameter columns (one per grid key, resolved) in row order.
PARAM_COLUMNS = ("preset", "layout", "n_robots", "pitch_mm", "alpha_length_mm",
                 "beta_length_mm", "segment_end_mm", "fold_alpha_deg", "fold_beta_deg",
                 "buffer_mm", "step_deg", "algorithm",
                 "greed", "phobia", "resolution", "direction", "max_rounds", "max_steps")

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
])


# =====================================================================================
# Study definition
# =====================================================================================
@dataclass(frozen=True)
class StudyPoint:
    """One resolved grid point: every parameter explicit (no preset defaults left)."""

    preset: str
    layout: str
    n_robots: int
    pitch_mm: float
    alpha_length_mm: float
    beta_length_mm: float
    segment_end_mm: float
    fold_alpha_deg: float
    fold_beta_deg: float
    buffer_mm: float
    step_deg: float
    algorithm: str
    greed: float
    phobia: float
    resolution: str
    direction: str
    max_rounds: int
    max_steps: int
    spec: RobotSpec = field(compare=False, repr=False, default=None)  # type: ignore[assignment]

    def to_dict(self) -> dict[str, Any]:
        """The parameters as plain Python values (the hash input)."""
        return {k: getattr(self, k) for k in PARAM_COLUMNS}

    @functools.cached_property
    def canonical(self) -> str:
        return json.dumps(self.to_dict(), sort_keys=True, separators=(",", ":"))

    @functools.cached_property
    def point_id(self) -> str:
        """Stable 12-hex-digit id of the point."""
        return hashlib.sha256(self.canonical.encode()).hexdigest()[:12]

    @property
    def reach_mm(self) -> float:
        return self.alpha_length_mm + self.beta_length_mm

    def trial_key(self, base_seed: int, index: int) -> str:
        """Resume key of trial ``index``: 20 hex digits."""
        text = f"{self.canonical}|seed={int(base_seed)}|trial={int(index)}"
        return hashlib.sha256(text.encode()).hexdigest()[:20]

    def trial_seed(self, base_seed: int, index: int) -> int:
        """Seed of trial ``index`` (a non-negative int64 for ``numpy.random.default_rng``)."""
        h = hashlib.sha256(self.canonical.encode()).digest()
        words = (int.from_bytes(h[0:4], "little"), int.from_bytes(h[4:8], "little"))
        ss = np.random.SeedSequence(entropy=int(base_seed), spawn_key=(*words, int(index)))
        return int(ss.generate_state(1, np.uint64)[0] >> np.uint64(1))


@dataclass(frozen=True)
class Trial:
    point: StudyPoint
    index: int
    key: str
    seed: int


@dataclass(frozen=True)
class Study:
    """A parsed, validated study.

    Attributes
    ----------
    name, description, reference : str
    trials : int, trials per point
    seed : int, base seed
    check : bool, run checker2d per trial
    batch : "auto" or int, trials per Dask task
    grid : {key: tuple of values}, as written (after alias normalisation)
    points : tuple of StudyPoint, the product of the grid (duplicates removed)
    source : str, file path or "study <name>"
    text : str, the TOML text
    """

    name: str
    description: str
    reference: str
    trials: int
    seed: int
    check: bool
    batch: str | int
    grid: dict
    points: tuple
    source: str
    text: str = field(repr=False, default="")

    @property
    def n_trials(self) -> int:
        return self.trials * len(self.points)

    def varied(self) -> list[str]:
        """Grid keys with more than one value."""
        return [k for k, v in self.grid.items() if len(v) > 1]

    def trial_list(self, trials: int | None = None) -> list[Trial]:
        """All trials, index-major (every point's trial 0, then every point's trial 1 ...),
        so a partial run covers the whole grid evenly."""
        n = self.trials if trials is None else int(trials)
        out = []
        for i in range(n):
            for p in self.points:
                out.append(Trial(p, i, p.trial_key(self.seed, i), p.trial_seed(self.seed, i)))
        return out


def list_studies() -> list[str]:
    """Names of the studies shipped with rfp-twin (``twin/study_files/*.toml``)."""
    root = resources.files("twin.study_files")
    return sorted(p.name[:-5] for p in root.iterdir() if p.name.endswith(".toml"))


def study_path(name_or_path: str | Path) -> Path:
    """Path of a study file: a shipped study name (``sim1-small``) or a path."""
    path = Path(name_or_path)
    if path.suffix == ".toml" or path.is_file():
        if not path.is_file():
            raise StudyError(f"{path}: study file not found; allowed: an existing .toml file or a "
                             f"shipped study ({', '.join(list_studies())})")
        return path
    ref = resources.files("twin.study_files") / f"{name_or_path}.toml"
    if not ref.is_file():
        raise StudyError(f"unknown study {str(name_or_path)!r}; allowed: "
                         f"{', '.join(list_studies())} or a path to a .toml file")
    return Path(str(ref))


def load_study(name_or_path: str | Path) -> Study:
    """Load and validate a study: a shipped name (``sim1``, ``sim1-small`` ...) or a path."""
    path = study_path(name_or_path)
    shipped = not (Path(name_or_path).suffix == ".toml" or Path(name_or_path).is_file())
    source = f"study {name_or_path}" if shipped else str(path)
    return parse_study(path.read_text(encoding="utf-8"), source=source, base_dir=path.parent,
                       default_name=path.stem)


def _bad(source: str, where: str, value, allowed: str) -> StudyError:
    return StudyError(f"{source}: {where} = {value!r}; allowed: {allowed}")


def _is_int(v) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _is_num(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def parse_study(text: str, source: str = "<study>", base_dir: str | Path | None = None,
                default_name: str = "study") -> Study:
    """Parse and validate study TOML text (see the module docstring for the format)."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise StudyError(f"{source}: malformed TOML ({exc}); allowed: a TOML file with tables "
                         "'study' and 'grid'") from None
    unknown = sorted(set(data) - {"study", "grid"})
    if unknown:
        raise StudyError(f"{source}: unknown table or key {unknown[0]!r}; allowed: tables 'study' "
                         "and 'grid'")
    st = data.get("study", {})
    gr = data.get("grid", {})
    for name, tab in (("study", st), ("grid", gr)):
        if not isinstance(tab, dict):
            raise StudyError(f"{source}: '{name}' must be a table; allowed: a TOML table '{name}'")
    for key in st:
        if key not in STUDY_KEYS:
            raise StudyError(f"{source}: unknown key '{key}' in table 'study'; allowed: "
                             + ", ".join(STUDY_KEYS))
    for key in gr:
        if key not in GRID_KEYS:
            raise StudyError(f"{source}: unknown key '{key}' in table 'grid'; allowed: "
                             + ", ".join(GRID_KEYS))

    name = st.get("name", default_name)
    if not isinstance(name, str) or not NAME_RE.match(name):
        raise _bad(source, "study.name", name, STUDY_KEYS["name"])
    for key in ("description", "reference"):
        if not isinstance(st.get(key, ""), str):
            raise _bad(source, f"study.{key}", st[key], STUDY_KEYS[key])
    trials = st.get("trials", 1)
    if not _is_int(trials) or trials < 1:
        raise _bad(source, "study.trials", trials, STUDY_KEYS["trials"])
    seed = st.get("seed", 0)
    if not _is_int(seed) or seed < 0:
        raise _bad(source, "study.seed", seed, STUDY_KEYS["seed"])
    check = st.get("check", True)
    if not isinstance(check, bool):
        raise _bad(source, "study.check", check, STUDY_KEYS["check"])
    batch = st.get("batch", "auto")
    if not (batch == "auto" or (_is_int(batch) and batch >= 1)):
        raise _bad(source, "study.batch", batch, STUDY_KEYS["batch"])

    grid: dict[str, tuple] = {}
    for key, default in GRID_DEFAULTS.items():
        raw = gr.get(key, default)
        values = list(raw) if isinstance(raw, list) else [raw]
        if not values:
            raise _bad(source, f"grid.{key}", raw, "a value or a non-empty list of values")
        norm = [_check_value(source, key, v) for v in values]
        if len(set(norm)) != len(norm):
            raise _bad(source, f"grid.{key}", raw, "a list without repeated values")
        grid[key] = tuple(norm)

    base = Path(base_dir) if base_dir is not None else Path.cwd()
    specs: dict[str, RobotSpec] = {}
    for preset in grid["preset"]:
        specs[preset] = _load_preset(source, preset, base)

    points: list[StudyPoint] = []
    seen: set[str] = set()
    for combo in itertools.product(*grid.values()):
        p = _resolve_point(source, dict(zip(grid, combo)), specs)
        if p.canonical not in seen:
            seen.add(p.canonical)
            points.append(p)
    return Study(name=name, description=st.get("description", ""),
                 reference=st.get("reference", ""), trials=trials, seed=seed, check=check,
                 batch=batch, grid=grid, points=tuple(points), source=source, text=text)


#: Numeric grid keys: (low, high, low excluded, integer); None = unbounded.
_NUMERIC = {
    "fold_alpha_deg": (None, None, False, False), "fold_beta_deg": (None, None, False, False),
    "pitch_mm": (0.0, None, True, False), "alpha_length_mm": (0.0, None, True, False),
    "beta_length_mm": (0.0, None, True, False), "buffer_mm": (0.0, None, True, False),
    "segment_end_mm": (0.0, None, False, False), "step_deg": (0.001, 10.0, False, False),
    "greed": (0.0, 1.0, False, False), "phobia": (0.0, 1.0, False, False),
    "max_rounds": (0, None, False, True), "max_steps": (1, None, False, True),
}


def _check_value(source: str, key: str, v):
    """Validate one grid value on its own; returns it normalised."""
    where = f"grid.{key}"
    allowed = GRID_KEYS[key]
    if v is None:
        return None
    if key in _NUMERIC:
        lo, hi, lo_open, integer = _NUMERIC[key]
        ok = _is_int(v) if integer else _is_num(v)
        if ok and lo is not None:
            ok = v > lo if lo_open else v >= lo
        if ok and hi is not None:
            ok = v <= hi
        if not ok:
            raise _bad(source, where, v, allowed)
        return int(v) if integer else float(v)
    if key == "preset":
        if not isinstance(v, str) or not v:
            raise _bad(source, where, v, allowed)
        return v
    if key == "n_robots":
        if not _is_int(v) or v < 1:
            raise _bad(source, where, v, allowed)
        if hex_rings(v) is None:
            near = ", ".join(map(str, _nearest_hex_counts(v)))
            raise _bad(source, where, v, f"{allowed}; nearest: {near}")
        return int(v)
    if key == "algorithm":
        a = ALGORITHM_ALIASES.get(str(v).lower()) if isinstance(v, str) else None
        if a is None:
            raise _bad(source, where, v, allowed)
        return a
    choices = {"layout": LAYOUTS, "resolution": RESOLUTIONS, "direction": DIRECTIONS}[key]
    if v not in choices:
        raise _bad(source, where, v, allowed)
    return v


def _load_preset(source: str, preset: str, base: Path) -> RobotSpec:
    path = Path(preset)
    if path.suffix == ".toml" and not path.is_absolute():
        path = base / path
    try:
        return load_spec(path if path.suffix == ".toml" else preset)
    except RfpError as exc:
        raise StudyError(f"{source}: grid.preset = {preset!r}: {exc}; allowed: "
                         f"{', '.join(list_presets())} or a robot TOML path") from None


def _resolve_point(source: str, raw: dict, specs: dict[str, RobotSpec]) -> StudyPoint:
    """Fill preset defaults, build the RobotSpec, check the combination."""
    base = specs[raw["preset"]]
    where = ", ".join(f"{k}={v}" for k, v in raw.items() if v is not None)
    layout = raw["layout"]
    if layout == "sdss-v-fps":
        lay = _layout("sdss-v-fps", 0, 0.0)
        n_robots = lay.n_robots
        if raw["pitch_mm"] is not None and abs(raw["pitch_mm"] - 22.4) > 1e-9:
            raise StudyError(f"{source}: grid.pitch_mm = {raw['pitch_mm']} with layout = "
                             "'sdss-v-fps' (point " + where + "); allowed: unset or 22.4 (the "
                             "real focal plane has a fixed pitch)")
        pitch = 22.4
    else:
        n_robots = raw["n_robots"]
        pitch = raw["pitch_mm"] if raw["pitch_mm"] is not None else base.pitch_mm
    la = raw["alpha_length_mm"] if raw["alpha_length_mm"] is not None else base.alpha_length_mm
    lb = raw["beta_length_mm"] if raw["beta_length_mm"] is not None else base.beta_length_mm
    buffer = raw["buffer_mm"] if raw["buffer_mm"] is not None else base.buffer_mm
    if raw["segment_end_mm"] is not None:
        seg = raw["segment_end_mm"]
    elif isinstance(base.segment_end_mm, str):
        seg = base.segment_end(buffer)           # e.g. the SDSS-V production rule
    elif abs(float(base.segment_end_mm) - base.beta_length_mm) < 1e-12:
        seg = lb                                 # the segment runs to the fiber: follow the arm
    else:
        seg = float(base.segment_end_mm)
    fold = (raw["fold_alpha_deg"] if raw["fold_alpha_deg"] is not None else base.fold_deg[0],
            raw["fold_beta_deg"] if raw["fold_beta_deg"] is not None else base.fold_deg[1])
    try:
        spec = base.with_overrides(pitch_mm=pitch, alpha_length_mm=la, beta_length_mm=lb,
                                   segment_end_mm=float(seg), buffer_mm=buffer,
                                   fold_deg=(float(fold[0]), float(fold[1])))
    except RfpError as exc:
        raise StudyError(f"{source}: grid point ({where}): {exc}") from None
    if not buffer < pitch / 2:
        raise StudyError(f"{source}: grid.buffer_mm = {buffer} at pitch_mm = {pitch} (point "
                         f"{where}); allowed: buffer_mm < pitch_mm / 2 = {pitch / 2}")
    alg = raw["algorithm"]
    greed, phobia = (raw["greed"], raw["phobia"]) if alg == "markov" else (1.0, 0.0)
    max_steps = raw["max_steps"] if raw["max_steps"] is not None else \
        int(round(1000.0 / raw["step_deg"]))
    return StudyPoint(preset=raw["preset"], layout=layout, n_robots=int(n_robots),
                      pitch_mm=float(pitch), alpha_length_mm=float(la), beta_length_mm=float(lb),
                      segment_end_mm=float(seg), fold_alpha_deg=float(fold[0]),
                      fold_beta_deg=float(fold[1]), buffer_mm=float(buffer),
                      step_deg=float(raw["step_deg"]), algorithm=alg, greed=float(greed),
                      phobia=float(phobia), resolution=raw["resolution"],
                      direction=raw["direction"], max_rounds=int(raw["max_rounds"]),
                      max_steps=int(max_steps), spec=spec)


# =====================================================================================
# One trial (runs on a Dask worker)
# =====================================================================================
@functools.lru_cache(maxsize=8)
def _layout(kind: str, n_robots: int, pitch_mm: float) -> Layout:
    if kind == "sdss-v-fps":
        return Layout.sdss_v_fps()
    return Layout.hex_grid_positions(n_robots, pitch_mm)


@functools.lru_cache(maxsize=16)
def _geometry(spec: RobotSpec, kind: str, n_robots: int):
    from models.array import ArrayGeometry

    lay = _layout(kind, n_robots, spec.pitch_mm)
    return lay, ArrayGeometry(spec, lay, spec.buffer_mm)


_WARM = False


def _warm_up() -> None:
    """Load (or compile) every numba kernel once per process, so that the first trial's
    tau_pg measures planning and not the JIT cache."""
    global _WARM
    if _WARM:
        return
    spec = load_spec("sdss-v").with_overrides(buffer_mm=2.0)
    point = dict(preset="sdss-v", layout="hex", n_robots=7, pitch_mm=22.4, alpha_length_mm=7.4,
                 beta_length_mm=15.0, segment_end_mm=15.0, fold_alpha_deg=10.0,
                 fold_beta_deg=170.0, buffer_mm=2.0, step_deg=1.0,
                 greed=0.9, phobia=0.3, resolution="replace", direction="reverse",
                 max_rounds=5, max_steps=1000)
    for alg in ("greedy", "markov"):
        _trial_row(dict(point, algorithm=alg), spec, 0, 0, True)
    _WARM = True


def run_trial(point: StudyPoint, index: int, base_seed: int, check: bool = True,
              study: str = "") -> dict:
    """Run one trial in this process; returns its row (a dict with the :data:`SCHEMA` columns)."""
    row = _trial_row(point.to_dict(), point.spec, point.trial_seed(base_seed, index), index, check)
    row.update(key=point.trial_key(base_seed, index), study=study, point_id=point.point_id,
               base_seed=int(base_seed))
    return row


def _run_batch(batch: list[tuple[dict, RobotSpec, int, int, str, str]], check: bool,
               study: str, base_seed: int) -> list[dict]:
    """Dask task: a few trials. Items are (point dict, spec, trial index, seed, key, point id)."""
    _warm_up()
    rows = []
    for point, spec, index, seed, key, pid in batch:
        row = _trial_row(point, spec, seed, index, check)
        row.update(key=key, study=study, point_id=pid, base_seed=int(base_seed))
        rows.append(row)
    return rows


def _trial_row(point: dict, spec: RobotSpec, seed: int, index: int, check: bool) -> dict:
    from planners.solver import PlannerSettings, plan_reconfiguration
    from planners.stepwise import max_displacement
    from planners.targets import random_targets

    t0, c0 = time.perf_counter(), time.thread_time()
    row: dict[str, Any] = {k: point[k] for k in PARAM_COLUMNS}
    la, lb = point["alpha_length_mm"], point["beta_length_mm"]
    row.update(trial=int(index), seed=int(seed), reach_mm=la + lb,
               pitch_over_reach=point["pitch_mm"] / (la + lb), checked=bool(check),
               worker=f"{socket.gethostname()}:{os.getpid()}", error=None)
    try:
        lay, geom = _geometry(spec, point["layout"], int(point["n_robots"]))
        row["n_fiducials"] = lay.n_fiducials
        if point["algorithm"] in FIELD_ALGORITHMS:
            return _field_trial(row, point, spec, lay, geom, seed, check, t0, c0)
        settings = PlannerSettings(algorithm=point["algorithm"], step_deg=point["step_deg"],
                                   greed=point["greed"], phobia=point["phobia"],
                                   direction=point["direction"], max_steps=point["max_steps"],
                                   max_rounds=point["max_rounds"],
                                   resolve="search" if point["resolution"] == "search" else "replace")
        fold = np.tile(np.asarray(spec.fold_deg, dtype=np.float64), (geom.n_robots, 1))
        clear = geom.pair_clearance(fold)
        if clear.size and clear.min() <= 0.0:
            raise PlanningError(f"folded state {tuple(spec.fold_deg)} deg collides (clearance "
                                f"{clear.min():.3f} mm at pitch {spec.pitch_mm:g} mm, buffer "
                                f"{spec.buffer_mm:g} mm): infeasible")
        # the same sequence as `rfp-twin plan --seed SEED`: targets, then the plan
        rng = np.random.default_rng(int(seed))
        md = max_displacement(spec.alpha_length_mm, spec.beta_length_mm,
                              float(geom.seg_end.max()), settings.step_deg)
        targets = random_targets(geom, rng, margin_mm=md)
        plan = plan_reconfiguration(geom, targets, settings, rng,
                                    resolve=point["resolution"] != "none")
        m = plan.metrics
        row.update(efficiency=float(m["efficiency"]), convergence=float(m["convergence"]),
                   fold_time_s=float(m["fold_time_s"]), tau_pg_s=float(m["tau_pg_s"]),
                   tau_sr_s=float(m["tau_sr_s"]), n_replaced=int(m["n_replaced"]),
                   n_deadlocked=int(m["n_deadlocked"]), rounds=int(m["rounds"]),
                   n_steps=int(m["n_steps"]),
                   status="deadlocked" if m["n_deadlocked"] else "ok")
        if check:
            from models.trajectory import Trajectory
            from validation.checker2d import check_trajectory

            t1 = time.perf_counter()
            rep = check_trajectory(Trajectory.from_plan(plan), spec, lay, spec.buffer_mm)
            row.update(collisions=len(rep.collisions), check_s=time.perf_counter() - t1,
                       min_clearance_mm=float(rep.min_clearance_mm)
                       if math.isfinite(rep.min_clearance_mm) else None)
    except RfpError as exc:  # e.g. no clear random targets in a very dense array
        row.update(status="error", error=f"{type(exc).__name__}: {exc}")
    row["wall_s"] = time.perf_counter() - t0
    row["cpu_s"] = time.thread_time() - c0
    row["finished_utc"] = datetime.now(timezone.utc)
    return row


def _field_trial(row: dict, point: dict, spec: RobotSpec, lay, geom, seed: int, check: bool,
                 t0: float, c0: float) -> dict:
    """One APF / CAPF trial: targets clear of the field's barrier, fold -> targets."""
    from planners.apf import ApfSettings, apf_target_margin_mm, plan_apf_reconfiguration
    from planners.capf import CapfSettings
    from planners.targets import random_targets

    alg = point["algorithm"]
    field = CapfSettings(model="segment") if alg == "capf" else ApfSettings(model="segment")
    rng = np.random.default_rng(int(seed))
    targets = random_targets(geom, rng, margin_mm=apf_target_margin_mm(geom, field)
                             + FIELD_TARGET_SLACK_MM)
    _, res = plan_apf_reconfiguration(geom, targets, field, algorithm=alg)
    m = res.metrics()
    row.update(efficiency=float(m["efficiency"]), convergence=float(m["convergence"]),
               fold_time_s=float(m["fold_time_s"]), tau_pg_s=float(m["tau_pg_s"]),
               tau_sr_s=float(m["tau_sr_s"]), n_replaced=0, n_deadlocked=int(m["n_deadlocked"]),
               rounds=0, n_steps=int(m["n_steps"]),
               status="deadlocked" if m["n_deadlocked"] else "ok")
    if check:
        from validation.checker2d import check_trajectory

        t1 = time.perf_counter()
        rep = check_trajectory(res.trajectory, spec, lay, spec.buffer_mm)
        row.update(collisions=len(rep.collisions), check_s=time.perf_counter() - t1,
                   min_clearance_mm=float(rep.min_clearance_mm)
                   if math.isfinite(rep.min_clearance_mm) else None)
    row["wall_s"] = time.perf_counter() - t0
    row["cpu_s"] = time.thread_time() - c0
    row["finished_utc"] = datetime.now(timezone.utc)
    return row


# =====================================================================================
# Results on disk
# =====================================================================================
def default_out_dir(study: Study) -> Path:
    return Path("out") / "studies" / study.name


def results_dir(study_dir: str | Path) -> Path:
    """The Parquet dataset folder of a study folder (or the folder itself if it is one)."""
    d = Path(study_dir)
    return d if d.name == RESULTS and not (d / RESULTS).is_dir() else d / RESULTS


def write_row(results: Path, row: dict) -> Path:
    """Write one trial as ``part-<key>.parquet``: temporary hidden name, then rename."""
    name = f"{PART_PREFIX}{row['key']}.parquet"
    tmp = results / f".{name}.{os.getpid()}.tmp"
    table = pa.Table.from_pylist([{k: row.get(k) for k in SCHEMA.names}], schema=SCHEMA)
    pq.write_table(table, tmp)
    os.replace(tmp, results / name)
    return results / name


def _data_files(results: Path) -> list[Path]:
    if not results.is_dir():
        return []
    return sorted(p for p in results.iterdir()
                  if p.suffix == ".parquet" and not p.name.startswith((".", "_")))


def _dedupe(table: pa.Table) -> pa.Table:
    keys = table.column("key").to_pylist()
    seen: set[str] = set()
    keep = []
    for i, k in enumerate(keys):
        if k not in seen:
            seen.add(k)
            keep.append(i)
    return table if len(keep) == len(keys) else table.take(pa.array(keep, type=pa.int64()))


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
    return _dedupe(_read_files(_data_files(results_dir(study_dir))))


def done_keys(study_dir: str | Path) -> set[str]:
    """Keys of the trials already written."""
    t = _read_files(_data_files(results_dir(study_dir)), columns=["key"])
    return set(t.column("key").to_pylist())


def compact_results(study_dir: str | Path) -> Path | None:
    """Merge every data file of ``results/`` into one ``compact-*.parquet`` (deduplicated).

    The merged file is renamed into place before the files it replaces are removed, so a
    kill at any moment leaves each trial at least once (and reads dedupe by key).
    """
    results = results_dir(study_dir)
    files = _data_files(results)
    if len(files) < 2:
        return None
    table = read_results(results)
    stamp = datetime.now(timezone.utc).strftime("%Y%m%dT%H%M%S%f")
    final = results / f"{COMPACT_PREFIX}{stamp}-{table.num_rows}.parquet"
    tmp = results / f".{final.name}.{os.getpid()}.tmp"
    pq.write_table(table, tmp)
    os.replace(tmp, final)
    for f in files:
        if f != final:
            f.unlink(missing_ok=True)
    return final


class _Lock:
    """An exclusive flock on ``results/.lock``: one writer per study folder. A killed
    process releases it."""

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


# =====================================================================================
# Running on Dask
# =====================================================================================
@dataclass
class RunSummary:
    """What :func:`run_study` did.

    n_total : trials in the study; n_before : already written when the run started;
    n_run : written by this run; n_errors / n_collisions : trials of this run with an
    error / with collisions found; seconds : from the first submission to the last
    result; setup_s : cluster start-up and resume scan; workers : Dask worker threads;
    rate_per_min : n_run / seconds * 60; complete : every trial is written.
    """

    study: str
    out_dir: Path
    n_total: int
    n_before: int
    n_run: int
    n_errors: int
    n_collisions: int
    seconds: float
    setup_s: float
    workers: int
    scheduler: str
    complete: bool

    @property
    def rate_per_min(self) -> float:
        return 60.0 * self.n_run / self.seconds if self.seconds > 0 else 0.0


def machine_workers() -> int:
    """Worker processes of the default LocalCluster: the cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover (not Linux)
        return max(1, os.cpu_count() or 1)


def _batches(trials: list[Trial], batch: str | int) -> list[list[Trial]]:
    out: list[list[Trial]] = []
    cur: list[Trial] = []
    robots = 0
    for t in trials:
        cur.append(t)
        robots += t.point.n_robots
        full = (len(cur) >= batch) if batch != "auto" else \
            (robots >= AUTO_BATCH_ROBOTS or len(cur) >= AUTO_BATCH_MAX)
        if full:
            out.append(cur)
            cur, robots = [], 0
    if cur:
        out.append(cur)
    return out


def _write_study_copy(out: Path, study: Study) -> None:
    dest = out / STUDY_COPY
    text = study.text or ""
    if dest.is_file() and dest.read_text(encoding="utf-8") == text:
        return
    tmp = out / f".{STUDY_COPY}.{os.getpid()}.tmp"
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, dest)


def run_study(study: Study, out_dir: str | Path | None = None, *, scheduler: str | None = None,
              workers: int | None = None, processes: bool = True, client=None,
              trials: int | None = None, max_trials: int | None = None,
              progress: bool | Callable[[int, int], None] = True, console=None) -> RunSummary:
    """Run every trial of ``study`` not yet in ``out_dir/results``; write each as it finishes.

    Parameters
    ----------
    study : Study
    out_dir : study folder (default ``out/studies/<name>``); gets ``study.toml`` (a copy of
        the definition) and ``results/`` (the Parquet dataset).
    scheduler : ``tcp://HOST:PORT`` of a running Dask scheduler; default a new LocalCluster.
    workers : LocalCluster worker count (default: the cores of this machine).
    processes : LocalCluster workers as processes (True) or threads of this process.
    client : an existing ``distributed.Client`` to use instead (not closed here).
    trials : trials per point instead of the study's (keys do not depend on it, so a larger
        value later extends the same study).
    max_trials : stop after this many new trials (a partial run; run again to go on).
    progress : True: a rich progress bar (trials done / total, trials per minute);
        a callable(done, total); or False.
    console : rich Console for messages and the bar (default stderr).

    Returns
    -------
    RunSummary
    """
    from distributed import Client, LocalCluster, as_completed

    t_setup = time.perf_counter()
    out = Path(out_dir) if out_dir is not None else default_out_dir(study)
    results = out / RESULTS
    results.mkdir(parents=True, exist_ok=True)
    if scheduler is not None and client is not None:
        raise StudyError("give either scheduler or client, not both")
    if workers is not None and (not _is_int(workers) or workers < 1):
        raise StudyError(f"workers = {workers!r}; allowed: an integer >= 1")
    if trials is not None and (not _is_int(trials) or trials < 1):
        raise StudyError(f"trials = {trials!r}; allowed: an integer >= 1")

    with _Lock(results):
        for stale in results.glob(".*.tmp"):      # left by a killed run
            stale.unlink(missing_ok=True)
        _write_study_copy(out, study)
        if len(_data_files(results)) >= COMPACT_AT:
            compact_results(out)
        all_trials = study.trial_list(trials)
        done = done_keys(out)
        todo = [t for t in all_trials if t.key not in done]
        n_before = len(all_trials) - len(todo)
        if max_trials is not None:
            todo = todo[:max(0, int(max_trials))]
        batches = _batches(todo, study.batch)

        own_cluster = own_client = None
        try:
            if not batches:
                pass                              # nothing to do: no cluster
            elif client is None:
                if scheduler is not None:
                    try:
                        own_client = client = Client(scheduler, timeout="30s")
                    except (OSError, TimeoutError, ValueError) as exc:
                        raise StudyError(f"cannot reach the Dask scheduler at {scheduler!r} "
                                         f"({type(exc).__name__}: {exc}); allowed: the address "
                                         "of a running scheduler, e.g. tcp://HOST:8786") from None
                else:
                    own_cluster = LocalCluster(
                        n_workers=workers or machine_workers(), threads_per_worker=1,
                        processes=processes, dashboard_address=None,
                        silence_logs=50)  # logging.CRITICAL: no heartbeat noise at close
                    own_client = client = Client(own_cluster)
            if client is None:
                n_threads, sched = 0, "none (nothing left to run)"
            else:
                n_threads = max(1, sum(client.nthreads().values()))
                sched = scheduler or (f"LocalCluster({len(client.nthreads())} "
                                      f"{'processes' if processes else 'threads'})"
                                      if own_cluster else str(client.scheduler.address))
            setup_s = time.perf_counter() - t_setup
            summary = RunSummary(study.name, out, len(all_trials), n_before, 0, 0, 0, 0.0,
                                 setup_s, n_threads, sched, False)
            if batches:
                _drive(client, as_completed, study, batches, results, summary, n_threads,
                       progress, console)
        finally:
            if own_client is not None:
                own_client.close()
            if own_cluster is not None:
                own_cluster.close()
        if len(_data_files(results)) >= COMPACT_AT:
            compact_results(out)
    summary.complete = summary.n_before + summary.n_run >= summary.n_total
    return summary


def _drive(client, as_completed, study: Study, batches: list[list[Trial]], results: Path,
           summary: RunSummary, n_threads: int, progress, console) -> None:
    """Submit batches with a bounded window; write rows as results arrive."""
    it = iter(batches)
    by_key: dict[str, list[Trial]] = {}
    bar = None
    callback = progress if callable(progress) else None
    if progress is True:
        from rich.console import Console
        from rich.progress import (BarColumn, MofNCompleteColumn, Progress, TextColumn,
                                   TimeElapsedColumn, TimeRemainingColumn)

        bar = Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(),
                       TextColumn("trials  {task.fields[rate]}"), TimeElapsedColumn(),
                       TextColumn("eta"), TimeRemainingColumn(),
                       console=console or Console(stderr=True))
        task = bar.add_task(study.name, total=summary.n_total, completed=summary.n_before,
                            rate="-- trials/min")
        bar.start()

    def submit(b: list[Trial]):
        items = [(t.point.to_dict(), t.point.spec, t.index, t.seed, t.key, t.point.point_id)
                 for t in b]
        fut = client.submit(_run_batch, items, study.check, study.name, study.seed,
                            key=f"rfp-study-{b[0].key}", pure=False)
        by_key[fut.key] = b
        return fut

    def window() -> int:
        # 3 tasks per worker thread in flight; re-read as workers join (adaptive clusters)
        try:
            threads = sum(client.nthreads().values())
        except Exception:  # pragma: no cover (scheduler gone: as_completed will say so)
            threads = n_threads
        return max(4, 3 * threads)

    t0 = time.perf_counter()
    failure: BaseException | None = None
    ac = as_completed([submit(b) for b in itertools.islice(it, window())])
    target, checked_at = window(), time.perf_counter()
    try:
        for fut in ac:
            batch = by_key.pop(fut.key)
            try:
                rows = fut.result()
            except Exception as exc:  # a bug in a trial: stop submitting, keep what finished
                if failure is None:
                    failure = exc
                    exc.add_note(f"rfp-twin study {study.name}: trial {batch[0].key} "
                                 f"(point {batch[0].point.point_id}, trial {batch[0].index}) "
                                 "failed; finished trials are saved, run again to resume")
                continue
            for row in rows:
                write_row(results, row)
                summary.n_run += 1
                summary.n_errors += row["status"] == "error"
                summary.n_collisions += bool(row.get("collisions"))
            summary.seconds = time.perf_counter() - t0
            if bar is not None:
                bar.update(task, completed=summary.n_before + summary.n_run,
                           rate=f"{summary.rate_per_min:.1f} trials/min")
            if callback is not None:
                callback(summary.n_before + summary.n_run, summary.n_total)
            if failure is None:
                if time.perf_counter() - checked_at > 2.0:
                    target, checked_at = window(), time.perf_counter()
                while len(by_key) < target:
                    nxt = next(it, None)
                    if nxt is None:
                        break
                    ac.add(submit(nxt))
    finally:
        summary.seconds = time.perf_counter() - t0
        if bar is not None:
            bar.stop()
    if failure is not None:
        raise failure
