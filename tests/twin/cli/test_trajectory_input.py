"""A jaeger / kaiju trajectory file into `validate` (and `simulate`, `render`, `record`).

Files are written by hand into tmp_path: two neighbouring robots of the calibrated APO
instrument (548 and 846, bases 22.2 mm apart, 846 almost straight below 548 in the
plane), in encoder angles (model = encoder + the robot's offsets). Bad input must be one
line naming the file, the positioner and the field, exit 2, and no report written.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import typer
from typer.testing import CliRunner

from rfp_twin.models.layout import layout_by_name
from rfp_twin.twin.cli.validate import EXIT_BAD_INPUT, EXIT_COLLISION, register
from rfp_twin.twin.trajectory_file import angle_offsets_of

A, B = 548, 846


@pytest.fixture(scope="module")
def app():
    a = typer.Typer()
    register(a)
    return a


@pytest.fixture(scope="module")
def offsets():
    lay = layout_by_name("sdss-v-apo", 22.4)
    off = angle_offsets_of(lay)
    rows = lay.robot_indices([A, B])
    return {A: off[rows[0]], B: off[rows[1]]}


def invoke(app, *args):
    return CliRunner().invoke(app, [str(a) for a in args])


def encoder(offsets, rid, alpha, beta):
    """Model (alpha, beta) deg of robot ``rid`` as its encoder reads them."""
    return alpha - offsets[rid][0], beta - offsets[rid][1]


def clear_motion(offsets) -> dict:
    """Robot 548 turns alpha 10 -> 40 deg folded, 846 stays folded: far apart."""
    a0, b0 = encoder(offsets, A, 10.0, 170.0)
    a1, _ = encoder(offsets, A, 40.0, 170.0)
    c, d = encoder(offsets, B, 10.0, 170.0)
    return {str(A): {"alpha": [[a0, 0.0], [a1, 3.0]], "beta": [[b0, 0.0], [b0, 3.0]]},
            str(B): {"alpha": [[c, 0.0], [c, 3.0]], "beta": [[d, 0.0], [d, 3.0]]}}


def write(path: Path, data) -> Path:
    path.write_text(data if isinstance(data, str) else json.dumps(data))
    return path


def test_a_clear_file_reports_2d_clearance_kept_buffer_and_3d(app, tmp_path, offsets):
    f = write(tmp_path / "traj.json", clear_motion(offsets))
    r = invoke(app, "validate", f, "--layout", "sdss-v-apo")
    assert r.exit_code == 0, r.output
    report = tmp_path / "traj.validation.json"
    data = json.loads(report.read_text())
    assert data["check2d"]["ok"] and data["check2d"]["buffer_mm"] == 2.0
    assert data["ok"] and data["n_robots"] == 2 and data["pairs"]
    assert data["angles"] == "encoder" and data["n_moved"] == 2
    assert len(data["absent_ids"]) == 498
    kept = data["kept_buffer"]
    pmin = data["check2d"]["pair_min_distance_mm"][0]
    # one robot pair: kept >= d / 2 at 2.0 mm (production's segment is shorter at a larger
    # buffer, so the pair is farther apart there); its fixed point: tests/twin/test_kept_buffer.py
    assert set(kept["robot_pair"]) == {A, B}
    assert kept["robot_mm"] >= pmin / 2 - 1e-9
    assert kept["buffer_mm"] == min(kept["robot_mm"], kept["obstacle_mm"] or np.inf)
    assert "kept buffer" in r.output and "not checked: 498 robot(s)" in r.output


def test_encoder_and_model_files_are_the_same_motion(app, tmp_path, offsets):
    """The same motion written in encoder angles and in model angles (--angles model)."""
    enc = clear_motion(offsets)
    model = {k: {ax: [[p[0] + offsets[int(k)][i], p[1]] for p in v[ax]]
                 for i, ax in enumerate(("alpha", "beta"))} for k, v in enc.items()}
    a = write(tmp_path / "enc.json", enc)
    b = write(tmp_path / "model.json", model)
    assert invoke(app, "validate", a, "--layout", "sdss-v-apo").exit_code == 0
    assert invoke(app, "validate", b, "--layout", "sdss-v-apo", "--angles", "model").exit_code == 0
    da = json.loads((tmp_path / "enc.validation.json").read_text())
    db = json.loads((tmp_path / "model.validation.json").read_text())
    assert da["check2d"]["pair_min_distance_mm"] == pytest.approx(
        db["check2d"]["pair_min_distance_mm"], abs=1e-9)
    assert da["min_distance_mm"] == pytest.approx(db["min_distance_mm"], abs=1e-9)


def test_a_jaeger_dump_holds_unlisted_robots_at_their_initial_positions(app, tmp_path, offsets):
    """Robot 548 reaches straight down (alpha 270, beta 1) towards 846, which the
    trajectory does not move but the dump's initial positions hold reaching up at it."""
    a0, b0 = encoder(offsets, A, 270.0, 170.0)
    _, b1 = encoder(offsets, A, 270.0, 1.0)
    dump = {"start_time": 0.0, "success": True, "extra": {}, "final_positions": {},
            "trajectory": {str(A): {"alpha": [[a0, 0.0], [a0, 20.0]],
                                    "beta": [[b0, 0.0], [b1, 20.0]]}},
            "initial_positions": {str(A): list(encoder(offsets, A, 270.0, 170.0)),
                                  str(B): list(encoder(offsets, B, 90.0, 1.0)),
                                  "99999": [0.0, 0.0], "3": [None, None]}}
    f = write(tmp_path / "trajectory-60000-0001.json", dump)
    r = invoke(app, "validate", f, "--layout", "sdss-v-apo")
    assert r.exit_code == EXIT_COLLISION, r.output
    data = json.loads((tmp_path / "trajectory-60000-0001.validation.json").read_text())
    assert data["n_held"] == 1 and data["n_moved"] == 1
    hit = data["check2d"]["collisions"][0]
    assert {hit["robot_a"], hit["other"]} == {A, B}
    assert data["kept_buffer"]["buffer_mm"] < 0.5
    assert "2D collision" in r.output


