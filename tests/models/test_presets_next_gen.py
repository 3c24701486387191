"""The next-generation presets (pfs-cobra, raft-6p2) and the arm ratio helper."""
from __future__ import annotations

import math
import re
from importlib import resources

import numpy as np
import pytest

from rfp_twin.models.arm_ratio import arm_lengths, with_arm_ratio
from rfp_twin.models.errors import SpecError
from rfp_twin.models.geometry import load_geometry
from rfp_twin.models.robot import load_spec, load_tables
from rfp_twin.twin.pipeline import Reconfiguration
from rfp_twin.validation.checker2d import check_trajectory


def test_pfs_cobra_numbers():
    s = load_spec("pfs-cobra")
    assert (s.alpha_length_mm, s.beta_length_mm, s.pitch_mm) == (2.375, 2.375, 8.0)
    assert (s.buffer_mm, s.segment_start_mm, s.segment_end()) == (1.0, 0.0, 2.375)
    assert s.patrol_annulus_mm == (0.0, 4.75)


def test_raft_6p2_numbers():
    s = load_spec("raft-6p2")
    assert (s.alpha_length_mm, s.beta_length_mm, s.pitch_mm) == (1.8, 1.8, 6.2)
    assert s.reach_mm == pytest.approx(3.6)
    assert s.collision_reach_mm() == pytest.approx(4.4)      # largest mechanical radius


@pytest.mark.parametrize("name", ["pfs-cobra", "raft-6p2"])
def test_3d_robot_fits_the_2d_model_and_the_pitch(name):
    spec, geom = load_spec(name), load_geometry(name)
    assert geom.beta_envelope_mm(spec.segment_start_mm, spec.segment_end()) <= spec.buffer_mm + 1e-9
    assert not geom.alpha_arms_can_touch()
    assert geom.params.body_radius_mm < spec.pitch_mm / 2
    assert geom.params.fibers[0][1] == pytest.approx(spec.beta_length_mm)


#: Keys whose values are facts (or our planning conventions), per preset: every other
#: number in the file must say "estimate" on its line.
FACTS = {"pfs-cobra": {"alpha_length_mm", "beta_length_mm", "pitch_mm", "beta_limits_deg",
                       "buffer_mm", "segment_start_mm", "segment_end_mm",
                       "beta_half_width_mm", "ferrule_y_mm", "fibers"},
         "raft-6p2": {"alpha_length_mm", "beta_length_mm", "pitch_mm", "alpha_limits_deg",
                      "beta_limits_deg", "buffer_mm", "segment_start_mm", "segment_end_mm",
                      "ferrule_y_mm", "fibers"}}


@pytest.mark.parametrize("name", ["pfs-cobra", "raft-6p2"])
def test_numbers_not_in_the_facts_are_marked_estimate(name):
    text = (resources.files("rfp_twin.models") / "presets" / f"{name}.toml").read_text()
    checked = 0
    for line in text.splitlines():
        m = re.match(r"(\w+)\s*=\s*[\[\d.-]", line)
        if m and m.group(1) not in FACTS[name]:
            assert "estimate" in line, line
            checked += 1
    assert checked >= 15
    assert set(load_tables(name)["geometry"]) >= {"beta_tip_mm", "body_radius_mm"}


def _plan_and_check(preset: str, layout: str, seed: int):
    rc = Reconfiguration.from_names(preset, layout)
    outcome = rc.run(seed=seed)
    traj = outcome.trajectory
    assert traj.n_robots == rc.layout.n_robots
    moved = np.abs(traj.end() - traj.start()).max(axis=1)
    assert (moved > 1.0).mean() > 0.9                        # a real reconfiguration
    again = check_trajectory(traj, rc.spec, rc.layout, outcome.check.buffer_mm)
    return outcome, again


def test_raft_preset_plans_on_a_raft_layout():
    outcome, again = _plan_and_check("raft-6p2", "raft:4", seed=1)
    assert outcome.trajectory.n_robots == 252
    assert outcome.n_deadlocked == 0
    assert outcome.check.ok and again.ok and again.min_clearance_mm > 0


def test_pfs_preset_plans_on_its_default_kind_of_grid():
    outcome, again = _plan_and_check("pfs-cobra", "hex:61", seed=2)
    assert outcome.check.ok and again.ok


# -- arm ratio ---------------------------------------------------------------------------
@pytest.mark.parametrize("ratio", [0.25, 1.0, 2.0, 3.5])
def test_arm_ratio_keeps_the_reach(ratio):
    s = with_arm_ratio(load_spec("raft-6p2"), ratio)
    assert s.alpha_length_mm / s.beta_length_mm == pytest.approx(ratio)
    assert s.reach_mm == pytest.approx(3.6)
    assert s.segment_end() == pytest.approx(s.beta_length_mm)  # segment ended on the fiber
    assert s.patrol_annulus_mm[0] == pytest.approx(abs(s.alpha_length_mm - s.beta_length_mm))
    assert (s.buffer_mm, s.pitch_mm, s.fold_deg) == (0.8, 6.2, (10.0, 170.0))
    assert f"with_arm_ratio {ratio:g}" in s.description


def test_arm_ratio_of_sdss_v():
    s = with_arm_ratio(load_spec("sdss-v"), 7.4 / 15.0)       # its own ratio: unchanged arms
    assert (s.alpha_length_mm, s.beta_length_mm) == pytest.approx((7.4, 15.0))
    a, b = arm_lengths(22.4, 1.0)
    assert (a, b) == (11.2, 11.2)


def test_a_segment_end_off_the_fiber_keeps_its_distance_to_it():
    prod = load_spec("sdss-v-production")                     # rule: 14.73 mm at cb 2.0
    s = with_arm_ratio(prod, 1.0)
    assert s.beta_length_mm == pytest.approx(11.2)
    assert s.segment_end() == pytest.approx(prod.segment_end() - 3.8)
    short = load_spec("raft-6p2").with_overrides(segment_end_mm=1.5)
    t = with_arm_ratio(short, 0.5)                            # beta 2.4: end 1.5 + 0.6
    assert (t.beta_length_mm, t.segment_end()) == pytest.approx((2.4, 2.1))


@pytest.mark.parametrize("ratio", [0.0, -1.0, math.inf, math.nan, "2", None, True])
def test_bad_arm_ratio_names_the_field(ratio):
    with pytest.raises(SpecError) as info:
        with_arm_ratio(load_spec("raft-6p2"), ratio)
    msg = str(info.value)
    assert "'arm_ratio'" in msg and "(0, inf)" in msg and "\n" not in msg
