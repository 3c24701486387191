"""The MIRADAS probe arm kind: Sabater 2018 Eqs. 1-4, inverse kinematics, bench, bad input."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from rfp_twin.models.errors import LayoutError, SpecError, TargetError
from rfp_twin.models.kinds import ProbeArmKind, load_kind, load_probe_spec
from rfp_twin.models.layout import layout_by_name
from rfp_twin.models.robot import load_tables

PRESET = Path(__file__).resolve().parents[2] / "models" / "presets" / "miradas-probe.toml"


@pytest.fixture(scope="module")
def kind() -> ProbeArmKind:
    return load_kind("miradas-probe")


def _eqs_1_to_4(s, q_deg):
    """Sabater 2018 Eqs. 1-4 written out as printed."""
    t1, t2 = np.radians(q_deg[:, 0]), np.radians(q_deg[:, 1])
    u = (-s.d13_mm * np.sin(t1) + s.d24_mm * np.sin(t2)) / \
        (s.d12_mm - s.d13_mm * np.cos(t1) - s.d24_mm * np.cos(t2))
    x = s.d13_mm * np.cos(t1) + s.d3tip_mm / np.sqrt(1 + u ** 2)
    y = s.d13_mm * np.sin(t1) + s.d3tip_mm * u / np.sqrt(1 + u ** 2)
    d34 = np.sqrt((s.d12_mm - s.d24_mm * np.cos(t2) - s.d13_mm * np.cos(t1)) ** 2
                  + (s.d24_mm * np.sin(t2) - s.d13_mm * np.sin(t1)) ** 2)
    return np.column_stack([x, y]), d34


def _poses(n=400, seed=0):
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(0, 180, n), rng.uniform(0, 360, n)])


def test_forward_kinematics_and_zoa_are_eqs_1_to_4(kind):
    q = _poses()
    tip, d34 = _eqs_1_to_4(kind.spec, q)
    np.testing.assert_allclose(kind.forward(q), tip, atol=1e-9)
    np.testing.assert_allclose(kind.d34(q), d34, atol=1e-9)
    zoa = (d34 <= kind.spec.ds1_mm) | (d34 >= kind.spec.ds2_mm)
    assert zoa.any() and (~zoa).any()
    np.testing.assert_array_equal(kind.forbidden(q), zoa)
    # the head capsule ends at the tip; the crank and rocker hang on J1 and J2
    caps = kind.bodies(q)
    np.testing.assert_allclose(caps[:, 4, 2:4], tip, atol=1e-9)
    np.testing.assert_allclose(np.hypot(*caps[:, 0, 2:4].T), kind.spec.d13_mm)
    np.testing.assert_allclose(np.hypot(caps[:, 1, 2] - kind.spec.d12_mm, caps[:, 1, 3]),
                               kind.spec.d24_mm)


def test_park_pose_and_joint_ranges(kind):
    s = kind.spec
    assert s.park_deg == (180.0, 0.0) and s.max_speed_deg_s == (1.8, 1.8)
    assert math.radians(1.8) == pytest.approx(0.031416, abs=1e-6)     # Sect. 8
    np.testing.assert_allclose(kind.forward(np.array([180.0, 0.0])), [[s.d3tip_mm - s.d13_mm, 0.0]],
                               atol=1e-9)
    assert kind.forbidden(np.array([[-1.0, 10.0], [90.0, 361.0]])).all()


def test_inverse_kinematics_round_trip_soonest_from_reference(kind):
    q = _poses(seed=1)
    q = q[~kind.forbidden(q)]
    back = kind.inverse(kind.forward(q), ref_deg=np.array([180.0, 0.0]))
    assert np.all(np.isfinite(back))
    np.testing.assert_allclose(kind.forward(back), kind.forward(q), atol=1e-7)
    assert not kind.forbidden(back).any()
    # from the pose itself, the pose itself is the soonest
    for row in q[:20]:
        np.testing.assert_allclose(kind.inverse(kind.forward(row), ref_deg=row)[0], row, atol=1e-7)
    assert np.isnan(kind.inverse(np.array([[2000.0, 0.0]]))).all()


def test_bench_layout_miradas_12(kind):
    lay = layout_by_name("miradas-12", 22.4)
    assert lay.name == "miradas-12" and len(lay.robot_ids) == 12
    np.testing.assert_allclose(np.hypot(*lay.xy.T), kind.spec.bench_radius_mm)
    heading = np.radians(lay.extra["heading_deg"].astype(float))
    # each frame's x axis points at the field centre
    np.testing.assert_allclose(np.column_stack([np.cos(heading), np.sin(heading)]),
                               -lay.xy / kind.spec.bench_radius_mm, atol=1e-12)
    park_tips = kind.tips_world(kind.park())
    assert np.all(np.hypot(*park_tips.T) > kind.spec.field_radius_mm)   # park outside the field
    assert len(layout_by_name("miradas-6", 1.0).robot_ids) == 6
    with pytest.raises(LayoutError, match="miradas-N"):
        layout_by_name("miradas-x", 1.0)


def _spec_with(tmp_path, **changes):
    text = PRESET.read_text()
    for key, value in changes.items():
        lines = [ln for ln in text.splitlines() if ln.startswith(f"{key} =")]
        assert lines, key
        text = text.replace(lines[0], f"{key} = {value}")
    path = tmp_path / "probe.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize("changes, field", [
    ({"ds1_mm": 400.0, "ds2_mm": 450.0, "d3tip_mm": 500.0}, "'ds1_mm, ds2_mm'"),  # no pose
    ({"d12_mm": 150.0}, "'d12_mm'"),                        # loop cannot close as Eqs. 1-3
    ({"d3tip_mm": 250.0}, "'d3tip_mm'"),                    # tip inside the tube's end stop
    ({"ds1_mm": 270.0}, "'park_deg'"),                      # park pose in the ZoA
    ({"theta1_limits_deg": "[0.0, 200.0]", "park_deg": "[190.0, 0.0]", "ds1_mm": 10.0},
     None),                                                  # allowed: a wider range
])
def test_bad_probe_presets_fail_in_one_line(tmp_path, changes, field):
    path = _spec_with(tmp_path, **changes)
    if field is None:
        assert load_probe_spec(path).park_deg == (190.0, 0.0)
        return
    with pytest.raises(SpecError) as exc:
        load_probe_spec(path)
    msg = str(exc.value)
    assert "\n" not in msg and field in msg and "allowed" in msg and str(path) in msg


def test_unknown_field_and_missing_table(tmp_path):
    path = tmp_path / "p.toml"
    path.write_text(PRESET.read_text().replace("[bench]", "[benches]"))
    with pytest.raises(SpecError, match="benches"):
        load_probe_spec(path)
    tables = load_tables("miradas-probe")
    assert tables["kind"] == "miradas-probe" and set(tables) >= {"robot", "collision", "bench"}


def test_bad_targets_name_the_arm_and_the_range(kind):
    park = kind.park()
    far = np.full((12, 2), np.nan)
    far[3] = [2000.0, 0.0]
    with pytest.raises(TargetError, match=r"^arm 3: target .* has no pose; allowed: .*ZoA"):
        kind.poses_for_tips(far)
    q = park.copy()
    q[5] = [0.0, 0.0]                                          # d34 = 5 mm: in the ZoA
    with pytest.raises(TargetError, match=r"^arm 5: target .* is in the ZoA: d34 = 5.00 mm; "
                                          r"allowed: \(100, 300\) mm"):
        kind.check_poses(q)
    q[5] = [200.0, 0.0]
    with pytest.raises(TargetError, match=r"^arm 5: .*allowed: theta1 in \[0, 180\]"):
        kind.check_poses(q)
    kind.check_poses(park)
