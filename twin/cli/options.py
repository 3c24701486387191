"""CLI options built from declared settings fields (:mod:`rfp_twin.models.options`).

:func:`with_options` gives a typer command the options of a settings dataclass: one
``--kebab-name`` per declared field, its default, and its help text with unit and range,
all read from the field's declaration; the command receives the values as keyword
arguments and :func:`options_from` turns them back into the dataclass. A new option of
the settings is then a new option of the command, with no edit here.
"""
from __future__ import annotations

import inspect
from typing import Any, Callable, Optional

import typer

from rfp_twin.models.options import KEY, declared

#: Field type (as written in the dataclass) -> the annotation typer converts with.
_TYPES = {"str": str, "float": float, "int": int, "bool": bool,
          "int | None": Optional[int], "float | None": Optional[float]}


def cli_parameters(cls, rename: dict[str, str]) -> list[inspect.Parameter]:
    """One keyword parameter per declared field of ``cls``: ``rename`` maps a field name to
    the CLI's shorter name (e.g. ``step_deg`` -> ``step``)."""
    out = []
    for f in declared(cls):
        name = rename.get(f.name, f.name)
        hint = f.type if isinstance(f.type, str) else getattr(f.type, "__name__", str(f.type))
        default = typer.Option(f.default, "--" + name.replace("_", "-"),
                               help=f.metadata[KEY].describe())
        out.append(inspect.Parameter(name, inspect.Parameter.KEYWORD_ONLY, default=default,
                                     annotation=_TYPES[hint]))
    return out


def options_from(cls, values: dict[str, Any], rename: dict[str, str]):
    """``cls`` built from the CLI's ``values`` (keyed by CLI name)."""
    return cls(**{f.name: values[rename.get(f.name, f.name)] for f in declared(cls)})


def with_options(cls, rename: dict[str, str]) -> Callable:
    """Decorator: the command's signature gains ``cls``'s options (after its own
    parameters, which must not use their names); the function takes them in ``**kw``."""
    def decorate(fn: Callable) -> Callable:
        own = [p for p in inspect.signature(fn).parameters.values()
               if p.kind is not inspect.Parameter.VAR_KEYWORD]
        params = [p.replace(kind=inspect.Parameter.KEYWORD_ONLY) for p in own]
        fn.__signature__ = inspect.Signature(params + cli_parameters(cls, rename))
        return fn
    return decorate
