"""Options declared once (models/options.py): range and choice checks, shared declarations."""
from __future__ import annotations

from dataclasses import dataclass

import pytest

from rfp_twin.models.errors import SpecError
from rfp_twin.models.options import (check_options, declared, option, option_info,
                                     same_option)


@dataclass(frozen=True)
class Demo:
    step_deg: float = option(0.1, "Angular step", unit="deg", lo=0.001, hi=10.0)
    mode: str = option("a", "a | b", choices=("a", "b"))
    limit: int | None = option(None, "Limit [default: none]", lo=1)
    free: str = "not an option"

    def __post_init__(self):
        check_options(self)


@dataclass(frozen=True)
class Wider:
    step_deg: float = same_option(Demo, "step_deg")
    mode: str = same_option(Demo, "mode", choices=("a", "b", "c"), default="c")

    def __post_init__(self):
        check_options(self, label="--{name} {value!r}")


@pytest.mark.parametrize("kwargs, message", [
    ({"step_deg": 0.0}, "field 'step_deg' = 0.0; allowed: [0.001, 10] deg"),
    ({"step_deg": float("nan")}, "field 'step_deg' = nan; allowed: [0.001, 10] deg"),
    ({"mode": "z"}, "field 'mode' = 'z'; allowed: a, b"),
    ({"limit": 0}, "field 'limit' = 0; allowed: >= 1"),
])
def test_out_of_range_names_the_field_and_the_range(kwargs, message):
    with pytest.raises(SpecError) as err:
        Demo(**kwargs)
    assert str(err.value) == message


def test_none_where_optional_and_undeclared_fields_are_free():
    assert Demo(limit=None).limit is None
    assert [f.name for f in declared(Demo)] == ["step_deg", "mode", "limit"]


def test_a_shared_option_keeps_the_declaration_and_overrides_what_it_says():
    assert option_info(Wider, "step_deg") == option_info(Demo, "step_deg")
    assert option_info(Wider, "mode").choices == ("a", "b", "c")
    assert Wider().mode == "c"
    with pytest.raises(SpecError, match=r"^--step_deg 20.0; allowed: \[0.001, 10\] deg$"):
        Wider(step_deg=20.0)


def test_cli_help_reads_unit_range_and_choices_from_the_declaration():
    assert option_info(Demo, "step_deg").describe() == "Angular step ([0.001, 10] deg)."
    assert option_info(Demo, "mode").describe() == "a | b."          # the text names them
    assert option_info(Wider, "mode").describe() == "a | b (a, b, c)."


def test_plan_options_take_the_planner_declarations():
    from rfp_twin.planners.plan import PlannerSettings
    from rfp_twin.twin.pipeline import PlanOptions

    shared = {f.name for f in declared(PlanOptions)} & {f.name for f in declared(PlannerSettings)}
    assert {"step_deg", "greed", "phobia", "beta_first", "fold_repairs", "reruns"} <= shared
    for name in shared - {"algorithm", "resolve"}:
        assert option_info(PlanOptions, name) == option_info(PlannerSettings, name)
