"""The offscreen OpenGL backend of MuJoCo, chosen before ``mujoco`` is imported.

MuJoCo reads ``MUJOCO_GL`` once, when ``mujoco`` is first imported. Importing this module
(which :mod:`rfp_twin.twin.render` does first, so that importing any part of the render package
does it) therefore picks a backend and imports no mujoco itself: if ``MUJOCO_GL`` is
unset, :func:`select_gl_backend` probes ``egl`` then ``osmesa``, each in a throw-away
subprocess (a backend whose libraries are missing or broken can fail on import and must
not poison this process), and sets ``MUJOCO_GL`` to the first that creates a context. A
value the user set is kept as it is. Import :mod:`rfp_twin.twin.render` before anything imports
mujoco (the CLI's ``render`` command imports it first).

If mujoco was imported earlier anyway, rendering still works: :func:`gl_context_class`
takes the GL context from the chosen backend's own module (``mujoco.egl`` /
``mujoco.osmesa``), not from whatever ``mujoco.GLContext`` was bound at import.
When no backend works, importing still succeeds (other commands need no GL); the first
renderer raises :class:`RenderError` naming each backend and why it failed.

Times are wall-clock seconds.
"""
from __future__ import annotations

import os
import subprocess
import sys

from rfp_twin.models.errors import RfpError

#: Offscreen backends, in the order they are tried.
GL_BACKENDS = ("egl", "osmesa")
#: Wall seconds one backend probe may take.
PROBE_TIMEOUT_S = 60.0

_PROBE = r"""
import mujoco
ctx = mujoco.GLContext(16, 16)
ctx.make_current()
con = mujoco.MjrContext(mujoco.MjModel.from_xml_string("<mujoco/>"),
                        mujoco.mjtFontScale.mjFONTSCALE_100)
from OpenGL import GL
print("RENDERER=" + GL.glGetString(GL.GL_RENDERER).decode(errors="replace"))
con.free()
ctx.free()
"""


class RenderError(RfpError):
    """Rendering cannot run: no working OpenGL backend, bad render settings, a report
    without the sampled record, an unwritable output."""


def probe_gl_backend(backend: str, timeout_s: float = PROBE_TIMEOUT_S) -> tuple[bool, str]:
    """Try one backend in a subprocess: ``(True, GL renderer string)`` when mujoco can
    create a context with ``MUJOCO_GL=backend`` within ``timeout_s`` wall seconds, else
    ``(False, why)``."""
    env = dict(os.environ, MUJOCO_GL=backend)
    env.pop("PYOPENGL_PLATFORM", None)
    try:
        r = subprocess.run([sys.executable, "-c", _PROBE], env=env, capture_output=True,
                           text=True, timeout=timeout_s)
    except subprocess.TimeoutExpired:
        return False, f"no answer within {timeout_s:g} s"
    except OSError as exc:
        return False, f"cannot start {sys.executable}: {exc.strerror}"
    for line in r.stdout.splitlines():
        if r.returncode == 0 and line.startswith("RENDERER="):
            return True, line[len("RENDERER="):].strip()
    lines = [ln.strip() for ln in (r.stderr or r.stdout).splitlines() if ln.strip()]
    return False, (lines[-1] if lines else f"exit code {r.returncode}")[:300]


_selected: dict[str, object] = {}


def select_gl_backend(candidates: tuple[str, ...] = GL_BACKENDS) -> str:
    """The offscreen backend to use, and ``MUJOCO_GL`` set to it.

    A ``MUJOCO_GL`` already set (by the user or an earlier call) is kept. Otherwise each
    candidate is probed in a subprocess (:func:`probe_gl_backend`) and the first that
    works is exported as ``MUJOCO_GL`` (and ``PYOPENGL_PLATFORM`` when unset), so child
    processes inherit it without probing again. Call it before ``import mujoco``.

    Raises
    ------
    RenderError
        No candidate works; the message lists each backend's failure.
    """
    current = os.environ.get("MUJOCO_GL", "").strip().lower()
    if current:
        return current
    failures = []
    for backend in candidates:
        ok, info = probe_gl_backend(backend)
        if ok:
            os.environ["MUJOCO_GL"] = backend
            os.environ.setdefault("PYOPENGL_PLATFORM", backend)
            _selected["renderer"] = info
            return backend
        failures.append(f"{backend}: {info}")
    raise RenderError("no offscreen OpenGL backend works (" + "; ".join(failures) + "); allowed: "
                      "install Mesa's EGL (Debian libegl1) or OSMesa (libosmesa6), or set "
                      "MUJOCO_GL to a working backend")


# Pick the backend now, before mujoco is imported (see the module docstring).
try:
    BACKEND: str | None = select_gl_backend()
    _BACKEND_ERROR: RenderError | None = None
except RenderError as _exc:  # pragma: no cover - depends on the machine
    BACKEND, _BACKEND_ERROR = None, _exc


def require_backend() -> str:
    """The selected backend; raises :class:`RenderError` when none works."""
    if _BACKEND_ERROR is not None:
        raise _BACKEND_ERROR
    return os.environ.get("MUJOCO_GL", BACKEND or "").strip().lower()


def gl_context_class(backend: str):
    """The GLContext class of a backend, imported from its own module so that it works
    even when mujoco was imported before ``MUJOCO_GL`` was set."""
    try:
        if backend == "egl":
            from mujoco.egl import GLContext
        elif backend == "osmesa":
            from mujoco.osmesa import GLContext
        else:
            from mujoco import GLContext
    except (ImportError, AttributeError, OSError) as exc:
        raise RenderError(f"MUJOCO_GL={backend!r}: cannot load the backend ({exc}); allowed: "
                          f"{', '.join(GL_BACKENDS)} with Mesa installed") from None
    return GLContext


def gl_renderer_info() -> str:
    """The backend and GL renderer string (e.g. ``egl: llvmpipe (LLVM 15.0.6, 256 bits)``)."""
    backend = require_backend()
    info = _selected.get("renderer")
    if info is None:
        ok, info = probe_gl_backend(backend)
        _selected["renderer"] = info if ok else f"unknown ({info})"
    return f"{backend}: {_selected['renderer']}"
