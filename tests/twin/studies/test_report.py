"""Study reports (twin/studies/report.py, with figures.py, groups.py and paper.py)."""
from __future__ import annotations

import numpy as np
import pytest

from tests.twin.studies.builders import made_row, study_file
from rfp_twin.twin.studies import RESULTS, StudyError, load_study, run_study, write_row
from rfp_twin.twin.studies.report import FIGURES, PAPER_FIG10, write_report

#: Varies every axis a figure needs (buffer, step, grid size, pitch / reach).
ALL_AXES = """
[study]
name = "all-axes"
trials = 2
seed = 5
[grid]
n_robots = [7, 19]
pitch_mm = [20.0, 22.4]
buffer_mm = [1.5, 2.5]
step_deg = [0.5, 1.0]
algorithm = ["greedy", "markov"]
"""


def test_report_renders_every_figure(tmp_path):
    study = study_file(ALL_AXES, tmp_path)
    out = tmp_path / "out"
    run_study(study, out, workers=1, processes=False, progress=False)
    rep = write_report(out)
    assert not rep.skipped
    assert sorted(p.stem for p in rep.figures) == sorted(FIGURES)
    for p in rep.figures:
        data = p.read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000, p
    assert not list(rep.markdown.parent.glob(".*"))     # no temporaries left
    md = rep.markdown.read_text()
    for stem in FIGURES:
        assert f"({stem}.png)" in md
    assert "## Results per grid point" in md and "## Trends vs buffer" in md
    assert "## Runtime vs grid size" in md
    assert "rfp-twin plan --preset sdss-v" in md


def test_report_puts_the_papers_fig10_beside_ours(tmp_path):
    """Rows shaped like Simulation 1 (made metrics, real keys): the comparison table."""
    study = load_study("sim1-small")
    out = tmp_path / "sim1"
    results = out / RESULTS
    results.mkdir(parents=True)
    (out / "study.toml").write_text(study.text)
    rng = np.random.default_rng(0)
    for t in study.trial_list(3):
        p = t.point
        slope, offset = (0.02, 0.002) if p.algorithm == "greedy" else (0.005, 0.0)
        base = 1.0 - offset - slope * (p.buffer_mm - 1.5)
        write_row(results, made_row(study, t, efficiency=base - rng.uniform(0, 1e-4),
                                    convergence=base, n_replaced=1,
                                    fold_time_s=12.0 if p.algorithm == "greedy" else 24.0))
    rep = write_report(out)
    md = rep.markdown.read_text()
    assert "## Beside Sayres 2021 Simulation 1" in md
    assert "| GC | 3.5 | 3 |" in md and "0.968" in md and "0.993" in md
    assert rep.trends["monotonic GC"] and rep.trends["monotonic MC"] and rep.trends["MC >= GC"]
    assert set(PAPER_FIG10) <= {(p.algorithm, p.buffer_mm) for p in study.points}
    assert {"fig15_efficiency_vs_step", "feasibility_map"} <= set(rep.skipped)
    assert rep.skipped["fig17_efficiency_vs_grid"] == "n_robots has one value in this study"


def test_failed_trials_are_counted_and_named(tmp_path):
    """An infeasible design: every trial an error row; the report says why, draws the map."""
    text = "[study]\ntrials = 2\n[grid]\nn_robots = 7\npitch_mm = [16.0, 22.4]\nbuffer_mm = 3.5\n"
    study = study_file(text, tmp_path)
    out = tmp_path / "out"
    (out / RESULTS).mkdir(parents=True)
    (out / "study.toml").write_text(text)
    error = "PlanningError: folded state (10.0, 170.0) deg collides"
    for t in study.trial_list():
        bad = t.point.pitch_mm == 16.0
        write_row(out / RESULTS, made_row(study, t, **(dict(
            status="error", error=error, efficiency=None, checked=True, collisions=None)
            if bad else {})))
    rep = write_report(out)
    md = rep.markdown.read_text()
    assert "Failed trials (no plan, e.g. no clear random targets): 2." in md
    assert f"`{error}`" in md
    assert [p.stem for p in rep.figures] == ["feasibility_map"]


def test_a_folder_without_results_is_refused(tmp_path):
    with pytest.raises(StudyError, match="no results/ folder"):
        write_report(tmp_path)
    (tmp_path / RESULTS).mkdir()
    with pytest.raises(StudyError, match="no trials in results/ yet"):
        write_report(tmp_path)
