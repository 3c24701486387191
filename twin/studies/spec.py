"""What a design study is: the study file's keys, a grid point, a trial, a study.

A *study* is a TOML file that names a parameter grid, a number of trials per grid point
and a base seed (Sayres et al. 2021 Sect. 5 ran 36,000 trials for its Fig. 10); every
trial is one seeded random target draw + one planned reconfiguration + optionally the
independent dense 2D check (:mod:`rfp_twin.twin.studies.runner`). :mod:`rfp_twin.twin.studies.parse` reads
and validates the file into the :class:`Study` defined here.

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
    arm_ratio = [0.8, 1.0, 1.25]  # alpha / beta, the reach kept (models/arm_ratio.py)
    pitch_over_reach = [1.0, 1.2] # the arms scaled to reach = pitch / value (pitch kept)
    n_rafts = 2                   # layout = "raft" only: rafts of 63 robots (Spec-S5)

Design studies (:mod:`~rfp_twin.twin.studies.resolve`, :mod:`~rfp_twin.twin.studies.frontier`)
add ``[study]`` keys ``same_targets`` (grid keys whose values plan the same random targets, e.g.
``["resolution"]``: search and replace on the same draws), ``coverage`` (measure the
focal-plane coverage once per design geometry) and ``firmware`` (post-process every trial
and record the firmware-ready fold time), and ``[[family]]`` tables: each is a robot
family (its own preset, layout and axes, over the shared ``[grid]``); the study is the
union of the families' products. The arm lengths of a point: ``alpha_length_mm`` /
``beta_length_mm`` (default the preset's), scaled by ``pitch_over_reach``, then split by
``arm_ratio``. Every new key is optional and absent from the trial keys of studies that
do not use it, so older study folders resume as before.

Unknown tables or keys and bad values raise :class:`StudyError` naming the file, the key
and the allowed values. Shipped studies live in ``twin/study_files/*.toml`` (``sim1``,
``sim2``, ``sim3``: the paper's Simulations 1-3 at full size (Tables 1, 2, 4); ``*-small``:
versions that finish in minutes on a laptop; ``density*``: pitch / reach x buffer maps;
``design*``: coverage and feasibility over arm ratio x pitch / reach x buffer, two robot
families, search vs replace on the same targets; ``yield*``: science yield per design).

Yield studies (:mod:`~rfp_twin.twin.studies.yield_options`) add the grid keys ``catalogue``
(uniform | clustered: the trial plans a mock catalogue through the plannable loop, assign
-> plan -> forbid lost targets, instead of random per-robot targets), ``density`` and
``density_unit`` (science targets per robot, per patrol area or per deg^2),
``priority_levels`` and ``assign_rounds``, and the ``[study]`` key ``exposure_s`` (for
targets per hour). Layouts ``sdss-v-apo`` / ``sdss-v-lco`` are the calibrated SDSS-V
instruments (fixed pitch). Like the design keys, they enter a point's identity only when
``catalogue`` is set.

Trials and seeds
----------------
A trial is (grid point, trial index). Its seed comes from ``numpy.random.SeedSequence``
with the base seed as entropy and (a stable SHA-256 hash of the point, the index) as spawn
key, so reruns, other machines and other worker counts reproduce every trial. The seed
is stored: ``rfp-twin plan --layout hex:N --buffer B --step D --algorithm A --seed SEED``
replays a hex-grid trial exactly. The trial key (hash of point, base seed, index) is the
resume key (:mod:`rfp_twin.twin.studies.store`).

Units: mm, deg, s.
"""
from __future__ import annotations

import functools
import hashlib
import json
import re
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from rfp_twin.models.errors import RfpError
from rfp_twin.models.layout import Layout
from rfp_twin.models.options import option_info, option_range
from rfp_twin.models.robot import RobotSpec
from rfp_twin.planners.plan.settings import DEFAULT_GREED_PHOBIA, PlannerSettings
from rfp_twin.twin.studies.yield_options import (YIELD_GRID_KEYS, YIELD_STUDY_KEYS, YieldOptions,
                                                 yield_help)

__all__ = ["StudyError", "StudyPoint", "Trial", "Study", "STUDY_KEYS", "GRID_KEYS",
           "GRID_DEFAULTS", "PARAM_COLUMNS", "DESIGN_COLUMNS", "YIELD_COLUMNS", "FIXED_LAYOUTS", "GEOMETRY_COLUMNS",
           "SAME_TARGET_KEYS", "point_layout"]


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
    "same_targets": "a list of grid keys among resolution, max_rounds, direction, greed, "
                    "phobia (their values plan the same targets)",
    "coverage": "true | false (measure coverage once per design geometry)",
    "firmware": "true | false (post-process trials: firmware-ready fold time)",
    **{k: yield_help(k) for k in YIELD_STUDY_KEYS},
}
#: Planning directions (PlannerSettings' ``direction``).
DIRECTIONS = option_info(PlannerSettings, "direction").choices


