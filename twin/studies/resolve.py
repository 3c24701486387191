"""One grid point of a study file -> a :class:`~rfp_twin.twin.studies.spec.StudyPoint`.

Fills the robot preset's defaults, applies the design axes and checks the combination.
The arm lengths of a point (mm):

1. ``alpha_length_mm`` / ``beta_length_mm`` as given, else the preset's;
2. with ``pitch_over_reach``: both scaled so that reach = pitch / pitch_over_reach (the
   pitch stays; a numeric collision-segment end that is not on the fiber is scaled too);
3. with ``arm_ratio``: split at alpha / beta = arm_ratio with the reach kept, the
   segment end moved by :func:`rfp_twin.models.arm_ratio.with_arm_ratio`.

Checks: buffer < pitch / 2, the fold within the joint limits (the spec's own checks), the
real focal plane's fixed pitch (``sdss-v-fps`` and the calibrated ``sdss-v-apo`` /
``sdss-v-lco``), a raft layout that holds its robots at the pitch, a density per deg^2
only where the layout has a telescope's plate scale. The yield keys are kept only when
the point has a ``catalogue``. Errors
are one :class:`~rfp_twin.twin.studies.spec.StudyError` line naming the file, the field
(``grid.KEY`` or ``family[NAME].KEY``) and what is allowed. Units: mm, deg.
"""
from __future__ import annotations

from pathlib import Path

from rfp_twin.models.arm_ratio import with_arm_ratio
from rfp_twin.models.errors import RfpError
from rfp_twin.models.robot import RobotSpec, list_presets, load_spec
from rfp_twin.twin.studies.spec import (FIXED_LAYOUTS, YIELD_COLUMNS, StudyError, StudyPoint,
                                        point_layout)

__all__ = ["load_preset", "resolve_point"]


def load_preset(source: str, preset: str, base: Path, where: str = "grid.preset") -> RobotSpec:
    """The RobotSpec of a preset name or a robot TOML path (relative to ``base``)."""
    path = Path(preset)
    if path.suffix == ".toml" and not path.is_absolute():
        path = base / path
    try:
        return load_spec(path if path.suffix == ".toml" else preset)
    except RfpError as exc:
        raise StudyError(f"{source}: {where} = {preset!r}: {exc}; allowed: "
                         f"{', '.join(list_presets())} or a robot TOML path") from None


def _arms(raw: dict, base: RobotSpec, pitch: float, buffer: float) -> tuple[float, float, float]:
    """(alpha, beta, segment end) mm before the arm ratio: steps 1-2 of the module docstring."""
    la = raw["alpha_length_mm"] if raw["alpha_length_mm"] is not None else base.alpha_length_mm
    lb = raw["beta_length_mm"] if raw["beta_length_mm"] is not None else base.beta_length_mm
    scale = 1.0
    if raw.get("pitch_over_reach") is not None:
        scale = pitch / raw["pitch_over_reach"] / (la + lb)
        la, lb = la * scale, lb * scale
    if raw["segment_end_mm"] is not None:
        seg = raw["segment_end_mm"]
    elif isinstance(base.segment_end_mm, str):
        seg = base.segment_end(buffer)           # e.g. the SDSS-V production rule
    elif abs(float(base.segment_end_mm) - base.beta_length_mm) < 1e-12:
        seg = lb                                 # the segment runs to the fiber: follow the arm
    else:
        seg = float(base.segment_end_mm) * scale
    return float(la), float(lb), float(seg)


def _layout(source: str, raw: dict, pitch: float, where: str, origin) -> tuple[int, int | None]:
    """(n_robots, n_rafts) of the point's layout; a raft layout is built to check it fits."""
    layout = raw["layout"]
    if layout in FIXED_LAYOUTS:
        return point_layout(layout, 0, 0.0).n_robots, None
    if layout != "raft":
        return int(raw["n_robots"]), None
    n_rafts = raw.get("n_rafts")
    if n_rafts is None:
        raise StudyError(f"{source}: {origin('n_rafts')} is not set with layout = 'raft' (point "
                         f"{where}); allowed: an integer >= 1 (rafts of 63 robots)")
    try:
        lay = point_layout("raft", 0, float(pitch), int(n_rafts))
    except RfpError as exc:
        raise StudyError(f"{source}: {origin('pitch_mm')} = {pitch:g} with layout = 'raft' "
                         f"(point {where}): {exc}") from None
    return lay.n_robots, int(n_rafts)


