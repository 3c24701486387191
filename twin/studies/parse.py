"""Study TOML text -> a validated :class:`~rfp_twin.twin.studies.spec.Study`.

The file format is described in :mod:`rfp_twin.twin.studies.spec`.

Every key and value is checked on its own, then every grid point is resolved against its
robot preset (:mod:`rfp_twin.twin.studies.resolve`: defaults filled, design axes applied,
the combination checked: buffer below pitch / 2, fold within the joint limits, the real
focal plane's fixed pitch). ``[[family]]`` tables override ``[grid]`` keys per robot
family; the study is the union of the families' products. Errors are one
:class:`~rfp_twin.twin.studies.spec.StudyError` line naming the file, the key and what is allowed.
Units: mm, deg.
"""
from __future__ import annotations

import itertools
import math
import tomllib
from importlib import resources
from pathlib import Path

from rfp_twin.models.layout import hex_rings, nearest_hex_counts
from rfp_twin.models.options import option_info, option_range
from rfp_twin.planners.plan.settings import PlannerSettings
from rfp_twin.models.robot import RobotSpec
from rfp_twin.twin.studies.resolve import load_preset, resolve_point
from rfp_twin.twin.studies.spec import (ALGORITHM_ALIASES, DIRECTIONS, GRID_DEFAULTS, GRID_KEYS,
                                        LAYOUTS, NAME_RE, RESOLUTIONS, SAME_TARGET_KEYS,
                                        STUDY_KEYS, Study, StudyError, StudyPoint)
from rfp_twin.twin.studies.yield_options import YieldOptions

__all__ = ["list_studies", "study_path", "load_study", "parse_study", "is_int"]


def list_studies() -> list[str]:
    """Names of the studies shipped with rfp-twin (``twin/study_files/*.toml``)."""
    root = resources.files("rfp_twin.twin.study_files")
    return sorted(p.name[:-5] for p in root.iterdir() if p.name.endswith(".toml"))


def study_path(name_or_path: str | Path) -> Path:
    """Path of a study file: a shipped study name (``sim1-small``) or a path."""
    path = Path(name_or_path)
    if path.suffix == ".toml" or path.is_file():
        if not path.is_file():
            raise StudyError(f"{path}: study file not found; allowed: an existing .toml file or a "
                             f"shipped study ({', '.join(list_studies())})")
        return path
    ref = resources.files("rfp_twin.twin.study_files") / f"{name_or_path}.toml"
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


def is_int(v) -> bool:
    """True for an int that is not a bool."""
    return isinstance(v, int) and not isinstance(v, bool)


