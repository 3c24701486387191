"""Tests of models.layout: hex grids, the SDSS-V layout, CSV I/O and neighbour lists."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

from models.errors import LayoutError, UnknownRobotError
from models.layout import Layout

PITCH = 22.4
ROW_DY = PITCH * math.sqrt(3.0) / 2.0


def hex_distance(xy: np.ndarray, pitch: float) -> np.ndarray:
    """Lattice ring number of each position of a centred hex grid, (n,) int."""
    r = np.rint(xy[:, 1] / (pitch * math.sqrt(3.0) / 2.0))
    q = np.rint(xy[:, 0] / pitch - r / 2.0)
    return np.max(np.abs(np.stack([q, r, q + r])), axis=0).astype(int)


def write(tmp_path, text: str, name: str = "layout.csv"):
    path = tmp_path / name
    path.write_text(text)
    return path


# -- hex grids -------------------------------------------------------------------
@pytest.mark.parametrize("rings, count", [(3, 37), (5, 91), (7, 169), (13, 547), (31, 2977)])
def test_hex_grid_counts_and_pitch(rings, count):
    grid = Layout.hex_grid(rings, PITCH)
    assert len(grid.ids) == grid.n_robots == count
    assert grid.n_fiducials == 0
    assert grid.ids.tolist() == list(range(count))
    dist, _ = cKDTree(grid.xy).query(grid.xy, k=2)
    np.testing.assert_allclose(dist[:, 1], PITCH, rtol=1e-12)
    assert Layout.hex_grid_positions(count, PITCH).xy.shape == (count, 2)


def test_hex_grid_geometry():
    grid = Layout.hex_grid(3, 10.0)
    assert grid.xy.dtype == np.float64 and grid.ids.dtype == np.int64
    np.testing.assert_allclose(grid.xy.mean(axis=0), 0.0, atol=1e-12)
    assert np.any(np.all(grid.xy == 0.0, axis=1))                   # a position at the centre
    order = np.lexsort((grid.xy[:, 0], grid.xy[:, 1]))
    assert order.tolist() == list(range(37))                         # ids sorted by y then x
    centre_row = grid.xy[np.abs(grid.xy[:, 1]) < 1e-9, 0]
    np.testing.assert_allclose(np.diff(centre_row), 10.0)            # rows run along +x
    assert len(centre_row) == 7


def test_hex_grid_positions_rejects_non_hex_count():
    with pytest.raises(LayoutError, match=r"n_positions.*100.*91, 127"):
        Layout.hex_grid_positions(100, PITCH)


@pytest.mark.parametrize("rings, pitch", [(-1, PITCH), (2.5, PITCH), (3, 0.0), (3, math.nan)])
def test_hex_grid_rejects_bad_arguments(rings, pitch):
    with pytest.raises(LayoutError):
        Layout.hex_grid(rings, pitch)


def test_arrays_are_read_only():
    grid = Layout.hex_grid(1, PITCH)
    with pytest.raises(ValueError):
        grid.xy[0, 0] = 1.0


# -- neighbours --------------------------------------------------------------------
@pytest.mark.parametrize("reach, expected, depth", [(1.01 * PITCH, 6, 1), (48.8, 18, 2)])
def test_interior_robots_have_full_neighbourhoods(reach, expected, depth):
    rings = 7
    grid = Layout.hex_grid(rings, PITCH)
    ptr, idx = grid.neighbour_csr(reach)
    counts = np.diff(ptr)
    interior = hex_distance(grid.robot_xy, PITCH) <= rings - depth
    assert interior.sum() > 0
    assert (counts[interior] == expected).all()
    assert (counts[~interior] < expected).all()


def test_neighbour_pairs_and_csr_agree():
    grid = Layout.hex_grid(5, PITCH)
    pairs = grid.neighbour_pairs(48.8)
    assert pairs.dtype == np.int64 and pairs.shape[1] == 2
    assert (pairs[:, 0] < pairs[:, 1]).all()
    d = np.linalg.norm(grid.robot_xy[pairs[:, 0]] - grid.robot_xy[pairs[:, 1]], axis=1)
    assert (d <= 48.8).all()
    ptr, idx = grid.neighbour_csr(48.8)
    assert ptr.shape == (grid.n_robots + 1,) and ptr.dtype == idx.dtype == np.int64
    assert len(idx) == 2 * len(pairs)
    edges = {(i, int(j)) for i in range(grid.n_robots) for j in idx[ptr[i]:ptr[i + 1]]}
    expected = {(int(i), int(j)) for i, j in pairs} | {(int(j), int(i)) for i, j in pairs}
    assert edges == expected


def test_robot_fiducial_csr_uses_fiducial_indices():
    grid = Layout.sdss_v_grid(fiducial_ids=[273])                   # the centre position
    assert grid.n_robots == 546 and grid.n_fiducials == 1
    np.testing.assert_allclose(grid.fiducial_xy, [[0.0, 0.0]], atol=1e-12)
    ptr, idx = grid.robot_fiducial_csr(48.8)
    assert ptr.shape == (547,)
    assert np.diff(ptr).sum() == 18 and set(idx.tolist()) == {0}


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


# -- CSV ---------------------------------------------------------------------------
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


def test_validate_names_overlapping_ids():
    layout = Layout([4, 9], [[0.0, 0.0], [0.0, 0.2]], ["robot", "robot"], name="mem")
    with pytest.raises(LayoutError, match=r"mem: bases of ids 4 and 9 overlap \(0\.2000 mm"):
        layout.validate(1.0)


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