def bad_cases(offsets):
    good = clear_motion(offsets)

    def with_(rid, axis, points):
        d = json.loads(json.dumps(good))
        d[str(rid)][axis] = points
        return d

    no_beta = json.loads(json.dumps(good))
    del no_beta[str(A)]["beta"]
    unknown = json.loads(json.dumps(good))
    unknown["12345"] = good[str(A)]
    a0 = good[str(A)]["alpha"][0][0]
    return [
        ("malformed", '{"548": {"alpha": [[1, 0],, }', "{f}: malformed JSON at line 1 column 27: "
         "Expecting value; allowed: a JSON object "
         '{{"<positioner id>": {{"alpha": [[deg, s], ...], "beta": [[deg, s], ...]}}}}'),
        ("unknown", unknown, "{f}: positioner 12345 is not a robot of sdss-v-apo; allowed: a "
         "positioner of sdss-v-apo (500 robots, ids 3..1400)"),
        ("missing axis", no_beta, f"{{f}}: positioner {A}: field 'beta' is missing; allowed: "
         "both 'alpha' and 'beta', each a list of [deg, s] points"),
        ("backwards", with_(A, "alpha", [[a0, 0.0], [a0 + 1, 2.0], [a0 + 2, 1.0]]),
         f"{{f}}: positioner {A}: field 'alpha' time goes backwards at point 2: 1 s after 2 s; "
         "allowed: non-decreasing times"),
        ("outside", with_(A, "alpha", [[a0, 0.0], [370.0, 2.0]]),
         f"{{f}}: positioner {A}: field 'alpha' = 370 deg (encoder) at t = 2 s (point 1); "
         "allowed: [0, 360] deg (encoder)"),
        ("nan", with_(A, "beta", [[170.0, 0.0], [float("nan"), 2.0]]),
         f"{{f}}: positioner {A}: field 'beta' point 1 = [NaN, 2.0]; allowed: finite numbers "
         "[deg, s]"),
        ("not a point", with_(A, "beta", [[170.0, 0.0], [171.0]]),
         f"{{f}}: positioner {A}: field 'beta' point 1 = [171.0]; allowed: [deg, s], two numbers"),
    ]


@pytest.mark.parametrize("case", range(7))
def test_bad_trajectory_file_is_one_line_exit_2_nothing_written(app, tmp_path, offsets, case):
    name, data, message = bad_cases(offsets)[case]
    f = write(tmp_path / "t.json", data)
    r = invoke(app, "validate", f, "--layout", "sdss-v-apo")
    assert r.exit_code == EXIT_BAD_INPUT, (name, r.output)
    lines = [ln for ln in r.output.splitlines() if ln.strip()]
    assert len(lines) == 1, (name, r.output)
    assert lines[0] == "error: " + message.format(f=f), name
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.json"], name


