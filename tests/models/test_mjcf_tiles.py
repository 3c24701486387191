"""Tests of the tile split of a large array (models/mjcf/tiles.py) and of the tiled twin's
models (models/mjcf/tiled_twin.py): every robot owned once, halos that hold every robot
that can touch an owned one, and tile models whose robots and obstacles stand exactly where
they stand in the one-model twin (calibrated, curved-wok SDSS-V APO layout with walls)."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.errors import SpecError
from rfp_twin.models.geometry import geometry_for_spec
from rfp_twin.models.layout import layout_by_name
from rfp_twin.models.mjcf import build_model
from rfp_twin.models.mjcf.tiled_twin import HALO_SHIFT, build_tiled
from rfp_twin.models.mjcf.tiles import contact_reach_mm, plan_tiles, split_robots
from rfp_twin.models.robot import load_spec

SDSS = load_spec("sdss-v")


def test_split_covers_every_point_once_in_compact_patches_of_at_most_max():
    rng = np.random.default_rng(0)
    xy = rng.uniform(-100, 100, (1000, 2))
    parts = split_robots(xy, 130)
    allrows = np.concatenate(parts)
    assert sorted(allrows.tolist()) == list(range(1000))
    assert max(p.size for p in parts) <= 130
    assert len(parts) == 8                       # ceil(1000 / 130): no wasted patches
    # compact: a patch's extent is far below the whole square's
    assert max(np.ptp(xy[p], axis=0).max() for p in parts) < 110


@pytest.mark.parametrize("bad", [0, -3, 2.5, True])
def test_split_refuses_a_bad_tile_size(bad):
    with pytest.raises(SpecError, match="tile_robots"):
        split_robots(np.zeros((4, 2)), bad)


def test_contact_reach_matches_the_one_model_neighbours_on_a_curved_calibrated_wok():
    lay = layout_by_name("sdss-v-apo", SDSS.pitch_mm)
    twin = build_model(SDSS, lay)
    geo = twin.geometry
    # the model-derived value: longest beta body offset and the tilt of the body quaternions
    m, idx = twin.model, twin.index
    longest = float(m.body_pos[idx.beta_body, 0].max())
    reach = max(geo.beta_reach_mm() + max(0.0, longest - float(geo.link_offset("beta")[0])),
                geo.alpha_reach_mm())
    w = m.body_quat[idx.base_body]
    reach += float(np.max(2 * np.hypot(w[:, 1], w[:, 2]) * np.abs(w[:, 0]))) * geo.params.fiber_z_mm
    assert contact_reach_mm(lay, geo) == pytest.approx(reach, abs=1e-9)
    assert reach > geo.beta_reach_mm()          # the tilt and longer arms count


def test_halo_holds_every_cross_tile_neighbour_and_nothing_owned():
    lay = layout_by_name("sdss-v-apo", SDSS.pitch_mm)
    geo = geometry_for_spec(SDSS)
    plan = plan_tiles(lay, geo, SDSS, max_robots=60)
    assert plan.n_tiles >= 9                  # at least ceil(500 / 60); strips may need more
    owner = np.empty(lay.n_robots, dtype=np.int64)
    for t, rows in enumerate(plan.owned):
        owner[rows] = t
    pairs = lay.neighbour_pairs(2 * plan.reach_mm)
    for i, j in pairs:
        if owner[i] != owner[j]:
            assert j in plan.halo[owner[i]] and i in plan.halo[owner[j]]
    for t in range(plan.n_tiles):
        assert not np.isin(plan.halo[t], plan.owned[t]).any()
    # every obstacle a robot can reach is in that robot's tile
    near = lay.robot_fiducial_csr(plan.reach_mm)
    for r in range(lay.n_robots):
        for f in near[1][near[0][r]:near[0][r + 1]]:
            assert f in plan.obstacles[owner[r]]


def test_tile_models_put_every_robot_and_obstacle_where_the_one_model_does():
    lay = layout_by_name("sdss-v-apo", SDSS.pitch_mm)
    one = build_model(SDSS, lay)
    tiled = build_tiled(SDSS, lay, max_robots=120)
    angles = np.column_stack([np.linspace(10, 350, lay.n_robots), np.linspace(170, 20, lay.n_robots)])
    d_one = one.make_data(angles)
    seen = set()
    for tile in tiled.tiles:
        tw, local = tile.twin, tile.robots
        d = tw.make_data(angles[local])
        for name in ("base_body", "alpha_body", "beta_body"):
            a = getattr(tw.index, name)
            b = getattr(one.index, name)[local]
            assert d.xpos[a] == pytest.approx(d_one.xpos[b], abs=1e-9)
            assert d.xquat[a] == pytest.approx(d_one.xquat[b], abs=1e-12)
        jr_t = tw.model.jnt_range[tw.index.alpha_joint]
        assert jr_t == pytest.approx(one.model.jnt_range[one.index.alpha_joint[local]])
        fid_rows = {int(f): k for k, f in enumerate(one.index.fiducial_ids)}
        for k, fid in enumerate(tw.index.fiducial_ids):
            assert d.xpos[tw.index.fiducial_body[k]] == pytest.approx(
                d_one.xpos[one.index.fiducial_body[fid_rows[int(fid)]]], abs=1e-9)
        seen.update(local[tile.owned].tolist())
        # tiles only simulate: no robot visual meshes, every collision piece
        assert not any(tw.index.robot_geoms(i, collision=False).size for i in range(local.size))
        assert sum(tw.index.robot_geoms(i, collision=True).size for i in range(local.size)) == \
            sum(one.index.robot_geoms(int(r), collision=True).size for r in local)
    assert seen == set(range(lay.n_robots))
    assert tiled.options.robot_visuals          # what renderers build from keeps them


def test_halo_geoms_meet_owned_geoms_only():
    lay = layout_by_name("sdss-v-apo", SDSS.pitch_mm)
    tiled = build_tiled(SDSS, lay, max_robots=120)
    tile = tiled.tiles[0]
    m, idx = tile.twin.model, tile.twin.index
    col = idx.geom_collision & ((m.geom_contype | m.geom_conaffinity) > 0)
    robot = idx.geom_robot
    halo_g = np.flatnonzero(col & (robot >= 0) & ~tile.owned[np.maximum(robot, 0)])
    own_g = np.flatnonzero(col & (robot >= 0) & tile.owned[np.maximum(robot, 0)])
    obst_g = np.flatnonzero(col & (idx.geom_fiducial >= 0))
    assert halo_g.size and own_g.size and obst_g.size

    def collide(g1, g2):
        return bool((m.geom_contype[g1] & m.geom_conaffinity[g2])
                    | (m.geom_contype[g2] & m.geom_conaffinity[g1]))

    assert all(m.geom_contype[g] >= 1 << HALO_SHIFT for g in halo_g)
    assert not any(collide(a, b) for a in halo_g[:20] for b in halo_g[-20:])
    assert not any(collide(a, b) for a in halo_g[:20] for b in obst_g)
    # a halo beta meets an owned beta, as two betas do in the one model
    beta_h = [g for g in halo_g if m.geom_bodyid[g] in idx.beta_body]
    beta_o = [g for g in own_g if m.geom_bodyid[g] in idx.beta_body]
    assert collide(beta_h[0], beta_o[0])
    # body-level bits follow the geoms
    for g in (beta_h[0], beta_o[0]):
        b = m.geom_bodyid[g]
        assert m.body_contype[b] & m.geom_contype[g] == m.geom_contype[g]


def test_strips_cover_every_point_once_in_patches_of_at_most_max():
    rng = np.random.default_rng(2)
    xy = rng.uniform(-300, 300, (3000, 2))
    parts = split_robots(xy, 130, strip_mm=60.0)
    assert np.array_equal(np.sort(np.concatenate(parts)), np.arange(3000))
    assert max(p.size for p in parts) <= 130
    for p in parts:                                   # each patch inside one 60 mm strip
        k = np.floor((xy[p, 0] - xy[:, 0].min()) / 60.0)
        assert np.all(k == k[0])
    assert len(split_robots(xy[:100], 130, strip_mm=60.0)) == 1   # few points: one patch
    with pytest.raises(SpecError, match="strip_mm"):
        split_robots(xy, 130, strip_mm=0.0)
