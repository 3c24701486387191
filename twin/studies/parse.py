"""Study TOML text -> a validated :class:`~rfp_twin.twin.studies.spec.Study`.

The file format is described in :mod:`rfp_twin.twin.studies.spec`.

Every key and value is checked on its own, then every grid point is resolved against its
robot preset (defaults filled, the combination checked: buffer below pitch / 2, fold
within the joint limits, the real focal plane's fixed pitch). Errors are one
:class:`~rfp_twin.twin.studies.spec.StudyError` line naming the file, the key and what is allowed.
Units: mm, deg.
"""
from __future__ import annotations

import itertools
import math
import tomllib
from importlib import resources
from pathlib import Path

from rfp_twin.models.errors import RfpError
from rfp_twin.models.layout import hex_rings, nearest_hex_counts
from rfp_twin.models.robot import RobotSpec, list_presets, load_spec
from rfp_twin.twin.studies.spec import (ALGORITHM_ALIASES, DIRECTIONS, GRID_DEFAULTS, GRID_KEYS, LAYOUTS,
                               NAME_RE, RESOLUTIONS, STUDY_KEYS, Study, StudyError, StudyPoint,
                               point_layout)

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
    if not is_int(trials) or trials < 1:
        raise _bad(source, "study.trials", trials, STUDY_KEYS["trials"])
    seed = st.get("seed", 0)
    if not is_int(seed) or seed < 0:
        raise _bad(source, "study.seed", seed, STUDY_KEYS["seed"])
    check = st.get("check", True)
    if not isinstance(check, bool):
        raise _bad(source, "study.check", check, STUDY_KEYS["check"])
    batch = st.get("batch", "auto")
    if not (batch == "auto" or (is_int(batch) and batch >= 1)):
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
        lay = point_layout("sdss-v-fps", 0, 0.0)
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

