"""Design-study files (twin/studies/spec.py, parse.py, resolve.py): families, the arm ratio
and pitch / reach axes, raft layouts, shared targets, backward compatibility, bad input."""
from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from tests.twin.studies.builders import study_file
from rfp_twin.twin.cli.study import study_app
from rfp_twin.twin.studies import PARAM_COLUMNS, StudyError, list_studies, load_study, parse_study

#: Two families, two resolvers on the same targets: 2 x 2 + 1 x 2 = 6 points.
DESIGN = """
[study]
name = "tiny-design"
trials = 2
seed = 7
same_targets = ["resolution"]
coverage = true
firmware = true
[grid]
resolution = ["search", "replace"]
step_deg = 1.0
max_rounds = 2
[[family]]
name = "raft"
preset = "raft-6p2"
layout = "raft"
n_rafts = 1
arm_ratio = [0.8, 1.25]
pitch_over_reach = 1.72
buffer_mm = 0.8
[[family]]
name = "sdss"
n_robots = 19
arm_ratio = 1.0
pitch_over_reach = 1.2
buffer_mm = 2.0
fold_alpha_deg = 90.0
fold_beta_deg = 180.0
"""


def test_families_are_unions_of_products_with_their_own_axes():
    study = parse_study(DESIGN)
    assert study.families == ("raft", "sdss") and len(study.points) == 6
    assert study.same_targets == ("resolution",) and study.coverage and study.firmware
    raft = [p for p in study.points if p.family == "raft"]
    sdss = [p for p in study.points if p.family == "sdss"]
    assert len(raft) == 4 and len(sdss) == 2
    for p in raft:
        # 63 robots per raft; pitch kept, reach = pitch / (pitch / reach), split at q
        assert (p.layout, p.n_rafts, p.n_robots, p.pitch_mm) == ("raft", 1, 63, 6.2)
        assert p.reach_mm == pytest.approx(6.2 / 1.72)
        assert p.alpha_length_mm / p.beta_length_mm == pytest.approx(p.arm_ratio)
        assert p.segment_end_mm == pytest.approx(p.beta_length_mm)   # on the fiber
        assert p.spec.alpha_length_mm == p.alpha_length_mm and p.spec.buffer_mm == 0.8
    for p in sdss:
        assert (p.preset, p.layout, p.n_robots, p.n_rafts) == ("sdss-v", "hex", 19, None)
        assert p.alpha_length_mm == pytest.approx(22.4 / 1.2 / 2)
        assert p.spec.fold_deg == (90.0, 180.0)
    # the arm ratio keeps the reach
    a, b = (p for p in raft if p.resolution == "search")
    assert a.reach_mm == pytest.approx(b.reach_mm) and a.alpha_length_mm != b.alpha_length_mm


def test_search_and_replace_share_targets_but_not_keys():
    study = parse_study(DESIGN)
    trials = study.trial_list()
    by_design: dict = {}
    for t in trials:
        by_design.setdefault((t.point.design_id, t.index), []).append(t)
    assert len(by_design) == 3 * 2
    for pair in by_design.values():
        assert sorted(t.point.resolution for t in pair) == ["replace", "search"]
        assert pair[0].seed == pair[1].seed                    # same random targets
        assert pair[0].key != pair[1].key                      # two rows
        assert pair[0].point.geometry_id == pair[1].point.geometry_id
    # without same_targets each point draws its own targets
    own = parse_study(DESIGN.replace('same_targets = ["resolution"]', ""))
    seeds = {}
    for t in own.trial_list():
        seeds.setdefault((t.point.design_id, t.index), set()).add(t.seed)
    assert all(len(s) == 2 for s in seeds.values())
    # the geometry does not depend on the buffer, the design does
    two = parse_study(DESIGN.replace("buffer_mm = 2.0", "buffer_mm = [2.0, 3.0]"))
    sd = [p for p in two.points if p.family == "sdss" and p.resolution == "search"]
    assert sd[0].geometry_id == sd[1].geometry_id and sd[0].design_id != sd[1].design_id


