"""Render long AU animations in several processes (one OpenGL context each).

A software rasteriser (Mesa's llvmpipe) leaves cores idle while one thread processes vertices,
and moderngl holds the GIL during every GL call, so threads cannot fill that gap; processes
can. :func:`render_track` deals fixed-size chunks of AU frames to a pool of spawned workers,
each holding a copy of the rig, which deform and draw them; the images come back in order.
Each chunk starts afresh (:meth:`~mimika.render.Renderer.invalidate`), so the images are the
same whatever the number of workers. A :class:`RenderPool` started early sets its workers up
(occlusion, textures, shaders) while the caller is still busy, e.g. with speech. A chunk's
frames come back in a shared memory block (``/dev/shm/mimika-frames-*``), not pickled through
a pipe (that cost the main process 6 ms of CPU per 1280×720 frame).
"""

from __future__ import annotations

import contextlib
import itertools
import logging
import os
import pickle
import threading
import time
from collections import deque
from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np

log = logging.getLogger(__name__)

_worker: dict[str, Any] = {}  # the worker's rig and Renderer
#: the shared memory blocks that carry chunks of frames: mimika-frames-<parent>-<worker>-<n>
FRAMES = "mimika-frames-"
_serial = itertools.count()


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


def _init(setup: str, ppid: int) -> None:
    """Set a worker up from the settings its pool published (:func:`_publish`)."""
    from multiprocessing import shared_memory

    threading.Thread(target=_watch_parent, args=(ppid,), name="mimika-watch-parent",
                     daemon=True).start()
    shm = shared_memory.SharedMemory(setup)
    try:
        rig, size, samples, skin, lighting, lp_threads, hidden, camera = pickle.loads(shm.buf)
    finally:
        shm.close()
    os.environ.setdefault("LP_NUM_THREADS", str(lp_threads))
    renderer = _open(rig, size, samples, skin, lighting, hidden)
    if camera is not None:  # set up now (occlusion, textures, shaders): one frame at rest
        renderer.render(camera=camera, aus={})
    _worker.update(rig=rig, renderer=renderer, ppid=ppid)


def _publish(settings: tuple) -> Any:
    """The workers' settings (the rig among them, tens of MB) pickled once into a shared
    memory block that each worker reads as it starts (named as the blocks of frames, so a
    killed pool's is swept). Handed to ``spawn`` instead, they are written into each new
    process's pipe, and a process that dies before reading them all (a script that starts a
    render at import, without ``if __name__ == "__main__":``) leaves that write blocked
    forever instead of breaking the pool."""
    from multiprocessing import shared_memory

    data = pickle.dumps(settings, protocol=pickle.HIGHEST_PROTOCOL)
    shm = shared_memory.SharedMemory(f"{FRAMES}{os.getpid()}-{os.getpid()}-setup{next(_serial)}",
                                     create=True, size=len(data))
    shm.buf[:len(data)] = data
    return shm


def _ready() -> None:
    """A task that does nothing: submitting one per worker starts the processes."""


def _render_chunk(values: np.ndarray, channels: Sequence[str], camera: Any
                  ) -> tuple[str, tuple[int, ...]]:
    """Draw a chunk into a new shared memory block; its name and the frames' shape go back
    (the main process copies them out and removes it)."""
    from multiprocessing import shared_memory

    w = _worker
    frames = _draw(w["renderer"], w["rig"], values, channels, camera)
    first = next(frames)
    shape = (len(values), *first.shape)
    shm = shared_memory.SharedMemory(
        f"{FRAMES}{w['ppid']}-{os.getpid()}-{next(_serial)}", create=True,
        size=first.nbytes * len(values))
    try:
        out = np.ndarray(shape, np.uint8, buffer=shm.buf)
        out[0] = first
        for i, img in enumerate(frames, 1):
            out[i] = img
        del out
    except BaseException:
        shm.close()
        shm.unlink()
        raise
    shm.close()
    return shm.name, shape


def _take(block: tuple[str, tuple[int, ...]]) -> np.ndarray:
    """The frames of a chunk a worker drew (:func:`_render_chunk`), copied out of their shared
    memory block, which is removed."""
    from multiprocessing import shared_memory

    name, shape = block
    shm = shared_memory.SharedMemory(name)
    try:
        view = np.ndarray(shape, np.uint8, buffer=shm.buf)
        frames = view.copy()
        del view
    finally:
        shm.close()
        shm.unlink()
    return frames


def _discard(futures: Sequence[Any]) -> None:
    """Remove the shared memory blocks of chunks drawn but not taken."""
    from multiprocessing import shared_memory

    for f in futures:
        if f.done() and not f.cancelled() and f.exception() is None:
            with contextlib.suppress(OSError):
                shm = shared_memory.SharedMemory(f.result()[0])
                shm.close()
                shm.unlink()


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


def _alive(pid: str) -> bool:
    return pid.isdigit() and os.path.exists(f"/proc/{pid}")


