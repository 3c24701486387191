"""Tests of rfp_twin.models.files: atomic writes (the content is replaced only once complete)."""
from __future__ import annotations

import os
import stat

import pytest

from rfp_twin.models.files import atomic_write_bytes, atomic_write_text


def test_new_file_and_replacement(tmp_path):
    path = tmp_path / "out.json"
    atomic_write_text(path, "first ünïcode\n")
    assert path.read_bytes() == "first ünïcode\n".encode("utf-8")
    atomic_write_bytes(path, b"\x00second")
    assert path.read_bytes() == b"\x00second"
    assert stat.S_IMODE(path.stat().st_mode) == 0o644
    assert [p.name for p in tmp_path.iterdir()] == ["out.json"]


def test_a_failed_write_leaves_the_old_content_and_no_temp_file(tmp_path, monkeypatch):
    path = tmp_path / "out.txt"
    path.write_text("old\n")
    seen = []

    def failing_replace(src, dst):
        seen.append(open(src, "rb").read())          # the temp file was complete
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "replace", failing_replace)
    with pytest.raises(OSError, match="No space left"):
        atomic_write_text(path, "new content\n")
    assert seen == [b"new content\n"]
    assert path.read_text() == "old\n"
    assert [p.name for p in tmp_path.iterdir()] == ["out.txt"]


def test_an_interrupted_write_leaves_no_temp_file(tmp_path, monkeypatch):
    path = tmp_path / "out.txt"

    def interrupted(fd):
        raise KeyboardInterrupt

    monkeypatch.setattr(os, "fsync", interrupted)
    with pytest.raises(KeyboardInterrupt):
        atomic_write_bytes(path, b"data")
    assert list(tmp_path.iterdir()) == []


def test_a_missing_folder_raises_and_writes_nothing(tmp_path):
    with pytest.raises(FileNotFoundError):
        atomic_write_text(tmp_path / "missing" / "out.txt", "x")
    assert list(tmp_path.iterdir()) == []


def test_atomic_folder_replaces_whole_or_not_at_all(tmp_path):
    from rfp_twin.models.files import atomic_folder

    out = tmp_path / "run"
    with atomic_folder(out) as tmp:
        (tmp / "a.txt").write_text("one")
    assert (out / "a.txt").read_text() == "one"
    with pytest.raises(RuntimeError):
        with atomic_folder(out) as tmp:
            (tmp / "a.txt").write_text("two")
            raise RuntimeError("half-written")
    assert (out / "a.txt").read_text() == "one"                 # left as it was
    with atomic_folder(out) as tmp:
        (tmp / "b.txt").write_text("three")
    assert sorted(p.name for p in out.iterdir()) == ["b.txt"]   # replaced whole
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]  # no temp left
    assert oct(out.stat().st_mode & 0o777) == "0o755"


def test_atomic_folder_sub_folders_stay_listable(tmp_path):
    from rfp_twin.models.files import atomic_folder

    out = tmp_path / "passes"
    with atomic_folder(out) as tmp:
        (tmp / "pass1").mkdir()
        (tmp / "pass1" / "summary.json").write_text("{}")
    assert oct((out / "pass1").stat().st_mode & 0o777) == "0o755"
    assert oct((out / "pass1" / "summary.json").stat().st_mode & 0o777) == "0o644"
    assert (out / "pass1" / "summary.json").read_text() == "{}"
