"""Tests of rfp_twin.models.layout.csv_io: layout CSV files, read and written."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.errors import LayoutError
from rfp_twin.models.layout import Layout

PITCH = 22.4


def write(tmp_path, text: str, name: str = "layout.csv"):
    path = tmp_path / name
    path.write_text(text)
    return path


@pytest.mark.parametrize("layout", [Layout.sdss_v_fps(), Layout.hex_grid(4, PITCH),
                                    Layout.sdss_v_grid(fiducial_ids=[0, 10])])
def test_csv_round_trip(tmp_path, layout):
    path = tmp_path / "out.csv"
    layout.to_csv(path)
    back = Layout.from_csv(path)
    np.testing.assert_array_equal(back.ids, layout.ids)
    np.testing.assert_array_equal(back.xy, layout.xy)                # bit-identical
    assert back.kinds.tolist() == layout.kinds.tolist()
    assert list(back.extra) == list(layout.extra)
    for key in layout.extra:
        assert back.extra[key].tolist() == layout.extra[key].tolist()
    assert back.name == "out"


BAD_CSV = {
    "duplicate id": ("id,x_mm,y_mm,kind\n0,0,0,robot\n1,30,0,robot\n0,60,0,robot\n",
                     ["layout.csv:4", "duplicate id", "'id'", "line 2"]),
    "non-integer id": ("id,x_mm,y_mm,kind\nabc,0,0,robot\n",
                       ["layout.csv:2", "'id'", "not an integer"]),
    "nan": ("id,x_mm,y_mm,kind\n0,0,0,robot\n1,nan,0,robot\n",
            ["layout.csv:3", "'x_mm'", "NaN"]),
    "inf": ("id,x_mm,y_mm,kind\n0,0,inf,robot\n", ["layout.csv:2", "'y_mm'", "finite"]),
    "unparseable": ("id,x_mm,y_mm,kind\n0,1.2.3,0,robot\n", ["layout.csv:2", "'x_mm'"]),
    "overlapping": ("id,x_mm,y_mm,kind\n5,0,0,robot\n7,0.5,0,fiducial\n",
                    ["layout.csv:2,3", "overlap", "5", "7", "0.5000 mm", "1.0 mm"]),
    "unknown kind": ("id,x_mm,y_mm,kind\n0,0,0,robut\n",
                     ["layout.csv:2", "unknown kind", "'robut'", "robot, fiducial"]),
    "missing column": ("id,x_mm,y_mm\n0,0,0\n", ["layout.csv:1", "missing column", "kind"]),
    "empty": ("id,x_mm,y_mm,kind\n", ["layout.csv", "empty layout"]),
    "short row": ("id,x_mm,y_mm,kind\n0,0,0\n", ["layout.csv:2", "number of fields"]),
}


@pytest.mark.parametrize("case", sorted(BAD_CSV))
def test_bad_csv_is_rejected(tmp_path, case):
    text, words = BAD_CSV[case]
    with pytest.raises(LayoutError) as info:
        Layout.from_csv(write(tmp_path, text))
    message = str(info.value)
    assert "\n" not in message
    for word in words:
        assert word in message, f"{word!r} not in {message!r}"


def test_missing_file(tmp_path):
    with pytest.raises(LayoutError, match="nope.csv: file not found"):
        Layout.from_csv(tmp_path / "nope.csv")


def test_min_separation_is_configurable(tmp_path):
    path = write(tmp_path, "id,x_mm,y_mm,kind\n0,0,0,robot\n1,0.5,0,robot\n")
    assert Layout.from_csv(path, min_separation_mm=0.1).n_robots == 2


def test_extra_columns_and_whitespace(tmp_path):
    path = write(tmp_path, "id, x_mm, y_mm, kind, note\n3, 1.5, -2, fiducial, hello\n")
    layout = Layout.from_csv(path)
    assert layout.fiducial_ids.tolist() == [3] and layout.extra["note"].tolist() == ["hello"]
    np.testing.assert_array_equal(layout.fiducial_xy, [[1.5, -2.0]])


def test_failed_to_csv_leaves_no_partial_file(tmp_path, monkeypatch):
    target = tmp_path / "out.csv"
    target.write_text("old contents\n")
    grid = Layout.hex_grid(3, PITCH)
    original = Layout._csv_row

    def failing_row(self, k):
        if k == 10:
            raise RuntimeError("disk full")
        return original(self, k)

    monkeypatch.setattr(Layout, "_csv_row", failing_row)
    with pytest.raises(RuntimeError, match="disk full"):
        grid.to_csv(target)
    assert target.read_text() == "old contents\n"
    assert [p.name for p in tmp_path.iterdir()] == ["out.csv"]


def test_to_csv_into_missing_directory(tmp_path):
    target = tmp_path / "no-such-dir" / "out.csv"
    with pytest.raises(LayoutError, match="out.csv: cannot write"):
        Layout.hex_grid(1, PITCH).to_csv(target)
    assert not target.exists()
