"""Options declared once: a dataclass field that carries its help text, unit and range.

:func:`option` makes a ``dataclasses.field`` whose metadata holds what every consumer of
the option needs: the help text (shown by the CLI), the unit, the closed range or the
allowed choices (checked by :func:`check_options`, the same message everywhere). A
settings dataclass declares each option once this way; the CLI builds its parameters from
the fields (:mod:`rfp_twin.twin.cli.options`), another settings class that takes the same
option refers to the declaration (:func:`same_option`) instead of writing it again.

Example::

    @dataclass(frozen=True)
    class Settings:
        step_deg: float = option(0.1, "Angular step.", unit="deg", lo=0.001, hi=10.0)

        def __post_init__(self):
            check_options(self)
"""
from __future__ import annotations

import dataclasses
import math
from typing import Any

from rfp_twin.models.errors import SpecError

#: Metadata key under which :func:`option` stores its description.
KEY = "rfp_option"


@dataclasses.dataclass(frozen=True)
class OptionInfo:
    """What is declared about an option.

    help : text for ``--help`` (without unit, range or default: those are added)
    unit : "deg", "mm", "s", ... or "" for a plain number / a word
    lo, hi : closed range of a number (None: unbounded on that side)
    choices : the allowed words of a text option (empty: any)
    optional : None is allowed (meaning given in ``help``)
    """

    help: str
    unit: str = ""
    lo: float | None = None
    hi: float | None = None
    choices: tuple[str, ...] = ()
    optional: bool = False

    def allowed(self) -> str:
        """The allowed values as the error messages say them."""
        if self.choices:
            return ", ".join(self.choices)
        unit = f" {self.unit}" if self.unit else ""
        if self.lo is not None and self.hi is not None:
            return f"[{self.lo:g}, {self.hi:g}]{unit}"
        if self.lo is not None:
            return f">= {self.lo:g}{unit}"
        if self.hi is not None:
            return f"<= {self.hi:g}{unit}"
        return "any value"

    def describe(self) -> str:
        """Help text with unit and range (choices unless the text names them all), for
        the CLI."""
        if self.choices:
            extra = "" if all(c in self.help for c in self.choices) else self.allowed()
        elif self.lo is not None or self.hi is not None:
            extra = self.allowed()
        else:
            extra = self.unit
        text = f"{self.help} ({extra})" if extra else self.help
        return text if text.endswith(".") else text + "."


def option(default: Any, help: str, *, unit: str = "", lo: float | None = None,
           hi: float | None = None, choices: tuple[str, ...] = (),
           optional: bool = False) -> Any:
    """A dataclass field with its :class:`OptionInfo` (see the module docstring)."""
    info = OptionInfo(help, unit, lo, hi, tuple(choices), optional or default is None)
    return dataclasses.field(default=default, metadata={KEY: info})


def option_info(cls_or_obj, name: str) -> OptionInfo:
    """The :class:`OptionInfo` of field ``name`` of a settings class (or instance)."""
    for f in dataclasses.fields(cls_or_obj):
        if f.name == name and KEY in f.metadata:
            return f.metadata[KEY]
    raise KeyError(f"{name!r} is not a declared option of {cls_or_obj!r}")


def option_range(cls_or_obj, name: str) -> tuple[float | None, float | None, bool]:
    """``(low, high, integer)`` of the number option ``name`` (None: unbounded that side;
    ``integer``: the field is declared ``int``)."""
    info = option_info(cls_or_obj, name)
    kind = next(f.type for f in dataclasses.fields(cls_or_obj) if f.name == name)
    return info.lo, info.hi, "int" in str(kind)


def declared(cls_or_obj) -> list[dataclasses.Field]:
    """The fields of ``cls_or_obj`` declared with :func:`option`, in order."""
    return [f for f in dataclasses.fields(cls_or_obj) if KEY in f.metadata]


def same_option(cls, name: str, **changes: Any) -> Any:
    """A field declared as field ``name`` of ``cls`` (same default, help, unit, range);
    ``changes`` override parts of it (e.g. ``choices`` or ``default``)."""
    f = next(f for f in dataclasses.fields(cls) if f.name == name)
    info = f.metadata[KEY]
    default = changes.pop("default", f.default)
    return dataclasses.field(default=default,
                             metadata={KEY: dataclasses.replace(info, **changes)})


def check_options(obj, *, label: str = "field '{name}' = {value!r}") -> None:
    """SpecError for the first declared option of ``obj`` outside its range or choices:
    ``label`` (formatted with the field's ``name`` and ``value``) then "; allowed: ..."."""
    for f in declared(obj):
        info: OptionInfo = f.metadata[KEY]
        value = getattr(obj, f.name)
        if value is None and info.optional:
            continue
        if info.choices:
            ok = value in info.choices
        elif info.lo is not None or info.hi is not None:
            ok = (isinstance(value, (int, float)) and not isinstance(value, bool)
                  and math.isfinite(value)
                  and (info.lo is None or value >= info.lo)
                  and (info.hi is None or value <= info.hi))
        else:
            ok = True
        if not ok:
            raise SpecError(f"{label.format(name=f.name, value=value)}; allowed: "
                            f"{info.allowed()}")