def test_older_studies_keep_their_keys_and_seeds():
    """Points of studies without design keys hash exactly the PARAM_COLUMNS, as before."""
    for name in ("sim1-small", "density-small"):
        study = load_study(name)
        for p in study.points:
            assert tuple(p.to_dict()) == PARAM_COLUMNS
            old = json.dumps({k: getattr(p, k) for k in PARAM_COLUMNS}, sort_keys=True,
                             separators=(",", ":"))
            assert p.canonical == p.seed_canonical == old
    # a pinned trial of sim1-small (its key and seed must never change: stored studies resume)
    t = load_study("sim1-small").trial_list()[0]
    assert (t.key, t.seed) == ("e16483aac5aaa7781bb6", 3471601024095428699)


def test_shipped_design_studies():
    assert {"design", "design-small"} <= set(list_studies())
    small, full = load_study("design-small"), load_study("design")
    assert small.same_targets == full.same_targets == ("resolution",)
    assert small.coverage and small.firmware and small.families == ("raft", "sdss")
    for s in (small, full):
        assert {p.resolution for p in s.points} == {"search", "replace"}
        assert {round(p.alpha_length_mm / p.beta_length_mm, 6) for p in s.points} == {0.8, 1.0, 1.25}
    assert len(small.points) == 144 and small.n_trials == 576


@pytest.mark.parametrize("change, words", [
    (("buffer_mm = 0.8", "buffer_mm = []"),
     ["family[raft].buffer_mm = []", "non-empty list", "a number > 0 (mm)"]),
    (("arm_ratio = [0.8, 1.25]", "arm_ratio = [0.8, 0.0]"),
     ["family[raft].arm_ratio = 0.0", "(0, inf)"]),
    (("arm_ratio = 1.0", "arm_ratio = -1.25"), ["family[sdss].arm_ratio = -1.25", "(0, inf)"]),
    (("arm_ratio = 1.0", "arm_ratio = inf"), ["family[sdss].arm_ratio = inf", "(0, inf)"]),
    (("buffer_mm = 0.8", "buffer_mm = 3.1"),
     ["family[raft].buffer_mm = 3.1 at pitch_mm = 6.2", "buffer_mm < pitch_mm / 2 = 3.1"]),
    (("buffer_mm = 2.0", "buffer_mm = [2.0, 11.2]"),
     ["family[sdss].buffer_mm = 11.2 at pitch_mm = 22.4", "pitch_mm / 2 = 11.2"]),
    (("pitch_over_reach = 1.2", "pitch_over_reach = 0"), ["family[sdss].pitch_over_reach = 0"]),
    (("n_rafts = 1\n", ""), ["family[raft].n_rafts is not set", "integer >= 1"]),
    (("n_rafts = 1", "n_rafts = 0"), ["family[raft].n_rafts = 0", "integer >= 1"]),
    (('name = "sdss"', 'name = "raft"'), ["family[1].name = 'raft'", "different in each"]),
    (('same_targets = ["resolution"]', 'same_targets = ["buffer_mm"]'),
     ["study.same_targets = ['buffer_mm']", "resolution, max_rounds"]),
    (("fold_beta_deg = 180.0", "fold_beta_deg = 180.0\nbufer = 1"),
     ["unknown key 'bufer' in family 'sdss'"]),
])
def test_bad_design_input_is_one_line_naming_the_field(tmp_path, change, words):
    text = DESIGN.replace(*change)
    assert text != DESIGN
    with pytest.raises(StudyError) as info:
        study_file(text, tmp_path, "bad.toml")
    msg = str(info.value)
    assert "\n" not in msg and str(tmp_path / "bad.toml") in msg
    for w in words:
        assert w in msg, msg


@pytest.mark.parametrize("change", [("buffer_mm = 0.8", "buffer_mm = []"),
                                    ("arm_ratio = 1.0", "arm_ratio = 0"),
                                    ("buffer_mm = 2.0", "buffer_mm = 11.5")])
def test_cli_exits_2_and_writes_nothing_on_bad_design_input(tmp_path, change):
    bad = tmp_path / "bad.toml"
    bad.write_text(DESIGN.replace(*change))
    out = tmp_path / "o"
    r = CliRunner().invoke(study_app, ["run", str(bad), "--out", str(out), "--workers", "1"])
    assert r.exit_code == 2, r.output
    errors = [line for line in r.stderr.splitlines() if line.strip()]
    assert len(errors) == 1 and errors[0].startswith("error:") and change[1].split()[0] in errors[0]
    assert not out.exists()
