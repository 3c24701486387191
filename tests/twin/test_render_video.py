"""Tests of rfp_twin.twin.render.video: frames encoded to an MP4 that reads back frame for frame,
PNGs that read back pixel for pixel, and no partial file on failure."""
from __future__ import annotations

import imageio.v2 as iio2
import imageio.v3 as iio
import numpy as np
import pytest

from rfp_twin.twin.render import Mp4Writer, RenderError, save_png


def _frames(n: int, h: int = 48, w: int = 64) -> list[np.ndarray]:
    """n frames (h, w, 3) uint8: a bright square moving right on a dark ground."""
    out = []
    for k in range(n):
        f = np.full((h, w, 3), 20, np.uint8)
        f[10:30, 4 * k:4 * k + 16] = (250, 200, 40)
        out.append(f)
    return out


def test_mp4_holds_every_frame(tmp_path):
    frames = _frames(9)
    out = tmp_path / "sub" / "v.mp4"
    with Mp4Writer(out, 64, 48, fps=12, crf=18, preset="ultrafast") as w:
        for f in frames:
            w.write(f)
    assert w.frames == 9 and w.close() == out
    reader = iio2.get_reader(out)
    assert reader.get_meta_data()["fps"] == pytest.approx(12)
    back = [f for f in reader]
    reader.close()
    assert len(back) == 9 and back[0].shape == (48, 64, 3)
    for a, b in zip(frames, back):
        assert np.abs(a.astype(int) - b).mean() < 6                # lossy, but the same picture
    assert sorted(p.name for p in out.parent.iterdir()) == ["v.mp4"]   # no temp file left
    assert oct(out.stat().st_mode & 0o777) == "0o644"


def test_wrong_frames_are_refused_and_a_failed_video_leaves_nothing(tmp_path):
    out = tmp_path / "v.mp4"
    with pytest.raises(RenderError, match=r"allowed: \(48, 64, 3\) uint8"):
        with Mp4Writer(out, 64, 48, fps=10) as w:
            w.write(_frames(1)[0])
            w.write(np.zeros((48, 64, 3), np.float32))
    assert list(tmp_path.iterdir()) == []


def test_unwritable_folder_is_a_render_error(tmp_path):
    (tmp_path / "file").write_text("x")
    with pytest.raises(RenderError, match="cannot write here"):
        Mp4Writer(tmp_path / "file" / "v.mp4", 64, 48, fps=10)


def test_png_round_trips(tmp_path):
    img = _frames(3)[2]
    path = save_png(img, tmp_path / "a" / "b.png")
    np.testing.assert_array_equal(iio.imread(path), img)
    assert sorted(p.name for p in path.parent.iterdir()) == ["b.png"]
