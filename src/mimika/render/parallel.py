"""Render long AU animations in several processes (one OpenGL context each).

A software rasteriser (Mesa's llvmpipe) leaves cores idle while one thread processes vertices,
and moderngl holds the GIL during every GL call, so threads cannot fill that gap; processes
can. :func:`render_track` deals fixed-size chunks of AU frames to a pool of spawned workers,
each holding a copy of the rig, which deform and draw them; the images come back in order.
Each chunk starts afresh (:meth:`~mimika.render.Renderer.invalidate`), so the images are the
same whatever the number of workers.
"""

from __future__ import annotations

import contextlib
import logging
import os
import threading
import time
from collections import deque
from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np

log = logging.getLogger(__name__)

_worker: dict[str, Any] = {}  # the worker's rig, channels and Renderer


def default_workers(n_frames: int, chunk: int) -> int:
    """Worker processes worth starting for ``n_frames``: one per core (at most 4), none for
    clips of under three chunks (starting a process costs about a second)."""
    if n_frames < 3 * chunk:
        return 1
    return max(1, min(os.cpu_count() or 1, 4))


def _open(rig: Any, size: tuple[int, int], samples: int, skin: Any, lighting: Any,
          hidden: Sequence[str] = ()) -> Any:
    from mimika.render import Renderer

    # one camera for the whole track: what lies far outside its view is never drawn
    return Renderer(rig.head, size=size, samples=samples, skin_shader=skin, lighting=lighting,
                    hidden=hidden, crop=True)


def _draw(renderer: Any, rig: Any, values: np.ndarray, channels: Sequence[str],
          camera: Any) -> Iterator[np.ndarray]:
    renderer.invalidate()
    pos = rig.deform_batch(values, channels)
    for i in range(len(values)):
        yield renderer.render({n: p[i] for n, p in pos.items()}, camera=camera,
                              aus=dict(zip(channels, values[i].tolist(), strict=True)))


def _watch_parent(ppid: int) -> None:
    """Exit as soon as the parent is gone (killed, even by SIGKILL): no orphan workers."""
    while os.getppid() == ppid:
        time.sleep(0.25)
    os._exit(1)


def _init(rig: Any, channels: Sequence[str], size: tuple[int, int], samples: int, skin: Any,
          lighting: Any, lp_threads: int, hidden: Sequence[str] = (), ppid: int = 0) -> None:
    if ppid:
        threading.Thread(target=_watch_parent, args=(ppid,), name="mimika-watch-parent",
                         daemon=True).start()
    os.environ.setdefault("LP_NUM_THREADS", str(lp_threads))
    _worker.update(rig=rig, channels=channels,
                   renderer=_open(rig, size, samples, skin, lighting, hidden))


def _render_chunk(values: np.ndarray, camera: Any) -> np.ndarray:
    w = _worker
    return np.stack(list(_draw(w["renderer"], w["rig"], values, w["channels"], camera)))


def _stop(pool: Any) -> None:
    """Cancel what is queued and end the worker processes without waiting for their chunks
    (``ProcessPoolExecutor`` offers no terminate before Python 3.14)."""
    procs = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for p in procs:
        with contextlib.suppress(Exception):
            p.terminate()
    for p in procs:
        with contextlib.suppress(Exception):
            p.join(2.0)
            if p.is_alive():
                p.kill()


def _owned(path: str) -> bool:
    try:
        return os.stat(path).st_uid == os.getuid()
    except OSError:
        return False


def sweep_semaphores(shm: str = "/dev/shm") -> int:
    """Remove multiprocessing's named semaphores (``sem.mp-*``) of this user that no process
    has open: those of pools killed outright with their whole process group, which nobody is
    left to release. Returns how many were removed."""
    import glob

    left = [p for p in glob.glob(os.path.join(shm, "sem.mp-*")) if _owned(p)]
    if not left:
        return 0
    in_use: set[str] = set()
    for maps in glob.glob("/proc/[0-9]*/maps"):
        with contextlib.suppress(OSError), open(maps) as f:
            in_use.update(line.split(None, 5)[-1].strip() for line in f if "/sem.mp-" in line)
    removed = 0
    for p in left:
        if p not in in_use:
            with contextlib.suppress(OSError):
                os.unlink(p)
                removed += 1
    return removed


def render_track(rig: Any, values: np.ndarray, channels: Sequence[str], *, camera: Any,
                 size: tuple[int, int], samples: int = 0, skin: Any = False,
                 lighting: Any = None, chunk: int = 50, workers: int = 1,
                 hidden: Sequence[str] = ()) -> Iterator[np.ndarray]:
    """Yield the image (H, W, 3) uint8 of every row of ``values`` (T × channels AU
    intensities) on ``rig``'s head, in order.

    ``workers`` > 1 renders in that many spawned processes (at most ``workers + 1`` chunks of
    ``chunk`` frames in flight); 1 renders here. ``size``, ``samples``, ``skin`` and
    ``lighting`` and ``hidden`` are those of :class:`~mimika.render.Renderer`.
    """
    starts = range(0, len(values), chunk)
    if workers <= 1:
        with _open(rig, size, samples, skin, lighting, hidden) as r:
            for i0 in starts:
                yield from _draw(r, rig, values[i0:i0 + chunk], channels, camera)
        return

    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor
    from concurrent.futures.process import BrokenProcessPool

    from mimika.errors import RenderError

    # llvmpipe threads per worker: the cores shared out; 0 rasterises in the calling thread
    # (cheaper than handing every tile to a single helper thread)
    lp = (os.cpu_count() or 1) // workers
    lp = 0 if lp <= 1 else lp
    sweep_semaphores()
    with ProcessPoolExecutor(workers, mp_context=mp.get_context("spawn"), initializer=_init,
                             initargs=(rig, list(channels), size, samples, skin, lighting,
                                       lp, tuple(hidden), os.getpid())) as pool:
        pending: deque = deque()
        try:
            for i0 in starts:
                pending.append(pool.submit(_render_chunk, values[i0:i0 + chunk], camera))
                if len(pending) > workers:
                    yield from pending.popleft().result()
            while pending:
                yield from pending.popleft().result()
        except BrokenProcessPool as exc:
            raise RenderError(
                f"the rendering processes stopped ({exc}); render with workers=1 (--workers 1) "
                "to see the error here, and start them from a script only under "
                "'if __name__ == \"__main__\":'") from None
        except BaseException:  # interrupted, terminated or abandoned: stop the workers now
            _stop(pool)
            raise
