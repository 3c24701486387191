"""Tests of the calibration report on disk (validation/buffer/writer.py)."""
from __future__ import annotations

import json

import pytest

from rfp_twin.validation.buffer import write_report


def test_report_files(cal, tmp_path):
    paths = write_report(cal, tmp_path / "rep", command="rfp-twin calibrate-buffer")
    md = paths["markdown"].read_text()
    assert f"{cal.n_samples} uniform (Sobol) configurations" in md
    assert f"{cal.safe_buffer_mm:.4f}" in md and f"{cal.mc_buffer_mm:.4f}" in md
    assert "0.97" in md or f"{cal.paper_sigma_eps_mm:.4f}" in md
    for f in paths["figures"]:
        assert f.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and f.stat().st_size > 5000
        assert f.name in md
    data = json.loads(paths["json"].read_text())
    assert data["safe_buffer_mm"] == pytest.approx(cal.safe_buffer_mm)
    assert data["n_samples"] == cal.n_samples
