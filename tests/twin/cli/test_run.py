"""`rfp-twin simulate | render | record | model export` (twin/cli/run.py), as a user runs them."""
from __future__ import annotations

import json

import numpy as np
import pytest

from tests.twin.cli.runner import run


def test_simulate_and_model_export(tmp_path):
    out = tmp_path / "run"
    assert run("plan", "--layout", "hex:19", "--seed", "1", "--out", str(out)).returncode == 0
    r = run("simulate", str(out))
    assert r.returncode == 0, r.stderr
    sim = json.loads((out / "sim.json").read_text())
    assert sim["contact_pairs"] == [] and sim["not_reached"] == []
    r = run("simulate", str(out), "--stuck", "3:0.5")
    assert r.returncode == 0 and "stuck" in r.stdout
    assert json.loads((out / "sim.json").read_text())["not_reached"] == [3]
    r = run("simulate", str(out), "--slow", "x")
    assert r.returncode == 2 and "ID:FACTOR" in r.stderr
    r = run("simulate", str(tmp_path / "nope"))
    assert r.returncode == 2 and "run folder not found" in r.stderr
    r = run("model", "export", "--out", str(tmp_path / "model"), "--layout", "hex:7")
    assert r.returncode == 0, r.stderr
    import mujoco
    m = mujoco.MjModel.from_xml_path(str(tmp_path / "model" / "rfp-twin.xml"))
    assert m.njnt == 2 * 7


def test_load_run_reads_a_run_folder_both_ways(tmp_path):
    from rfp_twin.models.errors import RfpError
    from rfp_twin.twin.run_dir import LAYOUT, load_run

    out = tmp_path / "run"
    assert run("plan", "--layout", "hex:7", "--seed", "2", "--out", str(out)).returncode == 0
    spec, lay, traj, summary = load_run(out)
    assert lay.n_robots == 7 and summary["n_robots"] == 7 and spec.buffer_mm == 2.5
    _, _, back, _ = load_run(out, to_fold=True)
    np.testing.assert_allclose(back.end(), traj.start())
    (out / LAYOUT).unlink()
    with pytest.raises(RfpError, match="layout.csv is missing"):
        load_run(out)
    with pytest.raises(RfpError, match="run folder not found"):
        load_run(tmp_path / "nothing")


def test_render_and_record_commands(tmp_path):
    import imageio.v3 as iio

    out = tmp_path / "run"
    assert run("plan", "--layout", "hex:7", "--seed", "2", "--out", str(out)).returncode == 0
    mp4 = tmp_path / "fold.mp4"
    r = run("render", str(out), "--out", str(mp4), "--width", "320", "--height", "240",
            "--fps", "10", "--speedup", "4")
    assert r.returncode == 0, r.stderr
    frames = iio.imread(mp4)
    assert frames.shape[1:] == (240, 320, 3) and frames.std() > 5.0
    r = run("record", str(out), "--out", str(tmp_path / "run.rrd"))
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "run.rrd").stat().st_size > 10_000
    r = run("render", str(out), "--camera", "sideways", "--out", str(tmp_path / "x.mp4"))
    assert r.returncode == 2 and "camera" in r.stderr and not (tmp_path / "x.mp4").exists()


def test_a_raft_run_is_simulated_with_its_own_robot_in_one_model_and_in_tiles(tmp_path):
    """robot.toml has no [geometry]: the twin must take the raft preset's 3D robot, not the
    default one (whose fatter beta bars touched in this run: 273 contact pairs before)."""
    from rfp_twin.models.geometry import geometry_for_spec, load_geometry
    from rfp_twin.twin.run_dir import load_run

    out = tmp_path / "run"
    r = run("plan", "--preset", "raft-6p2", "--layout", "raft:8", "--buffer", "0.8", "--seed", "1",
            "--out", str(out))
    assert r.returncode == 0, r.stderr
    spec, _, _, _ = load_run(out)
    bar = geometry_for_spec(spec).links["beta"].collision[0].extents
    assert bar == pytest.approx(load_geometry("raft-6p2").links["beta"].collision[0].extents)
    for extra in ([], ["--tile-robots", "128"]):
        r = run("simulate", str(out), *extra)
        assert r.returncode == 0, r.stdout + r.stderr
        sim = json.loads((out / "sim.json").read_text())
        assert sim["contact_pairs"] == [] and sim["not_reached"] == []
    r = run("simulate", str(out), "--tile-robots", "-1")
    assert r.returncode == 2 and "--tile-robots -1; allowed" in r.stderr
