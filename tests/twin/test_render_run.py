"""Tests of rfp_twin.twin.render.run: a whole run to an MP4 with the expected frames, simulated
when no report is given, and nothing left behind on failure."""
from __future__ import annotations

import math

import imageio.v2 as iio2
import pytest

import rfp_twin.twin.render as render  # first: picks MUJOCO_GL before mujoco is imported here
from rfp_twin.twin.render import RenderError, RenderSettings, render_run
from rfp_twin.twin.sim import simulate
from tests.twin.builders import colliding_run, swing_trajectory


@pytest.fixture(scope="module")
def colliding7(twin7):
    """The centre robot unfolds into its +x neighbour: (trajectory, SimReport)."""
    return colliding_run(twin7)


def test_render_run_writes_an_mp4_with_the_expected_frames(tmp_path, twin7, colliding7):
    traj, report = colliding7
    s = RenderSettings(width=160, height=120, fps=10, speedup=2.0)
    out = tmp_path / "fold.mp4"
    seen = []
    r = render_run(twin7, traj, out, s, sim_report=report, progress=lambda i, n: seen.append((i, n)))
    expected = int(math.floor(report.sim_s * 10 / 2.0 + 1e-9)) + 1
    assert r.frames == expected and seen[-1] == (expected, expected)
    assert r.backend == render.require_backend() and r.fps_rendered > 0
    assert r.sim_report is report and r.sim_wall_s == 0.0
    assert r.state_counts["contact"] > 0
    assert r.video_s == pytest.approx(expected / 10) and r.sim_s == report.sim_s
    reader = iio2.get_reader(out)
    assert reader.count_frames() == expected
    frames = [f for f in reader]
    reader.close()
    assert len(frames) == expected and frames[0].shape == (120, 160, 3)
    assert max(f.std() for f in frames) > 20
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fold.mp4"]   # no temp file left


def test_render_run_simulates_when_given_no_report(tmp_path, twin7):
    _, traj = swing_trajectory(twin7.layout)
    r = render_run(twin7, traj, tmp_path / "a.mp4", RenderSettings(width=64, height=48, fps=5))
    assert r.sim_report is not None and r.sim_wall_s > 0
    assert r.frames == int(math.floor(r.sim_s * 5 + 1e-9)) + 1
    assert (tmp_path / "a.mp4").stat().st_size > 0


def test_failed_render_leaves_nothing(tmp_path, twin7, colliding7):
    traj, report = colliding7
    out = tmp_path / "x.mp4"

    def boom(i, n):
        if i == 3:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        render_run(twin7, traj, out, RenderSettings(width=64, height=48, fps=5),
                   sim_report=report, progress=boom)
    assert list(tmp_path.iterdir()) == []


def test_report_without_record_or_nothing_to_render_is_refused(tmp_path, twin7, colliding7):
    traj, _ = colliding7
    report = simulate(twin7, traj, record=False)
    with pytest.raises(RenderError, match="no sampled record"):
        render_run(twin7, traj, tmp_path / "x.mp4", sim_report=report)
    with pytest.raises(RenderError, match="needs a trajectory or a simulation report"):
        render_run(twin7, None, tmp_path / "x.mp4")
    assert list(tmp_path.iterdir()) == []