def sweep_semaphores(shm: str = "/dev/shm") -> int:
    """Remove multiprocessing's named semaphores (``sem.mp-*``) of this user that no process
    has open, and the blocks of frames (:data:`FRAMES`) whose main process or worker is gone:
    those of pools killed outright with their whole process group, which nobody is left to
    release. Returns how many were removed."""
    import glob

    removed = 0
    for p in glob.glob(os.path.join(shm, FRAMES + "*")):
        parent, worker, *_ = [*os.path.basename(p)[len(FRAMES):].split("-"), "", ""]
        if _owned(p) and not (_alive(parent) and _alive(worker)):
            with contextlib.suppress(OSError):
                os.unlink(p)
                removed += 1
    left = [p for p in glob.glob(os.path.join(shm, "sem.mp-*")) if _owned(p)]
    if not left:
        return removed
    in_use: set[str] = set()
    for maps in glob.glob("/proc/[0-9]*/maps"):
        with contextlib.suppress(OSError), open(maps) as f:
            in_use.update(line.split(None, 5)[-1].strip() for line in f if "/sem.mp-" in line)
    for p in left:
        if p not in in_use:
            with contextlib.suppress(OSError):
                os.unlink(p)
                removed += 1
    return removed


class RenderPool:
    """``workers`` spawned rendering processes for one track on ``rig``'s head, seen by
    ``camera``, started at once: each sets up its renderer (occlusion, textures, shaders —
    about a second) while the caller is still busy, e.g. with speech. ``size``, ``samples``,
    ``skin``, ``lighting`` and ``hidden`` are those of :class:`~mimika.render.Renderer`.

    Hand it to :func:`render_track`, which ends the processes when the track is done;
    ``close()`` (or leaving a ``with`` block) ends them otherwise.
    """

    def __init__(self, rig: Any, *, camera: Any, size: tuple[int, int], samples: int = 0,
                 skin: Any = False, lighting: Any = None, workers: int = 2,
                 hidden: Sequence[str] = ()) -> None:
        import multiprocessing as mp
        from concurrent.futures import ProcessPoolExecutor

        if getattr(mp.current_process(), "_inheriting", False):
            # a spawned process re-running a script that renders at import: stop before
            # making anything (the script's own process then reports the broken pool)
            from mimika.errors import RenderError

            raise RenderError("rendering processes cannot start while a new process starts "
                              "up; start them under 'if __name__ == \"__main__\":'")
        self.workers = max(1, int(workers))
        # llvmpipe threads per worker: the cores shared out; 0 rasterises in the calling
        # thread (cheaper than handing every tile to a single helper thread)
        lp = (os.cpu_count() or 1) // self.workers
        lp = 0 if lp <= 1 else lp
        sweep_semaphores()
        self._setup = _publish((rig, size, samples, skin, lighting, lp, tuple(hidden), camera))
        self.executor = ProcessPoolExecutor(
            self.workers, mp_context=mp.get_context("spawn"), initializer=_init,
            initargs=(self._setup.name, os.getpid()))
        for _ in range(self.workers):  # spawned on demand: one task each starts them all
            self.executor.submit(_ready)

    def stop(self) -> None:
        """End the processes now, dropping what they are drawing."""
        _stop(self.executor)
        self._unpublish()

    def close(self) -> None:
        """End the processes once they are idle."""
        self.executor.shutdown(wait=True, cancel_futures=True)
        self._unpublish()

    def _unpublish(self) -> None:
        with contextlib.suppress(OSError):
            self._setup.close()
            self._setup.unlink()

    def __enter__(self) -> RenderPool:
        return self

    def __exit__(self, *exc: object) -> None:
        if exc[0] is None:
            self.close()
        else:
            self.stop()


def render_track(rig: Any, values: np.ndarray, channels: Sequence[str], *, camera: Any,
                 size: tuple[int, int], samples: int = 0, skin: Any = False,
                 lighting: Any = None, chunk: int = 50, workers: int = 1,
                 hidden: Sequence[str] = (), pool: RenderPool | None = None
                 ) -> Iterator[np.ndarray]:
    """Yield the image (H, W, 3) uint8 of every row of ``values`` (T × channels AU
    intensities) on ``rig``'s head, in order.

    ``workers`` > 1 renders in that many spawned processes (at most ``workers + 1`` chunks of
    ``chunk`` frames in flight); 1 renders here. ``size``, ``samples``, ``skin`` and
    ``lighting`` and ``hidden`` are those of :class:`~mimika.render.Renderer`. A ``pool``
    started earlier for the same head, camera and settings renders instead (its workers
    count); it is closed when the track is done.
    """
    starts = range(0, len(values), chunk)
    if workers <= 1 and pool is None:
        with _open(rig, size, samples, skin, lighting, hidden) as r:
            for i0 in starts:
                yield from _draw(r, rig, values[i0:i0 + chunk], channels, camera)
        return

    from concurrent.futures.process import BrokenProcessPool

    from mimika.errors import RenderError

    if pool is None:
        pool = RenderPool(rig, camera=camera, size=size, samples=samples, skin=skin,
                          lighting=lighting, workers=workers, hidden=hidden)
    pending: deque = deque()
    try:
        for i0 in starts:
            pending.append(pool.executor.submit(_render_chunk, values[i0:i0 + chunk],
                                                list(channels), camera))
            if len(pending) > pool.workers:
                yield from _take(pending.popleft().result())
        while pending:
            yield from _take(pending.popleft().result())
    except BrokenProcessPool as exc:
        pool.stop()
        _discard(pending)
        raise RenderError(
            f"the rendering processes stopped ({exc}); render with workers=1 (--workers 1) "
            "to see the error here, and start them from a script only under "
            "'if __name__ == \"__main__\":'") from None
    except BaseException:  # interrupted, terminated or abandoned: stop the workers now
        pool.stop()
        _discard(pending)
        raise
    pool.close()
