"""The process-wide headless OpenGL context (Mesa EGL through moderngl).

One context is created lazily and shared by every :class:`~mimika.render.Renderer` of the
process; each renderer owns its own buffers, programs and framebuffers inside it.
"""

from __future__ import annotations

import logging
import threading
from typing import Any

from mimika.errors import RenderError

log = logging.getLogger(__name__)

#: Shown whenever no context can be made.
INSTALL_HINT = "install it with: apt-get install -y libegl1 libgl1-mesa-dri"

_context: Any = None
_lock = threading.Lock()
#: Held while a frame is drawn: the one context must not be used by two threads at once.
render_lock = threading.RLock()


def _create_context() -> Any:
    """Make a new standalone OpenGL ≥ 3.3 context on the EGL backend (no display needed)."""
    import moderngl

    return moderngl.create_standalone_context(backend="egl", require=330)


def get_context() -> Any:
    """The shared ``moderngl.Context``, created on first use.

    Raises
    ------
    RenderError
        If moderngl is missing or headless OpenGL (Mesa EGL) cannot be initialised.
    """
    global _context
    with _lock:
        if _context is not None:
            return _context
        try:
            import moderngl  # noqa: F401
        except ImportError as exc:
            raise RenderError(
                f"the OpenGL bindings are not installed ({exc}); "
                "install them with: pip install 'mimika[render]'"
            ) from exc
        try:
            ctx = _create_context()
        except Exception as exc:
            raise RenderError(
                f"headless OpenGL (Mesa EGL) is not available: {exc}; {INSTALL_HINT}"
            ) from exc
        # entering and leaving once releases it from this thread (glcontext leaves a new
        # context current where it was made, and then no other thread could use it)
        with ctx:
            info = ctx.info
        log.info(
            "OpenGL context: %s, %s (GL %s)",
            info.get("GL_VENDOR"),
            info.get("GL_RENDERER"),
            info.get("GL_VERSION"),
        )
        _context = ctx
        return ctx


def has_uniform(prog: Any, name: str) -> bool:
    """True if the program ``prog`` has the uniform ``name`` (a variant may have compiled it
    away). ``name in prog`` walks every member in moderngl; the names are kept in
    ``prog.extra`` after the first call."""
    if prog.extra is None:
        prog.extra = frozenset(prog)
    return name in prog.extra


def egl_available() -> bool:
    """True if the shared headless context can be created (creates it if needed)."""
    try:
        get_context()
    except RenderError as exc:
        log.debug("no headless OpenGL: %s", exc)
        return False
    return True


def release_context() -> None:
    """Release the shared context; the next :func:`get_context` makes a new one.

    Renderers still holding objects of the old context must be closed first.
    """
    global _context
    with _lock:
        if _context is not None:
            try:
                _context.release()
            except Exception as exc:  # pragma: no cover - driver-dependent
                log.debug("releasing the GL context failed: %s", exc)
            _context = None