def _is_num(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _study_table(source: str, st: dict) -> dict:
    """The [study] table checked: {key: value} with defaults filled."""
    out = {}
    for key in ("description", "reference"):
        if not isinstance(st.get(key, ""), str):
            raise _bad(source, f"study.{key}", st[key], STUDY_KEYS[key])
        out[key] = st.get(key, "")
    trials = st.get("trials", 1)
    if not is_int(trials) or trials < 1:
        raise _bad(source, "study.trials", trials, STUDY_KEYS["trials"])
    seed = st.get("seed", 0)
    if not is_int(seed) or seed < 0:
        raise _bad(source, "study.seed", seed, STUDY_KEYS["seed"])
    for key, default in (("check", True), ("coverage", False), ("firmware", False)):
        out[key] = st.get(key, default)
        if not isinstance(out[key], bool):
            raise _bad(source, f"study.{key}", out[key], STUDY_KEYS[key])
    batch = st.get("batch", "auto")
    if not (batch == "auto" or (is_int(batch) and batch >= 1)):
        raise _bad(source, "study.batch", batch, STUDY_KEYS["batch"])
    same = st.get("same_targets", [])
    if not (isinstance(same, list) and all(k in SAME_TARGET_KEYS for k in same)
            and len(set(same)) == len(same)):
        raise _bad(source, "study.same_targets", same, STUDY_KEYS["same_targets"])
    exposure = st.get("exposure_s", YieldOptions().exposure_s)
    info = option_info(YieldOptions, "exposure_s")
    if not (_is_num(exposure) and info.lo <= exposure <= info.hi):
        raise _bad(source, "study.exposure_s", exposure, STUDY_KEYS["exposure_s"])
    out.update(trials=trials, seed=seed, batch=batch, same_targets=tuple(same),
               exposure_s=float(exposure))
    return out


def _grid_values(source: str, table: dict, prefix: str, base: dict | None) -> dict[str, tuple]:
    """{grid key: tuple of normalised values}: ``table``'s keys, the others from ``base``
    (or the defaults). ``prefix`` names the table in messages (``grid`` / ``family[NAME]``)."""
    grid: dict[str, tuple] = {}
    for key, default in GRID_DEFAULTS.items():
        if key not in table and base is not None:
            grid[key] = base[key]
            continue
        raw = table.get(key, default)
        values = list(raw) if isinstance(raw, list) else [raw]
        if not values:
            raise _bad(source, f"{prefix}.{key}", raw,
                       f"a value or a non-empty list of values, each {GRID_KEYS[key]}")
        norm = [_check_value(source, key, v, prefix) for v in values]
        if len(set(norm)) != len(norm):
            raise _bad(source, f"{prefix}.{key}", raw, "a list without repeated values")
        grid[key] = tuple(norm)
    return grid


def _families(source: str, data: dict, base_grid: dict) -> list[tuple[str | None, dict]]:
    """[(family name or None, its grid)]: the [[family]] tables over [grid], or [grid] alone."""
    fams = data.get("family")
    if fams is None:
        return [(None, base_grid)]
    if not (isinstance(fams, list) and fams and all(isinstance(f, dict) for f in fams)):
        raise StudyError(f"{source}: 'family' must be an array of tables; allowed: one or more "
                         "[[family]] tables with a 'name' and grid keys")
    out, names = [], set()
    for i, fam in enumerate(fams):
        name = fam.get("name")
        if not isinstance(name, str) or not NAME_RE.match(name) or name in names:
            raise _bad(source, f"family[{i}].name", name, "a folder-safe name (letters, digits, "
                       ". _ -), different in each family")
        names.add(name)
        for key in fam:
            if key != "name" and key not in GRID_KEYS:
                raise StudyError(f"{source}: unknown key '{key}' in family '{name}'; allowed: "
                                 "name, " + ", ".join(GRID_KEYS))
        out.append((name, _grid_values(source, fam, f"family[{name}]", base_grid)))
    return out


def parse_study(text: str, source: str = "<study>", base_dir: str | Path | None = None,
                default_name: str = "study") -> Study:
    """Parse and validate study TOML text (see :mod:`rfp_twin.twin.studies.spec` for the format)."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise StudyError(f"{source}: malformed TOML ({exc}); allowed: a TOML file with tables "
                         "'study' and 'grid'") from None
    unknown = sorted(set(data) - {"study", "grid", "family"})
    if unknown:
        raise StudyError(f"{source}: unknown table or key {unknown[0]!r}; allowed: tables 'study' "
                         "and 'grid', and [[family]] tables")
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
    opts = _study_table(source, st)
    families = _families(source, data, _grid_values(source, gr, "grid", None))

    base = Path(base_dir) if base_dir is not None else Path.cwd()
    specs: dict[str, RobotSpec] = {}
    points: list[StudyPoint] = []
    seen: set[str] = set()
    own_keys = {f.get("name"): set(f) for f in data.get("family", [])}
    for fam, grid in families:
        prefix = "grid" if fam is None else f"family[{fam}]"

        def origin(key: str, fam=fam) -> str:
            """Where a key of this family's points is (or should be) written, for messages:
            the [grid] table only when it holds the key and the family does not."""
            if fam is None or (key in gr and key not in own_keys.get(fam, ())):
                return f"grid.{key}"
            return f"family[{fam}].{key}"

        for preset in grid["preset"]:
            if preset not in specs:
                specs[preset] = load_preset(source, preset, base, f"{prefix}.preset")
        for combo in itertools.product(*grid.values()):
            p = resolve_point(source, dict(zip(grid, combo)), specs, family=fam, origin=origin,
                              seed_exclude=opts["same_targets"])
            if p.canonical not in seen:
                seen.add(p.canonical)
                points.append(p)
    merged = {k: tuple(dict.fromkeys(v for _, g in families for v in g[k]))
              for k in GRID_DEFAULTS}
    return Study(name=name, description=opts["description"], reference=opts["reference"],
                 trials=opts["trials"], seed=opts["seed"], check=opts["check"],
                 batch=opts["batch"], grid=merged, points=tuple(points), source=source, text=text,
                 same_targets=opts["same_targets"], coverage=opts["coverage"],
                 firmware=opts["firmware"],
                 families=tuple(f for f, _ in families if f is not None),
                 exposure_s=opts["exposure_s"])


def _declared_range(cls, name: str) -> tuple:
    """A grid key's range as ``cls`` declares it (PlannerSettings or YieldOptions)."""
    lo, hi, integer = option_range(cls, name)
    return lo, hi, False, integer


#: Numeric grid keys: (low, high, low excluded, integer); None = unbounded. The planner's
#: own options take the range PlannerSettings declares, the yield axes YieldOptions'.
_NUMERIC = {
    "fold_alpha_deg": (None, None, False, False), "fold_beta_deg": (None, None, False, False),
    "pitch_mm": (0.0, None, True, False), "alpha_length_mm": (0.0, None, True, False),
    "beta_length_mm": (0.0, None, True, False), "buffer_mm": (0.0, None, True, False),
    "segment_end_mm": (0.0, None, False, False),
    **{k: _declared_range(PlannerSettings, k) for k in ("step_deg", "greed", "phobia", "max_rounds", "max_steps")},
    "arm_ratio": (0.0, None, True, False), "pitch_over_reach": (0.0, None, True, False),
    "n_rafts": (1, None, False, True),
    **{k: _declared_range(YieldOptions, k) for k in ("density", "priority_levels", "assign_rounds")},
}


def _check_value(source: str, key: str, v, prefix: str = "grid"):
    """Validate one grid value on its own; returns it normalised."""
    where = f"{prefix}.{key}"
    allowed = GRID_KEYS[key]
    if v is None:
        return None
    if key in _NUMERIC:
        lo, hi, lo_open, integer = _NUMERIC[key]
        ok = is_int(v) if integer else _is_num(v)
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
        if not is_int(v) or v < 1:
            raise _bad(source, where, v, allowed)
        if hex_rings(v) is None:
            near = ", ".join(map(str, nearest_hex_counts(v)))
            raise _bad(source, where, v, f"{allowed}; nearest: {near}")
        return int(v)
    if key == "algorithm":
        a = ALGORITHM_ALIASES.get(str(v).lower()) if isinstance(v, str) else None
        if a is None:
            raise _bad(source, where, v, allowed)
        return a
    choices = {"layout": LAYOUTS, "resolution": RESOLUTIONS, "direction": DIRECTIONS,
               **{k: option_info(YieldOptions, k).choices
                  for k in ("catalogue", "density_unit")}}[key]
    if v not in choices:
        raise _bad(source, where, v, allowed)
    return v
