"""Tests of rfp_twin.models.layout.core: the Layout type, its checks, id lookup and the SDSS-V layouts."""
from __future__ import annotations

import math

import numpy as np
import pytest

from rfp_twin.models.errors import LayoutError, UnknownRobotError
from rfp_twin.models.layout import Layout

PITCH = 22.4
ROW_DY = PITCH * math.sqrt(3.0) / 2.0


def test_arrays_are_read_only():
    grid = Layout.hex_grid(1, PITCH)
    with pytest.raises(ValueError):
        grid.xy[0, 0] = 1.0


def test_sdss_v_grid_unknown_fiducial_id():
    with pytest.raises(UnknownRobotError, match=r"600.*0\.\.546"):
        Layout.sdss_v_grid(fiducial_ids=[600])


# -- the real SDSS-V focal plane -------------------------------------------------
def test_sdss_v_fps_counts():
    fps = Layout.sdss_v_fps()
    assert fps.n_robots == 500
    # The reference file's header claims 46 intra-array fiducials but lists 42 (its 4
    # "Open" positions make up the difference); plus 18 outer-ring fiducials (6
    # "Fiducial" + 12 "GFA-Fiducial").
    outer = fps.extra["row"] == "-99"
    assert fps.n_fiducials == 60
    assert outer.sum() == 18 and (fps.kinds[outer] == "fiducial").all()
    assert fps.ids.tolist() == list(range(560))
    assignment = fps.extra["assignment"][fps.robot_mask]
    assert (assignment == "BA").sum() == 298 and (assignment == "BOSS").sum() == 202


def test_sdss_v_fps_sits_on_the_hex_lattice():
    fps = Layout.sdss_v_fps()
    intra = fps.xy[fps.extra["row"] != "-99"]
    r = np.rint(intra[:, 1] / ROW_DY)
    q = np.rint(intra[:, 0] / PITCH - r / 2.0)
    lattice = np.stack([(q + r / 2.0) * PITCH, r * ROW_DY], axis=1)
    assert np.abs(intra - lattice).max() < 0.01
    np.testing.assert_array_equal(r, fps.extra["row"][fps.extra["row"] != "-99"].astype(int))
    outer = fps.xy[fps.extra["row"] == "-99"]
    np.testing.assert_allclose(np.hypot(*outer.T), 324.0, atol=1e-3)


# -- robot ids ---------------------------------------------------------------------
def test_robot_index_round_trip():
    fps = Layout.sdss_v_fps()
    k = fps.robot_indices(fps.robot_ids[::-1])
    assert k.tolist() == list(range(fps.n_robots))[::-1]
    assert fps.robot_index(int(fps.robot_ids[7])) == 7


@pytest.mark.parametrize("bad, words", [(999, ["999", "0..541"]), (21, ["21", "fiducial"]),
                                        (-1, ["-1"])])
def test_robot_index_unknown(bad, words):
    fps = Layout.sdss_v_fps()
    with pytest.raises(UnknownRobotError) as info:
        fps.robot_index(bad)
    assert all(w in str(info.value) for w in words)
    with pytest.raises(UnknownRobotError):
        fps.robot_indices([0, bad])


def test_validate_names_overlapping_ids():
    layout = Layout([4, 9], [[0.0, 0.0], [0.0, 0.2]], ["robot", "robot"], name="mem")
    with pytest.raises(LayoutError, match=r"mem: bases of ids 4 and 9 overlap \(0\.2000 mm"):
        layout.validate(1.0)


@pytest.mark.parametrize("ids, xy, kinds, words", [
    ([1.5, 2], [[0, 0], [5, 5]], ["robot", "robot"], ["'id'", "1.5", "not an integer"]),
    ([1, 2], [[0, 0, 0], [5, 5, 5]], ["robot", "robot"], ["'xy'", "(n, 2)"]),
    ([1, 1], [[0, 0], [5, 5]], ["robot", "robot"], ["duplicate id", "1"]),
    ([1, 2], [[0, 0], [np.nan, 5]], ["robot", "robot"], ["id 2", "NaN"]),
    ([1, 2], [[0, 0], [5, 5]], ["robot", "rover"], ["id 2", "unknown kind", "'rover'"]),
    ([], [], [], ["empty layout"]),
])
def test_constructor_rejects_bad_arrays(ids, xy, kinds, words):
    with pytest.raises(LayoutError) as info:
        Layout(ids, xy, kinds, name="mem")
    assert all(w in str(info.value) for w in words), str(info.value)
