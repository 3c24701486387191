"""Tests of rfp_twin.models.geometry.params: the [geometry] table, parsed and checked."""
from __future__ import annotations

from pathlib import Path

import pytest

from rfp_twin.models.errors import SpecError
from rfp_twin.models.geometry import build_geometry, params_from_tables
from rfp_twin.models.robot import load_spec


def test_bad_geometry_values_name_the_field():
    spec = load_spec("sdss-v")
    cases = [({"beta_half_width_mm": -1.0}, "beta_half_width_mm"),
             ({"beta_tip_half_width_mm": 2.0}, "beta_tip_half_width_mm"),
             ({"beta_z_mm": 1.0}, "beta_z_mm"),
             ({"ferrule_drop_mm": 3.0}, "ferrule_drop_mm"),
             ({"ferrule_x_mm": 16.0}, "ferrule_radius_mm"),
             ({"bogus_mm": 1.0}, "unknown field"),
             ({"circle_sections": 2}, "circle_sections"),
             ({"fibers": [{"name": "a", "x": 1.0}]}, "fibers"),
             ({"fibers": [{"name": "a", "x": 30.0, "y": 0.0}]}, "fibers.a"),
             ({"meshes": {"gamma": "x.stl"}}, "allowed links")]
    for table, message in cases:
        with pytest.raises(SpecError, match=message):
            build_geometry(spec, params_from_tables({"geometry": table}, spec, "t.toml"))


def test_table_values_and_relative_mesh_paths(tmp_path):
    spec = load_spec("sdss-v")
    table = {"beta_height_mm": 3, "circle_sections": 16,
             "fibers": [{"name": "only", "x": 14.5, "y": 0.0}],
             "meshes": {"beta": "arm.stl"}, "collision": {"alpha": ["a0.stl", "/abs/a1.stl"]}}
    p = params_from_tables({"geometry": table}, spec, "t.toml", base_dir=tmp_path)
    assert p.beta_height_mm == 3.0 and isinstance(p.beta_height_mm, float)
    assert p.circle_sections == 16 and p.fibers == (("only", 14.5, 0.0),)
    assert p.meshes == {"beta": str(tmp_path / "arm.stl")}
    assert p.collision == {"alpha": (str(tmp_path / "a0.stl"), "/abs/a1.stl")}
    assert p.source == "t.toml" and Path(p.meshes["beta"]).is_absolute()


@pytest.mark.parametrize("table, message", [
    ("not a table", "not a table"),
    ({"beta_tip_mm": True}, "beta_tip_mm"),
    ({"beta_tip_mm": float("nan")}, "finite"),
    ({"collision_slabs": 2000}, "collision_slabs"),
    ({"fibers": [{"name": "a", "x": 14.5, "y": 0.0}, {"name": "a", "x": 14.6, "y": 0.0}]},
     "duplicate names"),
    ({"meshes": {"beta": 3}}, "a path"),
    ({"collision": {"beta": "one.stl"}}, "a list of paths"),
])
def test_bad_table_entries_name_the_field(table, message):
    spec = load_spec("sdss-v")
    with pytest.raises(SpecError, match=message):
        params_from_tables({"geometry": table}, spec, "t.toml")
