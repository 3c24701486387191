"""A calibrated instrument as a planning layout: plane frame, per-robot columns, obstacles."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.instrument import (calibration_folder, instrument_layout, plane_to_wok,
                                        read_calibration, wok_to_plane)
from rfp_twin.models.layout import Layout, layout_by_name
from rfp_twin.models.layout.columns import robot_fibers
from rfp_twin.models.errors import LayoutError
from rfp_twin.models.robot import load_spec


def test_plane_frame_turns_the_hole_axes_onto_x_and_y():
    # a flat-wok hole: i = (0, -1), j = (1, 0) in the wok frame
    np.testing.assert_allclose(wok_to_plane([0.0, -1.0]), [1.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(wok_to_plane([1.0, 0.0]), [0.0, 1.0], atol=1e-15)
    xy = np.array([[12.5, -3.0], [0.0, 7.0]])
    np.testing.assert_allclose(plane_to_wok(wok_to_plane(xy)), xy)


def test_apo_layout_carries_each_robots_calibration():
    cal = read_calibration(calibration_folder("sdss-v-apo"))
    lay = layout_by_name("sdss-v-apo", 22.4)
    assert (lay.n_robots, lay.n_fiducials) == (500, 66)            # 60 fiducials + 6 GFAs
    np.testing.assert_array_equal(lay.robot_ids, cal.robot_ids)
    np.testing.assert_allclose(plane_to_wok(lay.robot_xy), cal.base_xyz[:, :2], atol=1e-12)
    geom = ArrayGeometry(load_spec("sdss-v-production"), lay, 2.0)
    assert not geom.uniform
    np.testing.assert_array_equal(geom.alpha_len, cal.alpha_len)
    # the segment runs from the beta axis (production's start) and its far end follows
    # the measured fiber head when it sits out: production's end + max(metX - 14.314, 0)
    np.testing.assert_array_equal(geom.seg_start, 0.0)
    end = load_spec("sdss-v-production").segment_end(2.0)
    np.testing.assert_allclose(geom.seg_end, end + np.maximum(cal.fibers[:, 0, 0] - 14.314, 0.0),
                               atol=1e-12)
    fibers = robot_fibers(lay, {})
    np.testing.assert_array_equal(fibers, cal.fibers, strict=False)
    # production obstacles: 60 fiducial points and 6 GFA segments, 3 mm keep-out each
    assert np.all(geom.fid_buffer == 3.0)
    is_gfa = lay.kinds[~lay.robot_mask] == "gfa"
    assert is_gfa.sum() == 6
    length = np.hypot(*(geom.fid_end_xy - geom.fid_xy)[is_gfa].T)
    np.testing.assert_allclose(length, 113.08, atol=0.01)
    assert np.all(geom.fid_end_xy[~is_gfa] == geom.fid_xy[~is_gfa])
    # the outer robots see a guide camera
    gfa_index = np.flatnonzero(is_gfa)
    assert np.isin(geom.robot_fid_pairs[:, 1], gfa_index).sum() >= 6


def test_lco_and_curved_instruments():
    lco = layout_by_name("sdss-v-lco", 22.4)
    curved = layout_by_name("sdss-v-curved", 22.4)
    z = np.array(curved.extra["z_mm"][:curved.n_robots], dtype=float)
    kz = np.array(curved.extra["kz"][:curved.n_robots], dtype=float)
    assert 3.0 < z.max() < 7.0 and np.degrees(np.arccos(kz.min())) > 1.5
    assert not np.array_equal(lco.robot_xy, layout_by_name("sdss-v-apo", 22.4).robot_xy)


def test_a_calibration_folder_path_is_a_layout(tmp_path):
    lay = layout_by_name(str(calibration_folder("sdss-v-lco")), 22.4)
    assert lay.n_robots == 500 and lay.name == "lco-duPontFlatCMM"


def test_layout_csv_round_trip_keeps_the_calibration(tmp_path):
    lay = instrument_layout("sdss-v-apo")
    lay.to_csv(tmp_path / "apo.csv")
    back = Layout.from_csv(tmp_path / "apo.csv")
    spec = load_spec("sdss-v-production")
    a, b = ArrayGeometry(spec, lay, 2.0), ArrayGeometry(spec, back, 2.0)
    for name in ("alpha_len", "seg_start", "seg_end", "buffer", "fid_end_xy", "fid_buffer"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))


def test_fiducial_watch_marks_the_robot_above_each_fiducial():
    lay = instrument_layout("sdss-v-apo")
    watch = np.array(lay.extra["fiducial_watch"][:lay.n_robots], dtype=int)
    holes = list(lay.extra["hole_id"][:lay.n_robots])
    # fiducial R+12C8 -> the hole one row above, one column left: R+13C7
    assert watch[holes.index("R+13C7")] == 1
    # a fiducial on row 0 watches row +1, whose columns are numbered one further left
    # (kaiju 1.4.1 marks R+1C23 for fiducial R0C24, and 42 robots at APO)
    assert watch[holes.index("R+1C23")] == 1 and watch[holes.index("R+1C24")] == 0
    assert watch.sum() == 42


def test_a_per_robot_buffer_column_enlarges_that_robot_only():
    lay = Layout.hex_grid_positions(7, 22.4)
    extra = {"buffer_add_mm": ["", "0.5", "", "", "", "", ""]}
    wide = Layout(lay.ids, lay.xy, lay.kinds, name="wide", extra=extra)
    geom = ArrayGeometry(load_spec("sdss-v"), wide, 2.0)
    np.testing.assert_array_equal(geom.buffer, [2.0, 2.5, 2.0, 2.0, 2.0, 2.0, 2.0])
    bad = Layout(lay.ids, lay.xy, lay.kinds, name="bad", extra={"buffer_add_mm": ["", "x"] + [""] * 5})
    with pytest.raises(LayoutError, match=r"bad: id 1 field 'buffer_add_mm' = 'x'"):
        ArrayGeometry(load_spec("sdss-v"), bad, 2.0).buffer


def test_curved_wok_robots_sit_where_their_tilted_axes_meet_the_focal_surface():
    from rfp_twin.models.instrument.layout import FOCAL_HEIGHT_MM

    cal = read_calibration(calibration_folder("sdss-v-curved"))
    lay = layout_by_name("sdss-v-curved", 22.4)
    k = int(np.argmin(cal.frames[:, 2, 2]))                 # the most tilted robot
    head = cal.base_xyz[k] + FOCAL_HEIGHT_MM * cal.frames[k, 2]
    np.testing.assert_allclose(plane_to_wok(lay.robot_xy[k]), head[:2], atol=1e-9)
    # 2 deg of tilt over 143 mm: the head is ~5 mm from its hole's x, y
    assert 4.0 < np.hypot(*(head[:2] - cal.hole_xyz[k, :2])) < 6.0
    # the planar model adds the projection's shortening to that robot's buffer only
    geom = ArrayGeometry(load_spec("sdss-v-production"), lay, 2.0)
    tilt = 1.0 - cal.frames[:, 2, 2]
    np.testing.assert_allclose(geom.buffer - 2.0, (geom.alpha_len + geom.seg_end) * tilt,
                               atol=1e-12)
    assert 0.005 < geom.buffer[k] - 2.0 < 0.02
    flat = ArrayGeometry(load_spec("sdss-v-production"), layout_by_name("sdss-v-apo", 22.4), 2.0)
    assert np.all(flat.buffer == 2.0)
