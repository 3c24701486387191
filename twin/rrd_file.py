"""Writing a Rerun recording (.rrd) atomically: one place for the temp file, the
recording stream and the rename, shared by the alpha/beta and the probe-arm recordings.

:func:`write_recording` opens a recording stream saving to a temp file beside ``out``,
lets the caller log into it, then flushes, sets mode 0644 and renames the file onto
``out``. On any error the temp file is removed and an existing ``out`` is left as it was.
"""
from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import Callable

import rerun as rr

from rfp_twin.models.errors import RfpError

APPLICATION_ID = "rfp-twin"


def write_recording(out_rrd: str | Path, log: Callable[[rr.RecordingStream], None],
                    error: type[RfpError] = RfpError) -> Path:
    """Write ``out_rrd`` with what ``log(rec)`` logs into the stream ``rec``; a folder
    that cannot be written raises ``error`` naming the path. Returns the path."""
    out = Path(out_rrd)
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=out.parent, prefix=f".{out.stem}.", suffix=".tmp.rrd")
        os.close(fd)
    except OSError as exc:
        raise error(f"{out}: cannot write here ({exc.strerror}); allowed: a path in a "
                    "writable folder") from None
    rec = rr.RecordingStream(APPLICATION_ID, send_properties=False)
    try:
        rec.save(tmp)
        log(rec)
        rec.flush()
        rec.disconnect()
        os.chmod(tmp, 0o644)
        os.replace(tmp, out)
    except BaseException:
        try:
            rec.disconnect()
        finally:
            Path(tmp).unlink(missing_ok=True)
        raise
    return out