def planner_allowed(name: str) -> str:
    """What a planner grid key holds, as PlannerSettings declares it (range and unit)."""
    lo, hi, integer = option_range(PlannerSettings, name)
    both = lo is not None and hi is not None
    return (f"{'an integer' if integer else 'a number'} {'in ' if both else ''}"
            f"{option_info(PlannerSettings, name).allowed()}")


#: Keys of the [grid] table and what they hold.
GRID_KEYS = {
    "preset": "a robot preset name or a path to a robot TOML",
    "layout": "\"hex\" | \"sdss-v-fps\" | \"sdss-v-apo\" | \"sdss-v-lco\" | \"raft\" (n_rafts "
              "rafts of 63 robots)",
    "n_robots": "a centred hex count 1 + 3r(r+1) (7, 19, 37, 61, 91, ..., 547, ...)",
    "pitch_mm": "a number > 0 (mm)",
    "alpha_length_mm": "a number > 0 (mm)",
    "beta_length_mm": "a number > 0 (mm)",
    "segment_end_mm": "a number >= 0 (mm)",
    "fold_alpha_deg": "a number (deg) within the preset's alpha limits",
    "fold_beta_deg": "a number (deg) within the preset's beta limits",
    "buffer_mm": "a number > 0 (mm), below pitch / 2",
    "step_deg": planner_allowed("step_deg"),
    "algorithm": "greedy | markov (GC / MC accepted) | apf | capf",
    "greed": planner_allowed("greed"),
    "phobia": planner_allowed("phobia"),
    "resolution": "replace | search | none",
    "direction": " | ".join(DIRECTIONS),
    "max_rounds": planner_allowed("max_rounds"),
    "max_steps": planner_allowed("max_steps"),
    "arm_ratio": "a finite number in (0, inf) (alpha / beta; the reach is kept)",
    "pitch_over_reach": "a finite number in (0, inf) (the arms are scaled; the pitch is kept)",
    "n_rafts": "an integer >= 1 (rafts of 63 robots; layout = \"raft\" only)",
    **{k: yield_help(k) for k in YIELD_GRID_KEYS},
}
#: Layouts of a fixed focal plane (pitch 22.4 mm): the SDSS-V design and its instruments.
FIXED_LAYOUTS = ("sdss-v-fps", "sdss-v-apo", "sdss-v-lco")
LAYOUTS = ("hex", "raft") + FIXED_LAYOUTS
#: Grid keys whose values may share the random targets (``study.same_targets``).
SAME_TARGET_KEYS = ("resolution", "max_rounds", "direction", "greed", "phobia")
RESOLUTIONS = ("replace", "search", "none")
ALGORITHM_ALIASES = {"greedy": "greedy", "gc": "greedy", "markov": "markov", "mc": "markov",
                     "apf": "apf", "capf": "capf"}
GRID_DEFAULTS = {
    "preset": "sdss-v", "layout": "hex", "n_robots": 547, "pitch_mm": None,
    "alpha_length_mm": None, "beta_length_mm": None, "segment_end_mm": None,
    "fold_alpha_deg": None, "fold_beta_deg": None, "buffer_mm": None,
    "step_deg": PlannerSettings().step_deg, "algorithm": "greedy",
    "greed": DEFAULT_GREED_PHOBIA["markov"][0], "phobia": DEFAULT_GREED_PHOBIA["markov"][1],
    "resolution": "replace", "direction": PlannerSettings().direction,
    "max_rounds": PlannerSettings().max_rounds, "max_steps": None,
    "arm_ratio": None, "pitch_over_reach": None, "n_rafts": None,
    **{k: getattr(YieldOptions(), k) for k in YIELD_GRID_KEYS},
}
NAME_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]*$")

#: Parameter columns (one per grid key, resolved) in row order.
PARAM_COLUMNS = ("preset", "layout", "n_robots", "pitch_mm", "alpha_length_mm",
                 "beta_length_mm", "segment_end_mm", "fold_alpha_deg", "fold_beta_deg",
                 "buffer_mm", "step_deg", "algorithm",
                 "greed", "phobia", "resolution", "direction", "max_rounds", "max_steps")
