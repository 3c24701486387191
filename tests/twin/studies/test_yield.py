"""Yield studies (twin/studies/yield_*.py): the catalogue axes declared once, a yield trial's
columns, resume of a yield study, its report, and bad input."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from tests.twin.studies.builders import study_file
from rfp_twin.models.catalogue import density_per_mm2
from rfp_twin.models.errors import CatalogueError
from rfp_twin.twin.catalogue_source import load_catalogue, parse_mock, robot_area_mm2
from rfp_twin.twin.plannable import MAX_ROUNDS
from rfp_twin.twin.studies import PARAM_COLUMNS, StudyError, load_study, parse_study, run_study
from rfp_twin.twin.studies.report import write_report
from rfp_twin.twin.studies.runner import run_trial
from rfp_twin.twin.studies.spec import GRID_KEYS, STUDY_KEYS, point_layout
from rfp_twin.twin.studies.store import done_keys, read_results
from rfp_twin.twin.studies.yield_options import YieldOptions, yield_help
from rfp_twin.twin.studies.yield_report import yield_points
from rfp_twin.twin.studies.yield_trial import targets_per_hour

#: Two designs (DESI-like and raft robots on 19 positions) x 2 kinds x 2 densities.
YIELD = """
[study]
name = "tiny-yield"
trials = 2
seed = 5
firmware = true
exposure_s = 600
[grid]
catalogue = ["uniform", "clustered"]
density = [0.25, 4.0]
priority_levels = 2
step_deg = 1.0
resolution = "search"
[[family]]
name = "desi"
preset = "desi"
n_robots = 19
[[family]]
name = "raft"
preset = "raft-6p2"
n_robots = 19
"""


def test_yield_keys_are_declared_once_and_enter_only_yield_points():
    for key in ("catalogue", "density", "density_unit", "priority_levels", "assign_rounds"):
        assert GRID_KEYS[key] == yield_help(key)
    assert STUDY_KEYS["exposure_s"] == yield_help("exposure_s")
    assert "uniform" in GRID_KEYS["catalogue"] and "clustered" in GRID_KEYS["catalogue"]
    assert "[0, 100000] s" in STUDY_KEYS["exposure_s"]
    assert YieldOptions().assign_rounds == MAX_ROUNDS      # the plan command's default
    study = parse_study(YIELD)
    assert len(study.points) == 8 and study.exposure_s == 600.0
    for p in study.points:
        d = p.to_dict()
        assert d["catalogue"] in ("uniform", "clustered") and d["density_unit"] == "robot"
        assert d["priority_levels"] == 2 and d["assign_rounds"] == MAX_ROUNDS
    # one design id per family: every density and catalogue of a design share it
    assert len({p.design_id for p in study.points}) == 2
    # without a catalogue the yield keys are not part of a point (older studies resume)
    plain = parse_study(YIELD.replace('catalogue = ["uniform", "clustered"]\n', ""))
    assert len(plain.points) == 2
    assert all(tuple(p.to_dict()) == PARAM_COLUMNS + ("family",) for p in plain.points)


def test_calibrated_instruments_are_study_layouts():
    study = parse_study(YIELD.replace('preset = "desi"\nn_robots = 19',
                                      'preset = "sdss-v-production"\nlayout = "sdss-v-lco"'))
    lco = [p for p in study.points if p.family == "desi"]
    assert {p.n_robots for p in lco} == {point_layout("sdss-v-lco", 0, 0.0).n_robots}
    assert all(p.pitch_mm == 22.4 and p.buffer_mm == 2.0 for p in lco)


@pytest.mark.parametrize("change, words", [
    (('catalogue = ["uniform", "clustered"]', 'catalogue = "poisson"'),
     ["grid.catalogue = 'poisson'", "uniform (Poisson) or clustered"]),
    (("density = [0.25, 4.0]", "density = [0.0]"), ["grid.density = 0.0", "[0.001, 1e+06]"]),
    (("density = [0.25, 4.0]", 'density = 1.0\ndensity_unit = "deg2"'),
     ["density_unit = 'deg2'", "a telescope's plate scale"]),
    (("density = [0.25, 4.0]", 'density = 1.0\ndensity_unit = "arcmin2"'),
     ["grid.density_unit = 'arcmin2'", "robot (targets per hexagonal cell"]),
    (("priority_levels = 2", "priority_levels = 0"), ["grid.priority_levels = 0", "[1, 1000]"]),
    (("exposure_s = 600", "exposure_s = -1"), ["study.exposure_s = -1", "[0, 100000] s"]),
    (('preset = "raft-6p2"', 'preset = "raft-6p2"\nlayout = "sdss-v-apo"\npitch_mm = 20.0'),
     ["pitch_mm = 20.0 with layout = 'sdss-v-apo'", "fixed pitch"]),
])
def test_bad_yield_input_is_one_line_naming_the_field(change, words):
    with pytest.raises(StudyError) as err:
        parse_study(YIELD.replace(*change), source="y.toml")
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith("y.toml: ")
    for w in words:
        assert w in msg, msg


def test_density_per_robot_is_a_mock_catalogue_unit():
    spec = load_study("yield-small").points[0].spec
    area = robot_area_mm2(spec)
    assert area == pytest.approx(math.sqrt(3) / 2 * 22.4 ** 2)
    assert density_per_mm2(2.0, "robot", robot_area_mm2=area) == pytest.approx(2.0 / area)
    assert parse_mock("mock:uniform:2/robot,levels=3") == ("uniform", 2.0, "robot",
                                                          {"levels": "3"})
    with pytest.raises(CatalogueError, match="area per robot"):
        density_per_mm2(2.0, "robot")


def test_a_yield_trial_counts_what_the_plan_keeps():
    study = parse_study(YIELD)
    rows = {}
    for p in study.points:
        if p.family == "desi" and p.catalogue == "uniform":
            rows[p.density] = [run_trial(p, i, study.seed, firmware=True, exposure_s=600.0)
                               for i in range(2)]
    for dens, rs in rows.items():
        for r in rs:
            assert r["status"] == "ok" and r["error"] is None
            assert r["collisions"] == 0 and r["n_lost"] == 0 and r["checked"]
            assert 0 < r["n_available"] <= r["n_targets"]
            assert r["targets_per_pointing"] <= min(19, r["n_assigned"], r["n_available"])
            assert r["completeness"] == r["targets_per_pointing"] / r["n_available"]
            levels = json.loads(r["completeness_by_priority"])
            assert set(levels) <= {"1", "2"} and all(0.0 <= c <= 1.0 for c in levels.values())
            assert r["completeness_top"] == levels[max(levels, key=float)]
            assert r["reconfig_s"] == r["fold_fw_s"] > 0 and r["fold_time_s"] > 0
            assert r["targets_per_hour"] == pytest.approx(
                3600 * r["targets_per_pointing"] / (r["reconfig_s"] + 600.0))
            assert r["loop_rounds"] >= 1 and r["exposure_s"] == 600.0
            missed = [r[k] for k in ("missed_busy", "missed_parked", "missed_neighbour",
                                     "missed_other")]
            assert min(missed) >= 0 and sum(missed) == r["n_available"] - r["targets_per_pointing"]
            # the row's catalogue text and seed draw the same catalogue again (replay)
            geom_n = r["n_targets"]
            from rfp_twin.models.array import ArrayGeometry
            p0 = study.points[0]
            geom = ArrayGeometry(p0.spec, point_layout("hex", 19, p0.spec.pitch_mm), 1.0)
            assert load_catalogue(r["catalogue_text"], geom, telescope=None, field_centre=None,
                                  seed=r["seed"]).n_targets == geom_n
    # 16 times the density: more targets per pointing, a smaller share of them
    assert np.mean([r["completeness"] for r in rows[4.0]]) < \
        np.mean([r["completeness"] for r in rows[0.25]])
    assert min(r["targets_per_pointing"] for r in rows[4.0]) > \
        max(r["targets_per_pointing"] for r in rows[0.25])
    assert targets_per_hour(10, 100.0, 800.0) == 40.0


def test_a_yield_study_resumes_skipping_done_trials_and_reports(tmp_path):
    study = study_file(YIELD.replace("trials = 2", "trials = 1"), tmp_path)
    out = tmp_path / "out"
    first = run_study(study, out, workers=1, processes=False, progress=False, max_trials=3)
    assert (first.n_run, first.complete) == (3, False)
    done = read_results(out).to_pydict()
    stamps = dict(zip(done["key"], done["finished_utc"]))
    # interrupted after 3 trials: the run again skips them and runs the other 5
    again = run_study(study, out, workers=1, processes=False, progress=False)
    assert (again.n_before, again.n_run, again.complete) == (3, 5, True)
    rows = read_results(out).to_pydict()
    assert len(done_keys(out)) == 8 == len(rows["key"])
    for key, stamp in zip(rows["key"], rows["finished_utc"]):
        if key in stamps:
            assert stamp == stamps[key]            # not run again
    assert all(c is not None for c in rows["completeness"])
    rep = write_report(out)
    names = {p.name for p in rep.figures}
    assert {"yield_completeness.png", "yield_frontier.png"} <= names
    text = rep.markdown.read_text()
    assert "## Science yield" in text and "targets per hour** = 3600" in text
    assert "rfp-twin plan --preset" in text and "--catalogue mock:" in text
    points = yield_points(out)
    assert len(points) == 8 and {p.label.split(":")[0] for p in points} == {"desi", "raft"}


PARKED = """
[study]
firmware = true
[grid]
catalogue = "uniform"
density = 0.25
step_deg = 1.0
resolution = "search"
[[family]]
name = "sdss"
preset = "sdss-v-production"
n_robots = 37
[[family]]
name = "desi"
preset = "desi"
n_robots = 37
"""


def test_misses_name_the_parked_neighbours_of_long_arms():
    """At a sparse density most robots park at the fold: SDSS-V's 15 mm beta arms, folded,
    block targets of their neighbours; the DESI-like 3 + 3 mm arms do not."""
    study = parse_study(PARKED)
    parked = {}
    for p in study.points:
        rows = [run_trial(p, i, 3, firmware=True) for i in range(4)]
        parked[p.family] = sum(r["missed_parked"] for r in rows)
        for r in rows:
            assert r["n_lost"] == 0 and r["collisions"] == 0
            assert r["missed_busy"] + r["missed_parked"] + r["missed_neighbour"] + \
                r["missed_other"] == r["n_available"] - r["targets_per_pointing"]
    assert parked["sdss"] > 0 and parked["desi"] == 0


def test_shipped_yield_study():
    study = load_study("yield-small")
    assert study.families == ("sdss-apo", "sdss-lco", "desi", "raft")
    assert study.firmware and study.check and study.exposure_s == 900.0
    assert len(study.points) == 70 and study.n_trials == 350
    assert {p.layout for p in study.points} == {"sdss-v-apo", "sdss-v-lco", "hex", "raft"}
    assert {p.density for p in study.points} == {0.25, 0.5, 1.0, 2.0, 4.0}
    assert {p.catalogue for p in study.points} == {"uniform", "clustered"}
    sdss = [p for p in study.points if p.family.startswith("sdss")]
    assert {(p.preset, p.buffer_mm, p.n_robots) for p in sdss} == {("sdss-v-production", 2.0, 500)}
    assert len({p.design_id for p in study.points}) == 7
