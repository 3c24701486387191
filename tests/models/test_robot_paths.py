"""Preset look-up edge cases: folders named like presets, relative `extends`."""
from __future__ import annotations

import numpy as np
import pytest

from models.errors import TargetError
from models.kinematics import inverse
from models.robot import load_spec


def test_folder_named_like_a_preset_does_not_hide_it(tmp_path, monkeypatch):
    (tmp_path / "sdss-v").mkdir()
    monkeypatch.chdir(tmp_path)
    assert load_spec("sdss-v").alpha_length_mm == 7.4


def test_relative_extends_is_resolved_from_the_file(tmp_path, monkeypatch):
    d = tmp_path / "specs"
    d.mkdir()
    (d / "base.toml").write_text(_sdss_text())
    (d / "mine.toml").write_text('extends = "base.toml"\n[robot]\npitch_mm = 20.0\n')
    monkeypatch.chdir(tmp_path)
    spec = load_spec(d / "mine.toml")
    assert spec.pitch_mm == 20.0 and spec.alpha_length_mm == 7.4


def _sdss_text() -> str:
    from importlib import resources
    return (resources.files("models") / "presets" / "sdss-v.toml").read_text()


def test_inverse_rejects_mismatched_shapes():
    with pytest.raises(TargetError, match=r"allowed: both \(n, 2\)"):
        inverse(np.zeros((1, 2)), np.ones((5, 2)), 7.4, 15.0)
