"""Targets as astronomers give them: wok x, y of a named fiber, solved per robot."""
from __future__ import annotations

import csv

import numpy as np
import pytest

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.errors import TargetError
from rfp_twin.models.instrument import calibration_folder, read_calibration
from rfp_twin.models.layout import layout_by_name
from rfp_twin.models.robot import load_spec
from rfp_twin.twin.targets_csv import read_targets_csv


@pytest.fixture(scope="module")
def apo():
    return ArrayGeometry(load_spec("sdss-v-production"), layout_by_name("sdss-v-apo", 22.4), 2.0)


def fiber_in_wok(cal, k, alpha, beta, fiber):
    """Fiber ``fiber`` (0 met, 1 boss, 2 apogee) of robot ``k`` in the wok frame, from the
    calibration alone: base + alpha arm along i/j, fiber in the beta frame turned by a + b."""
    i, j = cal.frames[k, 0, :2], cal.frames[k, 1, :2]
    base = cal.base_xyz[k, :2]
    a, ab = np.radians(alpha), np.radians(alpha + beta)
    fx, fy = cal.fibers[k, fiber]
    arm = cal.alpha_len[k] * (np.cos(a) * i + np.sin(a) * j)
    head = fx * (np.cos(ab) * i + np.sin(ab) * j) + fy * (-np.sin(ab) * i + np.cos(ab) * j)
    return base + arm + head


def write(path, header, rows):
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        w.writerows(rows)
    return path


def test_a_boss_target_in_wok_coordinates_lands_the_boss_fiber(apo, tmp_path):
    cal = read_calibration(calibration_folder("sdss-v-apo"))
    rng = np.random.default_rng(5)
    angles = np.column_stack([rng.uniform(0, 360, cal.n_robots), rng.uniform(20, 160, cal.n_robots)])
    rows = [(int(cal.robot_ids[k]), *fiber_in_wok(cal, k, *angles[k], 1), "boss")
            for k in range(cal.n_robots)]
    got = read_targets_csv(write(tmp_path / "t.csv", ["robot_id", "x_wok_mm", "y_wok_mm", "fiber"],
                                 rows), apo)
    back = np.array([fiber_in_wok(cal, k, *got[k], 1) for k in range(cal.n_robots)])
    want = np.array([r[1:3] for r in rows])
    assert np.abs(back - want).max() < 1e-6                 # within 1 um, every robot
    # the same pose, alpha turned into each robot's own range (its encoder offset shifts it)
    turn = (got[:, 0] - angles[:, 0] + 180.0) % 360.0 - 180.0
    np.testing.assert_allclose(turn, 0.0, atol=1e-7)
    np.testing.assert_allclose(got[:, 1], angles[:, 1], atol=1e-7)
    lim = apo.limits
    assert np.all((got[:, 0] >= lim[:, 0]) & (got[:, 0] <= lim[:, 1]))
    assert np.any(got[:, 0] != angles[:, 0]) and np.any(lim[:, 0] != 0.0)
    # not the metrology fiber: that one sits 0.7 mm away
    met = np.array([fiber_in_wok(cal, k, *got[k], 0) for k in range(cal.n_robots)])
    assert np.hypot(*(met - want).T).min() > 0.6


def test_a_boss_target_lands_the_boss_fiber_of_the_mujoco_model(apo, tmp_path):
    """The same targets, put into the MuJoCo twin of the APO instrument at the solved
    angles: each robot's BOSS fiber site is on its target (wok frame turned into the
    planning frame) within 1 um, and at the focal surface."""
    from rfp_twin.models.instrument import wok_to_plane
    from rfp_twin.models.mjcf import build_model

    cal = read_calibration(calibration_folder("sdss-v-apo"))
    rng = np.random.default_rng(8)
    angles = np.column_stack([rng.uniform(0, 360, cal.n_robots), rng.uniform(20, 160, cal.n_robots)])
    want = np.array([fiber_in_wok(cal, k, *angles[k], 1) for k in range(cal.n_robots)])
    rows = [(int(cal.robot_ids[k]), *want[k], "boss") for k in range(cal.n_robots)]
    got = read_targets_csv(write(tmp_path / "t.csv", ["robot_id", "x_wok_mm", "y_wok_mm", "fiber"],
                                 rows), apo)
    twin = build_model(apo.spec, apo.layout)
    order = [int(np.flatnonzero(cal.robot_ids == r)[0]) for r in apo.layout.robot_ids]
    xyz = twin.fiber_xyz(twin.make_data(got))
    boss = twin.index.fiber_names.index("boss")
    miss = np.hypot(*(xyz[:, boss, :2] - wok_to_plane(want[order])).T)
    assert miss.max() < 1e-3, miss.max()
    assert xyz[:, boss, 2] == pytest.approx(twin.geometry.params.focal_z_mm, abs=1e-9)
    met = twin.index.fiber_names.index("metrology")
    assert np.hypot(*(xyz[:, met, :2] - wok_to_plane(want[order])).T).min() > 0.6


