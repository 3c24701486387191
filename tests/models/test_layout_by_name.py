"""Tests of rfp_twin.models.layout.by_name: a layout from the name the command line gives."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.errors import LayoutError, UnknownRobotError
from rfp_twin.models.layout import Layout, layout_by_name


def test_the_real_focal_plane():
    fps = layout_by_name("sdss-v-fps", 22.4)
    assert (fps.name, fps.n_robots, fps.n_fiducials) == ("sdss-v-fps", 500, 60)


def test_the_paper_grid_with_pitch_and_fiducials():
    grid = layout_by_name("sdss-v-547", 20.0, (0, 273))
    assert (grid.n_robots, grid.n_fiducials) == (545, 2)
    assert grid.fiducial_ids.tolist() == [0, 273]
    np.testing.assert_array_equal(grid.xy, Layout.hex_grid(13, 20.0).xy)


def test_hex_grids_by_position_count():
    grid = layout_by_name("hex:37", 22.4)
    assert (grid.name, grid.n_robots, grid.n_fiducials) == ("hex-37", 37, 0)
    with_fid = layout_by_name("hex:37", 22.4, (0, 18))
    assert with_fid.fiducial_ids.tolist() == [0, 18] and with_fid.n_robots == 35
    np.testing.assert_array_equal(with_fid.xy, grid.xy)


@pytest.mark.parametrize("name, fiducials, error, words", [
    ("hex:x", (), LayoutError, ["'hex:x'", "'hex:N' needs an integer N"]),
    ("hex:40", (), LayoutError, ["n_positions", "40", "37, 61"]),
    ("hex:7", (99,), UnknownRobotError, ["99", "0..6"]),
    ("sdss-v-fps", (3,), LayoutError, ["--fiducials applies to generated grids", "'sdss-v-fps'"]),
    ("grid.csv", (3,), LayoutError, ["--fiducials", "a CSV layout says each position's kind"]),
    ("sdss-v", (), LayoutError, ["'sdss-v'", "allowed: sdss-v-fps, sdss-v-apo, sdss-v-lco, sdss-v-curved, sdss-v-547, hex:N, a CSV"]),
    ("missing.csv", (), LayoutError, ["missing.csv: file not found"]),
])
def test_bad_names_get_one_line_errors(name, fiducials, error, words):
    with pytest.raises(error) as info:
        layout_by_name(name, 22.4, fiducials)
    message = str(info.value)
    assert "\n" not in message and all(w in message for w in words), message


def test_a_csv_path_is_read_with_a_pitch_dependent_minimum_separation(tmp_path):
    path = tmp_path / "close.csv"
    path.write_text("id,x_mm,y_mm,kind\n1,0,0,robot\n2,0.5,0,robot\n")
    with pytest.raises(LayoutError, match=r"overlap.*>= 1.0 mm"):
        layout_by_name(str(path), 22.4)                            # min(1, 22.4 / 4) = 1 mm
    lay = layout_by_name(str(path), 1.6)                           # 0.4 mm
    assert (lay.name, lay.robot_ids.tolist()) == ("close", [1, 2])


@pytest.mark.parametrize("name", ["raft:100000000", "raft:R=100000", "hex:100000003"])
def test_an_array_too_large_for_memory_is_one_line_naming_size_and_limit(name):
    with pytest.raises(LayoutError, match=r"positions; allowed: at most 500,000 \(memory"):
        layout_by_name(name, 6.2)
