"""Tests of rfp_twin.twin.render.report: frame rates from the timings, and the JSON-ready summary."""
from __future__ import annotations

import json
import math
from pathlib import Path

from rfp_twin.twin.render import RenderReport


def _report(render_s: float, total_s: float) -> RenderReport:
    return RenderReport(Path("v.mp4"), 60, 2.0, 4.0, 320, 240, 30.0, 2.0, "top", "egl",
                        render_s, total_s, 1.5, {"waiting": 3, "moving": 1})


def test_frame_rates_are_frames_over_wall_time():
    r = _report(render_s=2.0, total_s=3.0)
    assert r.fps_rendered == 30.0 and r.fps_achieved == 20.0
    r = _report(render_s=0.0, total_s=0.0)
    assert math.isinf(r.fps_rendered) and math.isinf(r.fps_achieved)


def test_to_dict_is_json_and_leaves_out_the_simulation():
    d = _report(render_s=2.0, total_s=4.0).to_dict()
    assert json.loads(json.dumps(d)) == d
    assert d["path"] == "v.mp4" and d["frames"] == 60 and d["fps_achieved"] == 15.0
    assert d["state_counts"] == {"waiting": 3, "moving": 1} and "sim_report" not in d
