"""Tests of rfp_twin.twin.render.settings: render settings are checked field by field, with
one-line errors, and give the simulated time between frames."""
from __future__ import annotations

import math

import pytest

from rfp_twin.twin.render import RenderError, RenderSettings


@pytest.mark.parametrize("kwargs, message", [
    ({"width": 641}, "field 'width' = 641; allowed: an even integer"),
    ({"height": 8}, "field 'height' = 8"),
    ({"width": True}, "field 'width' = True"),
    ({"fps": 0}, "field 'fps' = 0; allowed: a finite number > 0"),
    ({"speedup": float("nan")}, "field 'speedup'"),
    ({"camera": "side"}, "field 'camera' = 'side'; allowed: top, oblique, closeup"),
    ({"robot_id": 3}, "allowed: a robot id only with camera 'closeup'"),
    ({"crf": 60}, "field 'crf' = 60"),
    ({"preset": "quick"}, "field 'preset' = 'quick'; allowed: ultrafast"),
])
def test_bad_settings_raise_one_line_errors(kwargs, message):
    with pytest.raises(RenderError) as err:
        RenderSettings(**kwargs)
    assert message in str(err.value) and "\n" not in str(err.value)


def test_good_settings_are_kept():
    s = RenderSettings(width=4096, height=16, fps=24, speedup=0.5, camera="closeup",
                       robot_id=7, crf=0, preset="veryslow")
    assert (s.width, s.height, s.robot_id, s.crf) == (4096, 16, 7, 0)


def test_frame_dt_is_speedup_over_fps_and_wide_cameras_show_the_grid():
    assert math.isclose(RenderSettings(fps=10, speedup=2.0).frame_dt_s, 0.2)
    assert math.isclose(RenderSettings(fps=30).frame_dt_s, 1 / 30)
    assert RenderSettings(camera="top").wide and RenderSettings(camera="oblique").wide
    assert not RenderSettings(camera="closeup").wide