#: Optional parameters of design studies: in a point's identity only when set (not None).
DESIGN_COLUMNS = ("family", "arm_ratio", "pitch_over_reach", "n_rafts")
#: Yield parameters: in a point's identity only when its ``catalogue`` is set.
YIELD_COLUMNS = YIELD_GRID_KEYS
#: Parameters that fix the focal-plane geometry (coverage depends on nothing else).
GEOMETRY_COLUMNS = ("layout", "n_robots", "n_rafts", "pitch_mm", "alpha_length_mm",
                    "beta_length_mm")


@functools.lru_cache(maxsize=8)
def point_layout(kind: str, n_robots: int, pitch_mm: float, n_rafts: int | None = None) -> Layout:
    """The layout of a grid point: ``sdss-v-fps`` (the real focal plane; ``n_robots`` and
    ``pitch_mm`` ignored), ``sdss-v-apo`` / ``sdss-v-lco`` (the calibrated instruments,
    likewise), ``raft`` (``n_rafts`` Spec-S5 rafts of 63 robots at
    ``pitch_mm``, :func:`rfp_twin.models.layout.rafts.raft_layout`) or a centred hex grid
    of ``n_robots`` at ``pitch_mm``."""
    if kind == "sdss-v-fps":
        return Layout.sdss_v_fps()
    if kind in FIXED_LAYOUTS:
        from rfp_twin.models.instrument.layout import instrument_layout

        return instrument_layout(kind)
    if kind == "raft":
        from rfp_twin.models.layout.rafts import raft_layout

        return raft_layout(pitch_mm=pitch_mm, n_rafts=int(n_rafts or 1))
    return Layout.hex_grid_positions(n_robots, pitch_mm)


def _short_hash(data: dict, n: int = 12) -> str:
    text = json.dumps(data, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:n]


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
    family: str | None = None
    arm_ratio: float | None = None
    pitch_over_reach: float | None = None
    n_rafts: int | None = None
    catalogue: str | None = None
    density: float | None = None
    density_unit: str | None = None
    priority_levels: int | None = None
    assign_rounds: int | None = None
    spec: RobotSpec = field(compare=False, repr=False, default=None)  # type: ignore[assignment]
    #: grid keys left out of the trial seed (``study.same_targets``)
    seed_exclude: tuple = field(compare=False, repr=False, default=())

    def to_dict(self) -> dict[str, Any]:
        """The parameters as plain Python values (the hash input): every
        :data:`PARAM_COLUMNS` key, the :data:`DESIGN_COLUMNS` keys that are set and, with a
        catalogue, the :data:`YIELD_COLUMNS`."""
        out = {k: getattr(self, k) for k in PARAM_COLUMNS}
        out.update((k, getattr(self, k)) for k in DESIGN_COLUMNS if getattr(self, k) is not None)
        if self.catalogue is not None:
            out.update((k, getattr(self, k)) for k in YIELD_COLUMNS)
        return out

    @functools.cached_property
    def design_id(self) -> str:
        """12 hex digits naming the design point: the parameters but ``resolution`` (the
        search and replace rows of one design share it) and the catalogue (every density
        and catalogue kind of one design share it)."""
        return _short_hash({k: v for k, v in self.to_dict().items()
                            if k != "resolution" and k not in YIELD_COLUMNS})

    @functools.cached_property
    def geometry_id(self) -> str:
        """12 hex digits naming the focal-plane geometry (layout, robots, pitch, arms):
        the key of the coverage table."""
        return _short_hash({k: getattr(self, k) for k in GEOMETRY_COLUMNS})

    @functools.cached_property
    def seed_canonical(self) -> str:
        """The parameters the trial seed depends on (all but ``seed_exclude``)."""
        d = {k: v for k, v in self.to_dict().items() if k not in self.seed_exclude}
        return json.dumps(d, sort_keys=True, separators=(",", ":"))

    def ids(self) -> dict[str, str]:
        """``point_id``, ``design_id`` and ``geometry_id`` (row columns)."""
        return {"point_id": self.point_id, "design_id": self.design_id,
                "geometry_id": self.geometry_id}

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
        """Seed of trial ``index`` (a non-negative int64 for ``numpy.random.default_rng``);
        points that differ only in ``seed_exclude`` keys share it (the same targets)."""
        h = hashlib.sha256(self.seed_canonical.encode()).digest()
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
    same_targets : tuple of grid keys whose values share the random targets
    coverage : bool, measure coverage once per geometry (:mod:`~rfp_twin.twin.studies.coverage`)
    firmware : bool, post-process trials (firmware-ready fold time)
    families : tuple of family names (empty: the [grid] table alone)
    exposure_s : float, exposure time per pointing for targets per hour, s (yield studies)
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
    same_targets: tuple = ()
    coverage: bool = False
    firmware: bool = False
    families: tuple = ()
    exposure_s: float = YieldOptions().exposure_s

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