def test_a_file_of_another_instrument_is_named(app, tmp_path):
    """Positioners of LCO in a file validated as APO: the ids say which instrument."""
    lco = layout_by_name("sdss-v-lco", 22.4)
    ids = lco.robot_ids[:3]
    data = {str(int(i)): {"alpha": [[10.0, 0.0]], "beta": [[170.0, 0.0]]} for i in ids}
    f = write(tmp_path / "lco.json", data)
    r = invoke(app, "validate", f, "--layout", "sdss-v-apo")
    assert r.exit_code == EXIT_BAD_INPUT, r.output
    assert r.output.strip() == (
        f"error: {f}: 3 of its 3 positioner ids (e.g. {int(ids[0])}) are not robots of "
        "sdss-v-apo: its ids are those of sdss-v-lco; allowed: positioners of sdss-v-apo "
        "(500 robots, ids 3..1400)")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["lco.json"]


def test_a_file_needs_its_instrument_and_a_run_folder_refuses_one(app, tmp_path, offsets):
    f = write(tmp_path / "t.json", clear_motion(offsets))
    r = invoke(app, "validate", f)
    assert r.exit_code == EXIT_BAD_INPUT
    assert "needs its instrument; allowed: --layout" in r.output
    folder = tmp_path / "run"
    folder.mkdir()
    r = invoke(app, "validate", folder, "--layout", "sdss-v-apo")
    assert r.exit_code == EXIT_BAD_INPUT and "--layout applies to a trajectory file" in r.output
    r = invoke(app, "validate", tmp_path / "none.json", "--layout", "sdss-v-apo")
    assert r.exit_code == EXIT_BAD_INPUT and "trajectory file not found" in r.output


def test_a_calibration_folder_with_a_70_mm_alpha_arm_is_refused(app, tmp_path, offsets):
    """--calibration DIR: robot 548's alphaArmLen set to 70 mm is no SDSS-V robot."""
    import csv
    import shutil

    from rfp_twin.models.instrument import calibration_folder

    cal = tmp_path / "cal"
    shutil.copytree(calibration_folder("sdss-v-apo"), cal)
    table = cal / "positionerTable.csv"
    table.chmod(0o644)
    with table.open(newline="") as fh:
        rows = list(csv.reader(fh))
    k = next(i for i, r in enumerate(rows) if r[rows[0].index("positionerID")] == str(A))
    rows[k][rows[0].index("alphaArmLen")] = "70"
    with table.open("w", newline="") as fh:
        csv.writer(fh).writerows(rows)
    f = write(tmp_path / "t.json", clear_motion(offsets))
    r = invoke(app, "validate", f, "--calibration", cal)
    assert r.exit_code == EXIT_BAD_INPUT, r.output
    assert r.output.strip() == (f"error: {table}:{k + 1}: robot {A}: field 'alphaArmLen' = 70 mm; "
                                "allowed: [6.9, 7.9] mm (design 7.4 mm +- 0.5 mm)")
    assert not (tmp_path / "t.validation.json").exists()
    # the same folder untouched is read, and the motion checked on it
    rows[k][rows[0].index("alphaArmLen")] = "7.4"
    with table.open("w", newline="") as fh:
        csv.writer(fh).writerows(rows)
    assert invoke(app, "validate", f, "--calibration", cal).exit_code == 0


def test_simulate_render_record_take_a_trajectory_file(tmp_path):
    """The MuJoCo commands replay a file on a layout (hex:7: model = encoder angles)."""
    import imageio.v3 as iio

    from tests.twin.cli.runner import run

    data = {str(i): {"alpha": [[10.0, 0.0], [10.0 + 20.0 * (i == 0), 2.0]],
                     "beta": [[170.0, 0.0], [170.0, 2.0]]} for i in range(7)}
    f = write(tmp_path / "seven.json", data)
    r = run("simulate", str(f), "--layout", "hex:7")
    assert r.returncode == 0, r.stderr
    sim = json.loads((tmp_path / "seven.sim.json").read_text())
    assert sim["contact_pairs"] == [] and sim["not_reached"] == []
    mp4 = tmp_path / "seven.mp4"
    r = run("render", str(f), "--layout", "hex:7", "--out", str(mp4), "--width", "160",
            "--height", "120", "--fps", "5")
    assert r.returncode == 0, r.stderr
    assert iio.imread(mp4).shape[1:] == (120, 160, 3)
    r = run("record", str(f), "--layout", "hex:7", "--out", str(tmp_path / "seven.rrd"))
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "seven.rrd").stat().st_size > 1000
    r = run("simulate", str(f), "--layout", "sdss-v-apo")
    assert r.returncode == 2 and "are not robots of sdss-v-apo" in r.stderr