def test_a_fiber_the_robot_does_not_carry_names_the_line(apo, tmp_path):
    cal = read_calibration(calibration_folder("sdss-v-apo"))
    boss_only = int(np.flatnonzero(cal.robot_hole_types == "Boss")[0])
    rows = [(int(rid), *fiber_in_wok(cal, k, 90.0, 90.0, 0), "metrology")
            for k, rid in enumerate(cal.robot_ids)]
    rows[boss_only] = (rows[boss_only][0], *rows[boss_only][1:3], "apogee")
    path = write(tmp_path / "t.csv", ["robot_id", "x_wok_mm", "y_wok_mm", "fiber"], rows)
    with pytest.raises(TargetError) as info:
        read_targets_csv(path, apo)
    msg = str(info.value)
    assert f"t.csv:{boss_only + 2}" in msg and "does not carry a apogee fiber" in msg, msg


def test_a_position_out_of_the_robots_own_reach_is_refused(apo, tmp_path):
    cal = read_calibration(calibration_folder("sdss-v-apo"))
    rows = [(int(rid), *fiber_in_wok(cal, k, 90.0, 90.0, 0)) for k, rid in enumerate(cal.robot_ids)]
    k = 17
    reach = cal.alpha_len[k] + cal.fibers[k, 0, 0]
    rows[k] = (rows[k][0], *(cal.base_xyz[k, :2] + [reach + 0.01, 0.0]))
    path = write(tmp_path / "t.csv", ["robot_id", "x_wok_mm", "y_wok_mm"], rows)
    with pytest.raises(TargetError) as info:
        read_targets_csv(path, apo)
    msg = str(info.value)
    assert f"t.csv:{k + 2}" in msg and f"robot {int(cal.robot_ids[k])}" in msg
    assert f"{reach:.3f}] mm" in msg, msg


def test_wok_positions_need_a_calibrated_instrument(tmp_path):
    geom = ArrayGeometry(load_spec("sdss-v"), layout_by_name("hex:7", 22.4), 2.0)
    path = write(tmp_path / "t.csv", ["robot_id", "x_wok_mm", "y_wok_mm"],
                 [(i, 0.0, 10.0) for i in range(7)])
    with pytest.raises(TargetError, match="x_wok_mm,y_wok_mm on layout 'hex-7'"):
        read_targets_csv(path, geom)


def test_robots_left_out_are_parked_at_the_fold(apo, tmp_path):
    """A file naming a few robots: they get their targets, every other robot its fold
    (turned into its own range), for positions and for angles alike."""
    from rfp_twin.models.layout.columns import fit_to_limits

    cal = read_calibration(calibration_folder("sdss-v-apo"))
    picked = [3, 40, 41, 200]
    rows = [(int(cal.robot_ids[k]), *fiber_in_wok(cal, k, 30.0 + k, 120.0, 1), "boss")
            for k in picked]
    got = read_targets_csv(write(tmp_path / "t.csv", ["robot_id", "x_wok_mm", "y_wok_mm",
                                                      "fiber"], rows), apo)
    fold = fit_to_limits(np.tile(apo.spec.fold_deg, (apo.n_robots, 1)), apo.limits)[0]
    others = np.setdiff1d(np.arange(apo.n_robots), picked)
    assert np.array_equal(got[others], fold[others])
    back = np.array([fiber_in_wok(cal, k, *got[k], 1) for k in picked])
    assert np.allclose(back, [r[1:3] for r in rows], atol=1e-9)
    ang = read_targets_csv(write(tmp_path / "a.csv", ["robot_id", "alpha_deg", "beta_deg"],
                                 [(int(cal.robot_ids[7]), 20.0, 100.0)]), apo)
    assert ang[7].tolist() == [20.0, 100.0]
    assert np.array_equal(np.delete(ang, 7, axis=0), np.delete(fold, 7, axis=0))
