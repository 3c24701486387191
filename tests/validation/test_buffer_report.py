"""Tests of the calibration result (validation/buffer/report.py)."""
from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest


def test_to_dict_is_strict_json(cal):
    odd = dataclasses.replace(cal, worst=dict(cal.worst, d2_mm=math.nan),
                              corner_buffer_mm=math.inf, pitch_mm=np.float64(22.4),
                              n_colliding=np.int64(7), buffers_mm=np.array([1.0, 2.0]),
                              mc_quantiles={"0.5": np.float32(1.5)})
    d = json.loads(json.dumps(odd.to_dict(), allow_nan=False))
    assert d["worst"]["d2_mm"] is None and d["corner_buffer_mm"] is None
    assert d["pitch_mm"] == 22.4 and d["n_colliding"] == 7 and d["buffers_mm"] == [1.0, 2.0]
    assert d["mc_quantiles"] == {"0.5": 1.5}
    assert set(d) == {f.name for f in dataclasses.fields(cal)}
    assert d["angular_error_deg"] == list(cal.angular_error_deg)


def test_wasted_at_takes_the_nearest_tabulated_buffer(cal):
    k = cal.buffers_mm.index(2.5)
    assert cal.wasted_at(2.5) == cal.wasted_fraction[k]
    assert cal.wasted_at(2.52) == cal.wasted_fraction[k]
    assert cal.wasted_at(100.0) == cal.wasted_fraction[-1]


def test_table_states_the_three_results(cal):
    lines = cal.table().splitlines()
    assert lines[0].startswith(f"buffer calibration ({cal.spec_name}, ")
    assert f"{cal.n_samples} uniform + {cal.n_boundary} boundary" in lines[0]
    assert lines[1].startswith(f"(a) smallest buffer with 2D-safe => 3D-safe: "
                               f"{cal.safe_buffer_mm:.4f} mm")
    assert f"links {cal.worst['links']}" in lines[2]
    assert lines[3].endswith(f"{cal.wasted_at(cal.spec_buffer_mm):.3f}")
    assert f"buffer {cal.mc_buffer_mm:.4f} mm keeps 3D safety" in lines[4]
    assert cal.mc_buffer_mm == pytest.approx(cal.safe_buffer_mm + cal.mc_share_mm)
