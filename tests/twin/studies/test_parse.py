"""Study files -> Study (twin/studies/parse.py): every bad key or value is one line naming
the file, the key and what is allowed; shipped studies are the paper's Simulations."""
from __future__ import annotations

import pytest

from tests.twin.studies.builders import study_file
from rfp_twin.twin.studies import StudyError, list_studies, load_study, parse_study


@pytest.mark.parametrize("text, words", [
    ("[grid]\nbufer_mm = 2.0\n", ["unknown key 'bufer_mm' in table 'grid'", "buffer_mm", "step_deg"]),
    ("[study]\ntrails = 3\n", ["unknown key 'trails' in table 'study'", "trials"]),
    ("[grids]\n", ["unknown table or key 'grids'", "tables 'study' and 'grid'"]),
    ("[grid]\nalgorithm = ['greedy', 'astar']\n", ["grid.algorithm = 'astar'",
                                                  "greedy | markov"]),
    ("[grid]\nn_robots = 500\n", ["grid.n_robots = 500", "nearest: 469, 547"]),
    ("[grid]\nbuffer_mm = [2.0, 12.0]\n", ["buffer_mm = 12.0", "pitch_mm / 2 = 11.2"]),
    ("[grid]\nstep_deg = 0\n", ["grid.step_deg = 0", "[0.001, 10]"]),
    ("[grid]\ngreed = 1.5\n", ["grid.greed = 1.5", "[0, 1]"]),
    ("[grid]\nresolution = 'roadmap'\n", ["grid.resolution = 'roadmap'", "replace | search | none"]),
    ("[grid]\nbuffer_mm = []\n", ["grid.buffer_mm = []", "non-empty list"]),
    ("[grid]\nbuffer_mm = [2.0, 2.0]\n", ["without repeated values"]),
    ("[grid]\npreset = 'nope'\n", ["grid.preset = 'nope'", "sdss-v"]),
    ("[grid]\nlayout = 'sdss-v-fps'\npitch_mm = 20.0\n", ["grid.pitch_mm = 20.0",
                                                        "unset or 22.4"]),
    ("[study]\ntrials = 0\n", ["study.trials = 0", "integer >= 1"]),
    ("[study]\ncheck = 'yes'\n", ["study.check = 'yes'", "true | false"]),
    ("[study]\nname = 'a b'\n", ["study.name = 'a b'", "folder-safe"]),
    ("[study\n", ["malformed TOML"]),
])
def test_bad_study_files_name_the_key_and_the_allowed_values(tmp_path, text, words):
    with pytest.raises(StudyError) as info:
        study_file(text, tmp_path, "bad.toml")
    msg = str(info.value)
    assert str(tmp_path / "bad.toml") in msg and "\n" not in msg
    for w in words:
        assert w in msg, msg


def test_unknown_study_names_list_the_shipped_ones(tmp_path):
    with pytest.raises(StudyError, match="sim1-small"):
        load_study("no-such-study")
    with pytest.raises(StudyError, match="study file not found"):
        load_study(tmp_path / "missing.toml")


def test_points_take_the_presets_defaults_and_follow_the_arm():
    study = parse_study("[grid]\nn_robots = 7\nbeta_length_mm = [15.0, 18.0]\n"
                        "algorithm = ['GC', 'MC']\n")
    assert len(study.points) == 4 and study.varied() == ["beta_length_mm", "algorithm"]
    for p in study.points:
        # the sdss-v segment runs to the fiber: a longer arm takes its segment along
        assert p.segment_end_mm == p.beta_length_mm == p.spec.beta_length_mm
        assert (p.pitch_mm, p.buffer_mm, p.spec.buffer_mm) == (22.4, 2.5, 2.5)
        assert (p.greed, p.phobia) == ((0.9, 0.3) if p.algorithm == "markov" else (1.0, 0.0))


def test_shipped_studies_match_the_paper_tables():
    names = list_studies()
    for n in ("sim1", "sim1-small", "sim2", "sim2-small", "sim3", "sim3-small", "density",
              "density-small"):
        assert n in names
    sim1, sim2, sim3 = load_study("sim1"), load_study("sim2"), load_study("sim3")
    assert sim1.n_trials == 36000 and sim2.n_trials == 18000 and sim3.n_trials == 6000
    assert sim1.grid["buffer_mm"] == (1.5, 1.75, 2.0, 2.25, 2.5, 2.75, 3.0, 3.25, 3.5)
    assert sim2.grid["step_deg"] == (0.05, 0.1, 0.25, 0.5, 0.75, 1.0)
    assert sim3.grid["n_robots"][0] == 37 and sim3.grid["n_robots"][-3:] == (2269, 2611, 2977)
    for s in (sim1, sim2, sim3):
        for p in s.points:
            assert (p.alpha_length_mm, p.beta_length_mm, p.pitch_mm) == (7.4, 15.0, 22.4)
            assert p.spec.fold_deg == (10.0, 170.0)
            assert p.max_steps == round(1000 / p.step_deg)
            assert (p.greed, p.phobia) == ((0.9, 0.3) if p.algorithm == "markov" else (1.0, 0.0))
    # the small versions are the first trials of the full ones (same keys)
    small = {t.key for t in load_study("sim1-small").trial_list()}
    assert small == {t.key for t in sim1.trial_list(6)}
