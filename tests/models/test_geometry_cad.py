"""Tests of rfp_twin.models.geometry.cad: the user's own STL/OBJ link meshes and their convex pieces."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

from rfp_twin.models.errors import SpecError
from rfp_twin.models.geometry import load_cad_mesh, load_geometry, slab_pieces


def _beta_cad() -> trimesh.Trimesh:
    """A CAD-like beta arm: the bar plus a notch-free block, origin on the beta axis."""
    bar = trimesh.creation.box(extents=(17.0, 3.0, 2.0))
    bar.apply_translation([16.2 - 8.5, 0.0, 1.0])
    return bar


def _write_toml(tmp_path, meshes: dict, extra: str = "") -> str:
    text = "extends = \"sdss-v\"\n[geometry.meshes]\n" + "".join(
        f'{k} = "{v}"\n' for k, v in meshes.items()) + extra
    path = tmp_path / "robot.toml"
    path.write_text(text)
    return str(path)


def test_cad_beta_mesh_replaces_the_link(tmp_path):
    _beta_cad().export(tmp_path / "beta.stl")
    g = load_geometry(_write_toml(tmp_path, {"beta": "beta.stl"}))  # relative to the TOML
    beta = g.links["beta"]
    assert beta.source.endswith("beta.stl")
    assert beta.visual.bounds[1, 0] == pytest.approx(16.2)
    assert all(p.is_convex for p in beta.collision)
    assert g.beta_envelope_mm(0.0, 14.73) > 1.5                      # square corners stick out


def test_cad_concave_link_is_cut_into_convex_slabs():
    # an L-shaped plate: concave, but convex within each x slab
    a = trimesh.creation.box(extents=(10.0, 2.0, 1.0))
    a.apply_translation([5.0, 0.0, 0.5])
    b = trimesh.creation.box(extents=(2.0, 6.0, 1.0))
    b.apply_translation([9.0, 3.0, 0.5])
    shape = trimesh.boolean.union([a, b], engine="manifold")
    pieces = slab_pieces(shape, 5)
    assert len(pieces) == 5
    assert all(p.is_convex for p in pieces)
    assert sum(p.volume for p in pieces) == pytest.approx(shape.volume, rel=1e-6)
    assert shape.convex_hull.volume > 1.2 * shape.volume             # one hull would not do


def test_bad_cad_meshes_get_clear_errors(tmp_path):
    with pytest.raises(SpecError, match="file not found"):
        load_cad_mesh(tmp_path / "nope.stl", "meshes.beta", 17.0)
    (tmp_path / "arm.ply").write_text("ply\n")
    with pytest.raises(SpecError, match=r"allowed: \.stl, \.obj"):
        load_cad_mesh(tmp_path / "arm.ply", "meshes.beta", 17.0)
    open_box = _beta_cad()
    open_box.update_faces(np.arange(len(open_box.faces)) > 1)         # drop one side
    open_box.export(tmp_path / "open.stl")
    with pytest.raises(SpecError, match="not watertight"):
        load_cad_mesh(tmp_path / "open.stl", "meshes.beta", 17.0)
    metres = _beta_cad()
    metres.apply_scale(1e-3)
    metres.export(tmp_path / "metres.obj")
    with pytest.raises(SpecError, match="metres"):
        load_cad_mesh(tmp_path / "metres.obj", "meshes.beta", 17.0)
    off_axis = _beta_cad()
    off_axis.apply_translation([30.0, 0.0, 0.0])
    off_axis.export(tmp_path / "off.stl")
    with pytest.raises(SpecError, match="not on the joint axis"):
        load_cad_mesh(tmp_path / "off.stl", "meshes.beta", 17.0)
    (tmp_path / "junk.stl").write_bytes(b"\x00" * 10)
    with pytest.raises(SpecError, match="meshes.beta"):
        load_cad_mesh(tmp_path / "junk.stl", "meshes.beta", 17.0)


def test_missing_cad_file_in_a_toml_names_the_field(tmp_path):
    with pytest.raises(SpecError, match=r"meshes\.alpha.*file not found"):
        load_geometry(_write_toml(tmp_path, {"alpha": "missing.stl"}))


def test_given_collision_pieces_are_used(tmp_path):
    _beta_cad().export(tmp_path / "beta.stl")
    piece = trimesh.creation.box(extents=(16.0, 3.0, 2.0))
    piece.apply_translation([8.0, 0.0, 1.0])
    piece.export(tmp_path / "piece.stl")
    g = load_geometry(_write_toml(tmp_path, {"beta": "beta.stl"},
                                  '[geometry.collision]\nbeta = ["piece.stl"]\n'))
    assert len(g.links["beta"].collision) == 1
    assert g.links["beta"].collision[0].bounds[1, 0] == pytest.approx(16.0)


def test_collision_files_for_a_procedural_link(tmp_path):
    """Collision pieces given for a link that keeps its procedural visual mesh."""
    piece = trimesh.creation.box(extents=(16.0, 3.0, 2.0))
    piece.apply_translation([8.0, 0.0, 1.0])
    piece.export(tmp_path / "piece.stl")
    (tmp_path / "robot.toml").write_text(
        'extends = "sdss-v"\n[geometry.collision]\nbeta = ["piece.stl"]\n')
    g = load_geometry(str(tmp_path / "robot.toml"))
    beta = g.links["beta"]
    assert beta.source == "procedural" and beta.visual.bounds[1, 0] == pytest.approx(16.2)
    assert len(beta.collision) == 1 and beta.collision[0].bounds[1, 0] == pytest.approx(16.0)
