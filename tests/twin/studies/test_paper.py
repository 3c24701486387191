"""Sayres 2021's stated numbers beside ours (twin/studies/paper.py)."""
from __future__ import annotations

import math

from rfp_twin.twin.studies.groups import Group
from rfp_twin.twin.studies.paper import PAPER_TABLE3, SIM1_CONDITIONS, is_sim1, paper_cell


def test_paper_cells_state_the_relation_and_whether_we_agree():
    assert paper_cell(None, 0.99, 0.0, 1.0) == ("-", "")
    assert paper_cell((">", 0.998), 0.999, math.nan, math.nan) == ("> 0.998", "yes")
    assert paper_cell(("<", 15.0), 16.0, math.nan, math.nan) == ("< 15", "no")
    assert paper_cell(("=", 0.968), 0.97, 0.96, 0.98) == ("0.968", "+0.0020 (in 95 % CI)")
    assert paper_cell(("~", 0.92), 0.90, 0.89, 0.91) == ("~0.92", "-0.0200")
    assert paper_cell(("=", 0.968), math.nan, 0.0, 1.0) == ("0.968", "")


def test_simulation1_conditions():
    params = dict(SIM1_CONDITIONS, algorithm="markov", greed=0.9, phobia=0.3, buffer_mm=2.0)
    assert is_sim1(Group("a", params))
    assert not is_sim1(Group("b", dict(params, greed=0.5)))
    assert is_sim1(Group("c", dict(params, algorithm="greedy", greed=1.0, phobia=0.0)))
    assert not is_sim1(Group("d", dict(params, n_robots=37)))
    # Table 3: both algorithms at the three (buffer, step) pairs of Simulation 2
    assert {(b, s) for _, b, s in PAPER_TABLE3} == {(1.5, 1.0), (2.5, 0.25), (3.5, 0.1)}
