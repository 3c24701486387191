"""Target catalogues: the data type, CSV / Parquet reading and its one-line errors."""
from __future__ import annotations

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from rfp_twin.models.catalogue import (APOGEE, ANY, BOSS, SKY, SCIENCE, STANDARD, Catalogue,
                                       read_catalogue)
from rfp_twin.models.errors import CatalogueError
from rfp_twin.models.instrument import wok_to_plane


def write(tmp_path, text, name="cat.csv"):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_a_csv_with_defaults(tmp_path):
    p = write(tmp_path, "id,x_mm,y_mm\n5,1.5,-2\n7,10,20\n")
    cat = read_catalogue(p)
    assert cat.ids.tolist() == [5, 7]
    assert cat.xy.tolist() == [[1.5, -2.0], [10.0, 20.0]]
    assert cat.priority.tolist() == [1.0, 1.0]
    assert cat.kind.tolist() == [SCIENCE, SCIENCE] and cat.fiber.tolist() == [ANY, ANY]
    assert cat.source == str(p)


def test_a_csv_with_every_column(tmp_path):
    p = write(tmp_path, "id,x_mm,y_mm,priority,kind,fiber\n1,0,0,3.5,Sky,boss\n"
                        "2,1,1,0,standard,APOGEE\n3,2,2,,,\n")
    cat = read_catalogue(p)
    assert cat.priority.tolist() == [3.5, 0.0, 1.0]
    assert cat.kind.tolist() == [SKY, STANDARD, SCIENCE]
    assert cat.fiber.tolist() == [BOSS, APOGEE, ANY]
    assert cat.counts() == {"science": 1, "sky": 1, "standard": 1}


@pytest.mark.parametrize("body,words", [
    ("id,x_mm,y_mm\n1,0,0\n2,nan,0\n", ["cat.csv:3", "'x_mm'", "'nan'", "finite number"]),
    ("id,x_mm,y_mm\n1,0,0\n2,,0\n", ["cat.csv:3", "'x_mm'", "blank: missing"]),
    ("id,x_mm,y_mm\n1,0,0\n2,1,1\n1,2,2\n", ["cat.csv:4", "'id' = 1 repeats line 2",
                                              "unique ids"]),
    ("id,x_mm,y_mm,kind\n1,0,0,science\n2,1,1,galaxy\n",
     ["cat.csv:3", "'kind' = 'galaxy'", "science, sky, standard"]),
    ("id,x_mm,y_mm,fiber\n1,0,0,boss\n2,1,1,red\n",
     ["cat.csv:3", "'fiber' = 'red'", "boss, apogee, any"]),
    ("id,x_mm,y_mm,priority\n1,0,0,1\n2,1,1,-0.5\n",
     ["cat.csv:3", "'priority' = '-0.5'", ">= 0"]),
    ("id,x_mm,y_mm\n1.5,0,0\n", ["cat.csv:2", "'id' = '1.5'", "an integer"]),
    ("id,x,y\n1,0,0\n", ["columns", "x_mm,y_mm", "ra_deg,dec_deg"]),
    ("id,x_mm,y_mm\n", ["no target rows"]),
])
def test_bad_csv_rows_are_one_line_naming_file_row_field(tmp_path, body, words):
    with pytest.raises(CatalogueError) as exc:
        read_catalogue(write(tmp_path, body))
    msg = str(exc.value)
    assert "\n" not in msg
    for w in words:
        assert w in msg, msg


def test_a_missing_file(tmp_path):
    with pytest.raises(CatalogueError, match="not found"):
        read_catalogue(tmp_path / "none.csv")


def test_parquet_reads_like_csv_and_names_rows(tmp_path):
    p = tmp_path / "cat.parquet"
    pq.write_table(pa.table({"id": [1, 2, 3], "x_mm": [0.0, 1.0, 2.0], "y_mm": [0.0, 0.5, 1.0],
                             "kind": ["science", "sky", "standard"],
                             "priority": [2.0, 1.0, 1.0]}), p)
    cat = read_catalogue(p)
    assert cat.ids.tolist() == [1, 2, 3] and cat.kind.tolist() == [SCIENCE, SKY, STANDARD]
    assert cat.xy[1].tolist() == [1.0, 0.5]
    pq.write_table(pa.table({"id": [1, 2], "x_mm": [0.0, None], "y_mm": [0.0, 1.0]}), p)
    with pytest.raises(CatalogueError, match=r"cat.parquet: row 2: field 'x_mm' = None"):
        read_catalogue(p)


def test_wok_positions_are_turned_into_the_planning_frame(tmp_path):
    p = write(tmp_path, "id,x_wok_mm,y_wok_mm\n1,10,0\n2,3,4\n")
    cat = read_catalogue(p, wok_frame=True)
    assert np.allclose(cat.xy, wok_to_plane(np.array([[10.0, 0.0], [3.0, 4.0]])))
    assert np.allclose(cat.xy[0], [0.0, 10.0])           # wok +x is the plane's +y
    with pytest.raises(CatalogueError, match="without a wok frame"):
        read_catalogue(p)


def test_the_data_type_checks_programmatic_input():
    with pytest.raises(CatalogueError, match="repeats row 0"):
        Catalogue([4, 4], [[0, 0], [1, 1]], [1, 1], [0, 0], [0, 0])
    with pytest.raises(CatalogueError, match="priority"):
        Catalogue([1], [[0, 0]], [-1], [0], [0])
    with pytest.raises(CatalogueError, match="'kind' = 5"):
        Catalogue([1], [[0, 0]], [1], [5], [0])
    cat = Catalogue([1, 2, 3], [[0, 0], [1, 1], [2, 2]], [1, 2, 3], [0, 1, 2], [0, 1, 2])
    both = Catalogue.concat([cat.subset(np.array([True, False, True])),
                             Catalogue([9], [[5, 5]], [1], [0], [0])])
    assert both.ids.tolist() == [1, 3, 9] and both.priority.tolist() == [1, 3, 1]
    assert not cat.xy.flags.writeable
