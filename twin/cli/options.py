"""CLI options built from declared settings fields (:mod:`rfp_twin.models.options`).

:func:`with_options` gives a typer command the options of a settings dataclass: one
``--kebab-name`` per declared field, its default, and its help text with unit and range,
all read from the field's declaration; the command receives the values as keyword
arguments and :func:`options_from` turns them back into the dataclass. A new option of
the settings is then a new option of the command, with no edit here.
"""
from __future__ import annotations

import inspect
from pathlib import Path
from typing import Any, Callable, Optional

import typer

from rfp_twin.models.options import KEY, declared

#: Field type (as written in the dataclass) -> the annotation typer converts with. A
#: ``tuple[str, ...]`` field is a repeatable option (typer hands a list back).
_TYPES = {"str": str, "float": float, "int": int, "bool": bool, "Path": Path,
          "int | None": Optional[int], "float | None": Optional[float],
          "str | None": Optional[str], "Path | None": Optional[Path],
          "tuple[str, ...]": list[str]}


def _hint(f) -> str:
    return f.type if isinstance(f.type, str) else getattr(f.type, "__name__", str(f.type))


def cli_parameters(cls, rename: dict[str, str] | None = None) -> list[inspect.Parameter]:
    """One keyword parameter per declared field of ``cls``: ``rename`` maps a field name to
    the CLI's shorter name (e.g. ``step_deg`` -> ``step``). A flag (bool) comes with its
    ``--no-`` form."""
    out = []
    for f in declared(cls):
        name = (rename or {}).get(f.name, f.name)
        flag = () if _hint(f) == "bool" else ("--" + name.replace("_", "-"),)
        default = list(f.default) if isinstance(f.default, tuple) else f.default
        option = typer.Option(default, *flag, help=f.metadata[KEY].describe())
        out.append(inspect.Parameter(name, inspect.Parameter.KEYWORD_ONLY, default=option,
                                     annotation=_TYPES[_hint(f)]))
    return out


def options_from(cls, values: dict[str, Any], rename: dict[str, str] | None = None):
    """``cls`` built from the CLI's ``values`` (keyed by CLI name)."""
    def value(f):
        v = values[(rename or {}).get(f.name, f.name)]
        return tuple(v) if _hint(f).startswith("tuple") else v
    return cls(**{f.name: value(f) for f in declared(cls)})


def with_options(cls, rename: dict[str, str] | None = None) -> Callable:
    """Decorator: the command's signature gains ``cls``'s options (after its own
    parameters, which must not use their names); the function takes them in ``**kw``.
    Decorators stack: the options come in the order the decorators are written."""
    def decorate(fn: Callable) -> Callable:
        added = getattr(fn, "declared_parameters", [])
        own = [p.replace(kind=inspect.Parameter.KEYWORD_ONLY)
               for p in inspect.signature(fn).parameters.values()
               if p.kind is not inspect.Parameter.VAR_KEYWORD and p not in added]
        fn.declared_parameters = cli_parameters(cls, rename) + added
        fn.__signature__ = inspect.Signature(own + fn.declared_parameters)
        return fn
    return decorate
