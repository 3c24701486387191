"""The calibration folders of the real SDSS-V instruments: read, checked, bad input named."""
from __future__ import annotations

import csv
import shutil

import numpy as np
import pytest

from rfp_twin.models.instrument import (INSTRUMENTS, CalibrationError, calibration_folder,
                                        read_calibration)


def rows(path):
    with path.open(newline="") as fh:
        return list(csv.DictReader(fh))


@pytest.mark.parametrize("name", sorted(INSTRUMENTS))
def test_each_packaged_instrument_reads_whole(name):
    cal = read_calibration(calibration_folder(name))
    assert cal.n_robots == 500 and cal.fiducial_xyz.shape == (60, 3)
    assert cal.gfa_segments.shape == (6, 2, 2)
    # the values are the file's, row by row (positioner-table order)
    table = rows(calibration_folder(name) / "positionerTable.csv")
    assert [int(r["positionerID"]) for r in table] == cal.robot_ids.tolist()
    np.testing.assert_array_equal(cal.alpha_len, [float(r["alphaArmLen"]) for r in table])
    np.testing.assert_array_equal(cal.fibers[:, 0, 0], [float(r["metX"]) for r in table])
    # APOGEE fibers only on ApogeeBoss holes
    assert np.all(np.isnan(cal.fibers[:, 2, 0]) == (cal.robot_hole_types == "Boss"))
    assert cal.curved == (name == "sdss-v-curved")


def test_base_is_hole_plus_offset_in_the_hole_frame():
    folder = calibration_folder("sdss-v-apo")
    cal = read_calibration(folder)
    wok = {r["holeID"]: r for r in rows(folder / "wokCoords.csv")}
    r = rows(folder / "positionerTable.csv")[7]
    h = wok[r["holeID"]]
    i = np.array([float(h[c]) for c in ("ix", "iy", "iz")])
    j = np.array([float(h[c]) for c in ("jx", "jy", "jz")])
    hole = np.array([float(h[c]) for c in ("xWok", "yWok", "zWok")])
    expected = hole + float(r["dx"]) * i + float(r["dy"]) * j
    np.testing.assert_allclose(cal.base_xyz[7], expected, atol=1e-12)
    # APO's offsets reach 0.5 mm: the base really moves
    assert np.abs(cal.base_offset).max() > 0.4


@pytest.fixture
def folder(tmp_path):
    dst = tmp_path / "cal"
    shutil.copytree(calibration_folder("sdss-v-apo"), dst)
    for p in dst.iterdir():
        p.chmod(0o644)
    return dst


def edit(path, row, field, value):
    data = rows(path)
    with path.open(newline="") as fh:
        header = next(csv.reader(fh))
    data[row][field] = value
    with path.open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=header)
        w.writeheader()
        w.writerows(data)


@pytest.mark.parametrize("file, row, field, value, words", [
    ("positionerTable.csv", 3, "holeID", "R+99C1",
     ["positionerTable.csv:5", "'holeID'", "R+99C1", "not in wokCoords.csv"]),
    ("positionerTable.csv", 4, "positionerID", None,
     ["positionerTable.csv:6", "'positionerID'", "repeats line 2", "unique"]),
    ("positionerTable.csv", 2, "alphaArmLen", "nan",
     ["positionerTable.csv:4", "'alphaArmLen'", "'nan'", "finite number"]),
    ("wokCoords.csv", 5, "ix", "0.5",
     ["wokCoords.csv:7", "'ix, iy, iz'", "unit vector"]),
    ("wokCoords.csv", 6, "jx", None, None),
    ("wokCoords.csv", 8, "holeID", None, ["wokCoords.csv:10", "'holeID'", "repeats line 2"]),
    ("fiberAssignments.csv", 10, "positionerID", "99999",
     ["fiberAssignments.csv:12", "'positionerID'", "'99999'", "not in positionerTable.csv"]),
    ("fiducialCoords.csv", 1, "holeID", "R+0C99", ["fiducialCoords.csv:3", "not in wokCoords"]),
])
def test_bad_folder_names_file_row_and_field(folder, file, row, field, value, words):
    path = folder / file
    if value is None and field != "jx":
        value = rows(path)[0][field]               # a repeat of the first row's id
    if field == "jx":
        # i turned 45 deg towards j: still unit, no longer orthogonal to j
        edit(path, row, "ix", "0.7071067811865476")
        edit(path, row, "iy", "-0.7071067811865476")
        words = ["wokCoords.csv:8", "'i, j'", "orthogonal"]
    else:
        edit(path, row, field, value)
    with pytest.raises(CalibrationError) as info:
        read_calibration(folder)
    msg = str(info.value)
    assert "\n" not in msg and all(w in msg for w in words), msg


def test_a_missing_file_or_column_is_named(folder):
    (folder / "fiducialCoords.csv").unlink()
    with pytest.raises(CalibrationError, match="fiducialCoords.csv: file not found"):
        read_calibration(folder)
    text = (folder / "positionerTable.csv").read_text().replace("alphaArmLen", "alphaLength")
    (folder / "positionerTable.csv").write_text(text)
    with pytest.raises(CalibrationError, match=r"positionerTable.csv:1: field 'alphaArmLen' is missing"):
        read_calibration(folder)


@pytest.mark.parametrize("field, value, allowed", [
    ("alphaArmLen", "70", "[6.9, 7.9] mm (design 7.4 mm +- 0.5 mm)"),
    ("metX", "4.3", "[13.3, 15.8] mm"),
    ("bossY", "-2.5", "[-1, 1] mm"),
    ("apX", "16.3", "[13.9, 16] mm"),
    ("dx", "3", "[-1, 1] mm"),
    ("dy", "-1.2", "[-1, 1] mm"),
])
def test_a_robot_outside_its_physical_range_is_named(folder, field, value, allowed):
    """A 70 mm alpha arm (or a fiber off the beta arm, an axis 3 mm off its hole) is no
    SDSS-V robot: one line naming file, line, robot, field and the range."""
    path = folder / "positionerTable.csv"
    robot = rows(path)[5]["positionerID"]
    edit(path, 5, field, value)
    with pytest.raises(CalibrationError) as info:
        read_calibration(folder)
    msg = str(info.value)
    assert msg.startswith(f"{path}:7: robot {robot}: field '{field}' = {float(value):g} mm; "
                          f"allowed: {allowed}"), msg
    assert "\n" not in msg


def test_the_physical_ranges_hold_every_measured_robot():
    from rfp_twin.models.instrument.calibration import PHYSICAL_RANGES_MM

    for name in sorted(INSTRUMENTS):
        table = rows(calibration_folder(name) / "positionerTable.csv")
        for field, (lo, hi, _) in PHYSICAL_RANGES_MM.items():
            values = np.array([float(r[field]) for r in table])
            # every measured value inside, at least 0.2 mm from either end
            assert lo + 0.2 <= values.min() and values.max() <= hi - 0.2, (name, field)
