"""Atomic file writes: a temp file in the target's folder, then a rename over the target.

A reader (or a crash) never sees a half-written file: the content is flushed to disk
before ``os.replace`` puts it in place, an existing file is replaced only once the new
content is complete, and on any error the temp file is removed and the target left as
it was. :func:`atomic_folder` does the same for a whole folder.
"""
from __future__ import annotations

import os
import shutil
import tempfile
from contextlib import contextmanager
from pathlib import Path


def atomic_write_bytes(path: str | Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temp file and ``os.replace`` (mode 0644).

    Raises
    ------
    OSError
        The folder does not exist or is not writable, or the disk is full; ``path`` is
        then unchanged and no temp file is left.
    """
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def atomic_write_text(path: str | Path, text: str) -> None:
    """Write UTF-8 ``text`` to ``path`` atomically (see :func:`atomic_write_bytes`)."""
    atomic_write_bytes(path, text.encode("utf-8"))


@contextmanager
def atomic_folder(out: str | Path):
    """Write a whole folder atomically: yields a temp folder beside ``out`` to fill; when
    the block ends without error its files get mode 0644, it and its sub-folders 0755 (a
    folder may hold whole run folders) and it replaces
    ``out`` (an existing ``out`` is moved aside first and removed after); on any error the
    temp folder is removed and ``out`` left as it was. The caller decides beforehand
    whether an existing ``out`` may be replaced."""
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.parent))
    try:
        yield tmp
        for f in tmp.rglob("*"):
            f.chmod(0o755 if f.is_dir() else 0o644)
        tmp.chmod(0o755)
        if out.exists():
            old = Path(tempfile.mkdtemp(prefix=f".{out.name}.old.", dir=out.parent))
            os.replace(out, old / "run")
            os.replace(tmp, out)
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
