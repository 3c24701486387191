"""Atomic file writes: a temp file in the target's folder, then a rename over the target.

A reader (or a crash) never sees a half-written file: the content is flushed to disk
before ``os.replace`` puts it in place, an existing file is replaced only once the new
content is complete, and on any error the temp file is removed and the target left as
it was.
"""
from __future__ import annotations

import os
import tempfile
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
