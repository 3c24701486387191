"""Tests of rfp_twin.models.mjcf.blocks: a grid built in blocks and merged by attaches is the
same model as one built element by element, names, classes and order kept."""
from __future__ import annotations

import mujoco
import numpy as np
import pytest

import rfp_twin.models.mjcf.blocks as blocks
from rfp_twin.models.layout import Layout
from rfp_twin.models.mjcf import build_model, collect_mujoco_warnings, export_model
from rfp_twin.models.robot import load_spec
from tests.models.conftest import with_fiducials

#: Compiled arrays that must not depend on how the spec was assembled.
ARRAYS = ("body_parentid", "body_pos", "body_quat", "body_mass", "jnt_range", "jnt_qposadr",
          "geom_bodyid", "geom_type", "geom_dataid", "geom_group", "geom_contype",
          "geom_conaffinity", "geom_matid", "geom_pos", "site_pos", "actuator_trnid",
          "actuator_gainprm", "actuator_biasprm", "actuator_forcerange")


def _names(m: mujoco.MjModel, obj, count: int) -> list[str]:
    return [mujoco.mj_id2name(m, obj, i) for i in range(count)]


def test_blocks_give_the_same_model_as_one_spec(monkeypatch):
    spec = load_spec("sdss-v")
    lay = with_fiducials(3, spec.pitch_mm, [0, 5, 20])            # 34 robots, 3 fiducials
    monkeypatch.setattr(blocks, "BLOCK_ROBOTS", 4)               # 9 leaves, 4 merge levels
    merged = build_model(spec, lay).model
    monkeypatch.setattr(blocks, "BLOCK_ROBOTS", 10_000)          # everything in one spec
    single = build_model(spec, lay).model
    assert (merged.nbody, merged.ngeom, merged.nu, merged.nsite, merged.nmesh) == \
        (single.nbody, single.ngeom, single.nu, single.nsite, single.nmesh)
    for name in ARRAYS:
        assert np.array_equal(getattr(merged, name), getattr(single, name)), name
    obj = mujoco.mjtObj
    for kind, count in ((obj.mjOBJ_BODY, merged.nbody), (obj.mjOBJ_GEOM, merged.ngeom),
                        (obj.mjOBJ_ACTUATOR, merged.nu), (obj.mjOBJ_SITE, merged.nsite)):
        assert _names(merged, kind, count) == _names(single, kind, count)


def test_add_in_blocks_keeps_order_and_merges_pairwise(monkeypatch):
    monkeypatch.setattr(blocks, "BLOCK_ROBOTS", 3)
    grid = mujoco.MjSpec()
    seen = []

    def add(s, k):
        body = s.worldbody.add_body()
        body.name = f"b{k}"
        body.add_geom().size = [1.0, 0.0, 0.0]

    attaches = blocks.add_in_blocks(grid, 10, add, progress=seen.append)
    assert seen == [3, 6, 9, 10]                 # after each leaf
    assert attaches == 3                         # 4 leaves merged pairwise: 2 + 1
    with blocks.quiet_attach():
        m = grid.compile()
    assert _names(m, mujoco.mjtObj.mjOBJ_BODY, m.nbody) == ["world"] + [f"b{k}" for k in range(10)]


def test_only_the_empty_prefix_warning_is_dropped():
    passed = []
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(passed.append)
    try:
        with blocks.quiet_attach():
            grid = mujoco.MjSpec()
            leaf = mujoco.MjSpec()
            leaf.worldbody.add_body(name="b").add_geom(size=[1.0, 0.0, 0.0])
            grid.attach(leaf, frame=grid.worldbody.add_frame(), prefix="")
            grid.worldbody.first_body().add_freejoint()
            m = grid.compile()
            d = mujoco.MjData(m)
            d.qpos[0] = np.nan                       # MuJoCo warns: bad qpos
            mujoco.mj_step(m, d)
    finally:
        mujoco.set_mju_user_warning(previous)
    assert len(passed) == 1 and "QPOS" in passed[0]


def test_an_exported_block_built_grid_has_each_class_once_and_reloads(tmp_path):
    spec = load_spec("desi")
    lay = Layout.hex_grid(4, spec.pitch_mm)                       # 61 robots: 2 leaves
    assert lay.n_robots > blocks.BLOCK_ROBOTS
    path = export_model(spec, lay, tmp_path)
    text = path.read_text()
    assert text.count('<default class="visual">') == 1
    assert text.count('<default class="collision">') == 1
    with collect_mujoco_warnings() as messages:
        m = mujoco.MjModel.from_xml_path(str(path))
    assert messages == []
    assert m.nu == 2 * lay.n_robots and m.nmesh == build_model(spec, lay).model.nmesh


@pytest.mark.parametrize("n, size, expect", [(0, 4, []), (5, 4, [range(0, 4), range(4, 5)])])
def test_blocks_cover_the_range(n, size, expect):
    assert blocks.blocks(n, size) == expect
