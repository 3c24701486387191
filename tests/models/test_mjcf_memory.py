"""Tests of rfp_twin.models.mjcf.memory: MuJoCo's arena is sized from the grid (not from
MuJoCo's O(dof^2) default, ~27 GB for 12,871 robots: the "Could not allocate memory"
compile failure), it holds what a colliding step uses, and grids MuJoCo's collision driver
cannot pair are refused with a message."""
from __future__ import annotations

import mujoco
import numpy as np
import pytest

from rfp_twin.models.errors import SpecError
from rfp_twin.models.layout import layout_by_name
from rfp_twin.models.mjcf import ModelOptions, build_model, build_spec, collect_mujoco_warnings
from rfp_twin.models.mjcf.blocks import quiet_attach
from rfp_twin.models.mjcf.memory import (CONTACT_BYTES, MAX_BODIES, arena_bytes, body_count,
                                         check_body_count)
from rfp_twin.models.robot import load_spec

GIB = 1 << 30


def test_the_arena_is_the_grid_s_own_and_grows_with_robots():
    sizes = [arena_bytes(n, 0, 4.0) for n in (7, 547, 2016, 12852)]
    assert sizes == sorted(sizes) and len(set(sizes)) == 4
    # the 12,871-robot SDSS-V grid of the issue: MuJoCo's default asked ~27 GB
    assert arena_bytes(12871, 0, 4.0) < 6 * GIB
    # contacts: linear, CONTACT_BYTES each
    more = arena_bytes(2016, 0, 5.0) - arena_bytes(2016, 0, 4.0)
    assert abs(more - 2016 * CONTACT_BYTES) <= 1 << 20


def test_compiled_model_uses_it_and_is_far_below_mujoco_s_default():
    spec = load_spec("sdss-v")
    lay = layout_by_name("hex:547", spec.pitch_mm)
    s = build_spec(spec, lay)
    ours = arena_bytes(lay.n_robots, 0, ModelOptions().contacts_per_robot)
    assert s.memory == ours
    with quiet_attach():
        m = s.compile()
    assert m.narena == ours
    s.memory = -1                                    # MuJoCo's own heuristic
    with quiet_attach():
        default = s.compile().narena
    assert default > 5 * ours                        # 115 MB against ~9 MB


def test_a_raft_grid_steps_through_collisions_within_its_arena():
    """756 robots at random angles (arms through their neighbours): the step's stack holds
    MuJoCo's body-pair buffer (the reason the arena grows with nbody^2) and every contact
    fits: no warning, no contact dropped."""
    spec = load_spec("raft-6p2")
    lay = layout_by_name("raft:12", spec.pitch_mm)
    twin = build_model(spec, lay)
    m = twin.model
    assert m.nbody == body_count(lay.n_robots, 0)
    rng = np.random.default_rng(4)
    d = twin.make_data(rng.uniform(0, 360, (lay.n_robots, 2)))
    with collect_mujoco_warnings() as messages:
        for _ in range(20):
            mujoco.mj_step(m, d)
    assert messages == []
    assert [int(w.number) for w in d.warning] == [0] * int(mujoco.mjtWarning.mjNWARNING)
    assert d.ncon > 0
    nb = m.nbody
    assert d.maxuse_stack >= 2 * nb * (nb - 1)       # 4-byte ids of nbody^2 / 2 pairs
    assert d.maxuse_arena <= m.narena


def test_too_many_bodies_for_mujoco_are_refused_before_building():
    spec = load_spec("raft-6p2")
    lay = layout_by_name("raft:476", spec.pitch_mm)      # 29,988 robots
    with pytest.raises(SpecError, match=r"29,988 robots and 0 obstacles make 89,965 MuJoCo bodies; "
                                        r"allowed: at most 46,341 bodies \(here 15,446 robots\)"):
        build_spec(spec, lay)
    check_body_count("ok", 15_446, 2)                    # 46,341 bodies: the most
    assert body_count(15_446, 2) == MAX_BODIES
    with pytest.raises(SpecError, match="15,447 robots and 0 obstacles make 46,342"):
        check_body_count("x", 15_447, 0)


@pytest.mark.parametrize("bad", [-1.0, 1e4, True, "4"])
def test_contacts_per_robot_is_checked(bad):
    with pytest.raises(SpecError, match="contacts_per_robot"):
        ModelOptions(contacts_per_robot=bad)
