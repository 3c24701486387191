"""What the spec readers of every robot kind share: a number checked against a range (one
message form), a spec's TOML tables read into its dataclass fields, and a copy with some
fields changed.

A spec is a frozen dataclass with a ``source`` field (the file or preset it came from,
named in every message). Units are the fields' own (mm, deg, s).
"""
from __future__ import annotations

import math
from dataclasses import fields, replace
from typing import Any

from rfp_twin.models.errors import SpecError


def check_range(spec, name: str, value, lo: float, hi: float, lo_open: bool = False) -> None:
    """SpecError naming ``spec.source`` and field ``name`` unless ``value`` is a finite number
    in ``[lo, hi]`` (``(lo, hi]`` with ``lo_open``)."""
    bad = not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value)
    if not bad:
        bad = value < lo or value > hi or (lo_open and value == lo)
    if bad:
        left = "(" if lo_open else "["
        raise SpecError(f"{spec.source}: field '{name}' = {value!r}; allowed: {left}{lo}, {hi}]")


def _as_number(value, keep_int: bool):
    """TOML integers as floats (lists as tuples of them), unless ``keep_int``."""
    if isinstance(value, list):
        value = tuple(value)
    if isinstance(value, int) and not isinstance(value, bool) and not keep_int:
        value = float(value)
    if isinstance(value, tuple):
        value = tuple(float(v) if isinstance(v, int) and not isinstance(v, bool) else v
                      for v in value)
    return value


def fields_from_tables(data: dict, tables: dict[str, dict[str, str]], source: str, *,
                       optional: set[str], missing_table: str, missing_field: str = "",
                       integers: set[str] = frozenset()) -> dict[str, Any]:
    """The spec's keyword arguments from its parsed TOML ``data``.

    tables : {table: {key: dataclass field}}; every table must be there, with no other
        key, and every key not in ``optional``.
    missing_table : what the "missing table" message allows (e.g. "a preset with [robot]
        and [collision] tables"); missing_field : appended to the "missing field" one.
    integers : keys kept as integers (every other TOML integer becomes a float)."""
    kwargs: dict[str, Any] = {}
    for table, names in tables.items():
        section = data.get(table)
        if not isinstance(section, dict):
            raise SpecError(f"{source}: missing table [{table}]; allowed: {missing_table}")
        extra = set(section) - set(names)
        if extra:
            raise SpecError(f"{source}: unknown field(s) {sorted(extra)} in [{table}]; allowed: "
                            + ", ".join(names))
        for key, attr in names.items():
            if key not in section:
                if key in optional:
                    continue
                raise SpecError(f"{source}: missing field '{key}' in [{table}]; allowed: every "
                                f"field of [{table}] set{missing_field}")
            kwargs[attr] = _as_number(section[key], key in integers)
    return kwargs


def with_fields(spec, **changes: Any):
    """A copy of ``spec`` with some fields changed (validated again by its
    ``__post_init__``); an unknown field raises SpecError."""
    unknown = set(changes) - {f.name for f in fields(spec)}
    if unknown:
        raise SpecError(f"{spec.source}: unknown field(s) {sorted(unknown)}")
    return replace(spec, **changes)
