"""Report figures (twin/studies/figures.py): what is drawn, what is left out and why."""
from __future__ import annotations

from tests.twin.studies.builders import made_row
from rfp_twin.twin.studies import RESULTS, parse_study, write_row
from rfp_twin.twin.studies.figures import MAX_SERIES, draw_figures
from rfp_twin.twin.studies.groups import load_groups, varied_params

MANY = """
[study]
trials = 2
[grid]
n_robots = 7
buffer_mm = [1.5, 2.5]
greed = [0.3, 0.35, 0.4, 0.45, 0.5, 0.55, 0.6, 0.65, 0.7, 0.75, 0.8, 0.85, 0.9]
algorithm = "markov"
"""


def test_figures_follow_the_varied_parameters_and_cap_the_series(tmp_path):
    study = parse_study(MANY)
    out = tmp_path / "out"
    (out / RESULTS).mkdir(parents=True)
    for t in study.trial_list():
        write_row(out / RESULTS, made_row(study, t, efficiency=1.0 - 0.01 * t.point.buffer_mm
                                          - 0.001 * t.index))
    groups, _ = load_groups(out)
    varied = varied_params(groups)
    assert varied == ["buffer_mm", "greed"]
    notes: list[str] = []
    drawn, skipped = draw_figures(groups, varied, tmp_path, notes)
    assert drawn == ["fig10_efficiency_mean", "fig11_efficiency_min", "fig12_efficiency_box",
                     "fig13_fold_time_mean", "fig14_fold_time_box"]
    assert skipped == {
        "fig15_efficiency_vs_step": "step_deg has one value in this study",
        "fig16_runtime_vs_step": "step_deg has one value in this study",
        "fig17_efficiency_vs_grid": "n_robots has one value in this study",
        "fig18_runtime_vs_grid": "n_robots has one value in this study",
        "feasibility_map": "pitch / reach has one value in this study (vary pitch_mm or the "
                           "arm lengths)"}
    assert sorted(p.name for p in tmp_path.glob("*.png")) == sorted(f"{n}.png" for n in drawn)
    # 13 greeds = 13 lines vs buffer: the first MAX_SERIES are drawn, and it is said
    assert notes[0] == (f"figs. 10-14: 13 series; the first {MAX_SERIES} of each algorithm "
                        "are drawn.")
