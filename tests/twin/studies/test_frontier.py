"""The design frontier (twin/studies/frontier.py, frontier_plot.py) on hand-made tables."""
from __future__ import annotations

import math

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from tests.twin.studies.builders import made_row
from rfp_twin.twin.studies import RESULTS, parse_study, write_row
from rfp_twin.twin.studies.coverage import COVERAGE_FILE, COVERAGE_SCHEMA
from rfp_twin.twin.studies.frontier import (choose_cover_k, design_results, mark_frontiers,
                                            pareto_mask)
from rfp_twin.twin.studies.frontier_plot import draw_frontier
from rfp_twin.twin.studies.report import write_report
from rfp_twin.twin.studies.store import write_study_copy

#: 4 geometries (pitch / reach) x 2 resolvers, one family; nothing is run.
HAND = """
[study]
name = "hand"
trials = 2
same_targets = ["resolution"]
coverage = true
[grid]
n_robots = 7
resolution = ["search", "replace"]
[[family]]
name = "f"
arm_ratio = 1.0
pitch_over_reach = [1.2, 1.4, 1.6, 1.8]
buffer_mm = 2.0
"""
#: pitch / reach -> share reached by >= 1 / 2 / 3 fibers
COVER = {1.2: (1.0, 0.9, 0.6), 1.4: (0.99, 0.7, 0.3), 1.6: (0.98, 0.5, 0.1),
         1.8: (0.97, 0.3, 0.0)}
#: (pitch / reach, resolver) -> (kept of trial 0, of trial 1, stepwise fold s)
KEPT = {(1.2, "search"): (0.95, 0.95, 12.0), (1.4, "search"): (0.99, 0.99, 11.0),
        (1.6, "search"): (0.99, 0.99, 11.5), (1.8, "search"): (1.0, 1.0, 10.0),
        (1.2, "replace"): (0.6, 0.6, 9.0), (1.4, "replace"): (0.8, 0.8, 9.5),
        (1.6, "replace"): (0.95, 0.95, 9.5), (1.8, "replace"): (0.9, None, 9.8)}


def test_pareto_mask_by_hand():
    x = [0.9, 0.7, 0.5, 0.3, 0.7, math.nan]
    y = [0.95, 0.99, 0.99, 1.0, 0.99, 1.0]
    # (0.5, 0.99) is beaten by (0.7, 0.99); the two equal points (0.7, 0.99) both stay
    assert pareto_mask(x, y).tolist() == [True, True, False, True, True, False]
    # fold time: shorter is better
    assert pareto_mask([0.9, 0.7, 0.5, 0.3], [12.0, 11.0, 11.5, 10.0],
                       maximize_y=False).tolist() == [True, True, False, True]
    assert pareto_mask([], []).tolist() == []
    assert pareto_mask([0.5], [0.5]).tolist() == [True]


@pytest.fixture()
def hand_folder(tmp_path):
    """A study folder with hand-made rows and coverage (trial 1 of p/r 1.8 replace failed)."""
    study = parse_study(HAND)
    out = tmp_path / "hand"
    (out / RESULTS).mkdir(parents=True)
    write_study_copy(out, study)
    cov_rows = {}
    for t in study.trial_list():
        p = t.point
        por = round(p.pitch_mm / p.reach_mm, 6)
        k0, k1, fold = KEPT[(por, p.resolution)]
        kept = k0 if t.index == 0 else k1
        metrics = dict(kept=kept, fold_time_s=fold, plan_s=0.5 + t.index, efficiency=kept)
        if kept is None:
            metrics = dict(status="error", error="PlanningError: made up", efficiency=None)
        write_row(out / RESULTS, {**made_row(study, t, **metrics), **p.ids()})
        c = COVER[por]
        cov_rows[p.geometry_id] = {"geometry_id": p.geometry_id, "family": "f",
                                   "cover_1": c[0], "cover_2": c[1], "cover_3": c[2]}
    pq.write_table(pa.Table.from_pylist(list(cov_rows.values()), schema=COVERAGE_SCHEMA),
                   out / COVERAGE_FILE)
    return out


def test_design_results_and_their_frontiers(hand_folder):
    designs = design_results(hand_folder)
    assert len(designs) == 8 and {d.family for d in designs} == {"f"}
    by = {(round(d.params["pitch_over_reach"], 6), d.resolution): d for d in designs}
    assert by[(1.2, "search")].cover == {1: 1.0, 2: 0.9, 3: 0.6}
    assert by[(1.4, "search")].kept == pytest.approx(0.99)
    # a failed trial keeps no target: (0.9 + 0) / 2
    failed = by[(1.8, "replace")]
    assert (failed.n_trials, failed.n_failed) == (2, 1)
    assert failed.kept == pytest.approx(0.45) and failed.kept_min == 0.0
    assert by[(1.2, "search")].plan_s == pytest.approx(1.0)   # median of 0.5 and 1.5
    # search and replace of one design share it
    assert by[(1.2, "search")].design_id == by[(1.2, "replace")].design_id
    assert choose_cover_k(designs) == 2
    mark_frontiers(designs, 2)
    on = {key: (d.frontier["kept"], d.frontier["fold"]) for key, d in by.items()}
    assert on == {(1.2, "search"): (True, True), (1.4, "search"): (True, True),
                  (1.6, "search"): (False, False), (1.8, "search"): (True, True),
                  (1.2, "replace"): (True, True), (1.4, "replace"): (True, False),
                  (1.6, "replace"): (True, False), (1.8, "replace"): (False, False)}


def test_frontier_figure_and_report_table(hand_folder, tmp_path):
    designs = design_results(hand_folder)
    mark_frontiers(designs, 2)
    png = draw_frontier(designs, tmp_path / "frontier.png", 2)
    data = png.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 20_000
    assert not list(tmp_path.glob(".*.tmp"))
    rep = write_report(hand_folder)
    assert rep.figures[0].name == "frontier.png" and rep.figures[0].is_file()
    md = rep.markdown.read_text()
    assert "## Design frontier: coverage and feasibility" in md and "![frontier](frontier.png)" in md
    table = [line for line in md.splitlines() if line.startswith("| f |")]
    assert len(table) == 4                                  # one row per design point
    row = next(line for line in table if "| 1.8 |" in line).split(" | ")
    assert "0.450" in row and "2 (0) / 2 (1)" in row[-2]
    assert row[-1].strip(" |") == "kept s3, fold s3"      # the figure's tags
    first = next(line for line in table if "| 1.2 |" in line)
    assert first.split(" | ")[-1].strip(" |") == "kept s1, fold s1, kept r1, fold r1"
    # the table without tags names resolver and metric
    from rfp_twin.twin.studies.frontier import frontier_table
    plain = [line for line in frontier_table(designs) if "| 1.4 |" in line][0]
    assert plain.endswith("| search (kept), search (fold), replace (kept) |")
    # only the >= 1 share varies: the frontier is drawn against it
    for d in designs:
        d.cover[2] = 1.0
    assert choose_cover_k(designs) == 1


def test_reports_of_studies_without_coverage_have_no_frontier(tmp_path):
    study = parse_study(HAND)
    out = tmp_path / "plain"
    (out / RESULTS).mkdir(parents=True)
    for t in study.trial_list():
        write_row(out / RESULTS, made_row(study, t))
    rep = write_report(out)
    assert "frontier" not in rep.skipped and "Design frontier" not in rep.markdown.read_text()
    assert not (out / "report" / "frontier.png").exists()
    assert np.all([p.suffix == ".png" for p in rep.figures])