def resolve_point(source: str, raw: dict, specs: dict[str, RobotSpec], *, family: str | None = None,
                  origin=lambda key: f"grid.{key}", seed_exclude: tuple = ()) -> StudyPoint:
    """Fill preset defaults, apply the design axes, build the RobotSpec, check the point.

    Parameters
    ----------
    source : the study file (for messages)
    raw : {grid key: one value or None}, the point as written
    specs : {preset: RobotSpec}
    family : the ``[[family]]`` name, or None
    origin : key -> the field's name in messages (``grid.KEY`` or ``family[NAME].KEY``)
    seed_exclude : grid keys left out of the trial seed (``study.same_targets``)
    """
    base = specs[raw["preset"]]
    where = ", ".join(f"{k}={v}" for k, v in raw.items() if v is not None)
    if family is not None:
        where = f"family {family}: {where}"
    layout = raw["layout"]
    if layout in FIXED_LAYOUTS:
        if raw["pitch_mm"] is not None and abs(raw["pitch_mm"] - 22.4) > 1e-9:
            raise StudyError(f"{source}: {origin('pitch_mm')} = {raw['pitch_mm']} with layout = "
                             f"'{layout}' (point " + where + "); allowed: unset or 22.4 (the "
                             "real focal plane has a fixed pitch)")
        pitch = 22.4
    else:
        pitch = raw["pitch_mm"] if raw["pitch_mm"] is not None else base.pitch_mm
    buffer = raw["buffer_mm"] if raw["buffer_mm"] is not None else base.buffer_mm
    if not buffer < pitch / 2:
        raise StudyError(f"{source}: {origin('buffer_mm')} = {buffer} at pitch_mm = {pitch} (point "
                         f"{where}); allowed: buffer_mm < pitch_mm / 2 = {pitch / 2}")
    n_robots, n_rafts = _layout(source, raw, pitch, where, origin)
    la, lb, seg = _arms(raw, base, pitch, buffer)
    fold = (raw["fold_alpha_deg"] if raw["fold_alpha_deg"] is not None else base.fold_deg[0],
            raw["fold_beta_deg"] if raw["fold_beta_deg"] is not None else base.fold_deg[1])
    ratio = raw.get("arm_ratio")
    try:
        spec = base.with_overrides(pitch_mm=pitch, alpha_length_mm=la, beta_length_mm=lb,
                                   segment_end_mm=seg, buffer_mm=buffer,
                                   fold_deg=(float(fold[0]), float(fold[1])))
        if ratio is not None:
            spec = with_arm_ratio(spec, ratio)
    except RfpError as exc:
        raise StudyError(f"{source}: grid point ({where}): {exc}") from None
    alg = raw["algorithm"]
    greed, phobia = (raw["greed"], raw["phobia"]) if alg == "markov" else (1.0, 0.0)
    max_steps = raw["max_steps"] if raw["max_steps"] is not None else \
        int(round(1000.0 / raw["step_deg"]))
    por = raw.get("pitch_over_reach")
    yields = _yield_keys(source, raw, layout, base.name, where, origin)
    return StudyPoint(preset=raw["preset"], layout=layout, n_robots=int(n_robots),
                      pitch_mm=float(pitch), alpha_length_mm=float(spec.alpha_length_mm),
                      beta_length_mm=float(spec.beta_length_mm),
                      segment_end_mm=float(spec.segment_end(buffer)),
                      fold_alpha_deg=float(fold[0]), fold_beta_deg=float(fold[1]),
                      buffer_mm=float(buffer), step_deg=float(raw["step_deg"]), algorithm=alg,
                      greed=float(greed), phobia=float(phobia), resolution=raw["resolution"],
                      direction=raw["direction"], max_rounds=int(raw["max_rounds"]),
                      max_steps=int(max_steps), family=family,
                      arm_ratio=None if ratio is None else float(ratio),
                      pitch_over_reach=None if por is None else float(por), n_rafts=n_rafts,
                      spec=spec, seed_exclude=tuple(seed_exclude), **yields)


def _yield_keys(source: str, raw: dict, layout: str, spec_name: str, where: str,
                origin) -> dict:
    """The yield keys of a point with a catalogue (all None without one); a density per
    deg^2 needs a telescope (the SDSS-V layouts and presets)."""
    if raw.get("catalogue") is None:
        return {k: None for k in YIELD_COLUMNS}
    if raw["density_unit"] == "deg2":
        from rfp_twin.twin.catalogue_source import telescope_for

        if telescope_for("auto", layout, spec_name) is None:
            raise StudyError(f"{source}: {origin('density_unit')} = 'deg2' (point {where}); "
                             "allowed: robot or patrol (a density per deg^2 needs a telescope's "
                             "plate scale: SDSS-V layouts and presets)")
    return {k: raw[k] for k in YIELD_COLUMNS}
