"""Render long AU animations in several processes (one OpenGL context each).

A software rasteriser (Mesa's llvmpipe) leaves cores idle while one thread processes vertices,
and moderngl holds the GIL during every GL call, so threads cannot fill that gap; processes
can. :func:`render_track` deals fixed-size chunks of AU frames to a pool of spawned workers,
each holding a copy of the rig, which deform and draw them; the images come back in order.
Each chunk starts afresh (:meth:`~mimika.render.Renderer.invalidate`), so the images are the
same whatever the number of workers. A :class:`RenderPool` started early sets its workers up
(occlusion, textures, shaders) while the caller is still busy, e.g. with speech. The workers
draw a chunk's frames straight into a shared memory block (``/dev/shm/mimika-frames-*``) that
the main process hands out without copying and reuses once its frames are dropped
(:class:`_Ring`); pickled through a pipe they cost the main process 6 ms of CPU per 1280×720
frame, copied into fresh memory about 4 ms.
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
          camera: Any, out: np.ndarray | None = None) -> Iterator[np.ndarray]:
    """The chunk's images in order (into ``out[i]`` when given). The chunk is deformed on one
    BLAS thread, as in the workers: a product summed in another order moves a vertex by 1e-6
    cm, which can change a pixel, and a video must not depend on how many processes drew it."""
    from threadpoolctl import threadpool_limits

    renderer.invalidate()
    with threadpool_limits(1, user_api="blas"):
        pos = rig.deform_batch(values, channels)
    for i in range(len(values)):
        yield renderer.render({n: p[i] for n, p in pos.items()}, camera=camera,
                              aus=dict(zip(channels, values[i].tolist(), strict=True)),
                              out=None if out is None else out[i])


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


@contextlib.contextmanager
def _env(**values: str) -> Iterator[None]:
    """Environment variables set for the processes spawned inside the block."""
    old = {k: os.environ.get(k) for k in values}
    os.environ.update(values)
    try:
        yield
    finally:
        for k, v in old.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def _ready() -> None:
    """A task that does nothing: submitting one per worker starts the processes."""


def _render_chunk(values: np.ndarray, channels: Sequence[str], camera: Any, block: str
                  ) -> tuple[int, ...]:
    """Draw a chunk straight into the shared memory block ``block`` (of the main process's
    :class:`_Ring`, mapped here once); the frames' shape goes back."""
    w = _worker
    width, height = w["renderer"].size
    shape = (len(values), height, width, 3)
    blocks = w.setdefault("blocks", {})
    if block not in blocks:
        blocks[block] = _map(block)
    out = np.ndarray(shape, np.uint8, buffer=blocks[block])
    for _ in _draw(w["renderer"], w["rig"], values, channels, camera, out):
        pass
    return shape


def _map(name: str, size: int | None = None) -> Any:
    """A shared memory block mapped (made with ``size`` bytes when given). Plain mmap, not
    ``multiprocessing.shared_memory``: a block stays mapped while frames of it are in use,
    and nothing registers it with the resource tracker."""
    import mmap

    path = os.path.join("/dev/shm", name)
    fd = os.open(path, os.O_RDWR | (0 if size is None else os.O_CREAT | os.O_EXCL), 0o600)
    try:
        if size is not None:
            os.ftruncate(fd, max(size, 1))  # (an empty file cannot be mapped)
        return mmap.mmap(fd, os.fstat(fd).st_size, flags=mmap.MAP_SHARED)
    finally:
        os.close(fd)


class _Lease:
    """The frames of one chunk in a ring block; the block is free again once no frame of
    it is referenced (numpy arrays over it keep this object alive)."""

    def __init__(self, mm: Any, shape: tuple[int, ...]) -> None:
        import ctypes

        self.mm = mm
        addr = ctypes.addressof(ctypes.c_char.from_buffer(mm))
        self.__array_interface__ = {"shape": shape, "typestr": "|u1", "data": (addr, False),
                                    "version": 3}


class _Ring:
    """Shared memory blocks that carry chunks of frames from the workers (who draw into
    them) to the main process (which hands the frames out without copying them), reused
    once their frames are dropped: fresh memory for every chunk cost about 4 ms of CPU per
    1280×720 frame in page faults. Named ``mimika-frames-<main>-<main>-ring<n>``, so the
    blocks of a killed main process are swept."""

    def __init__(self) -> None:
        self.blocks: dict[str, Any] = {}
        self.free: list[str] = []
        self.closed = False
        self.lock = threading.Lock()  # frames may be dropped in another thread (an encoder)

    def take(self, size: int) -> str:
        """A free block of at least ``size`` bytes, made if none is free."""
        with self.lock:
            for name in self.free:
                if len(self.blocks[name]) >= size:
                    self.free.remove(name)
                    return name
        name = f"{FRAMES}{os.getpid()}-{os.getpid()}-ring{next(_serial)}"
        self.blocks[name] = _map(name, size)
        return name

    def lease(self, name: str, shape: tuple[int, ...]) -> np.ndarray:
        """The frames a worker drew into ``name``; the block returns to the free list when
        the last of them is dropped."""
        import weakref

        lease = _Lease(self.blocks[name], shape)
        weakref.finalize(lease, self._release, name)
        return np.asarray(lease)

    def _release(self, name: str) -> None:
        with self.lock:
            if not self.closed:
                self.free.append(name)

    def close(self) -> None:
        """Remove the blocks' names (their memory goes with the last frame in use)."""
        with self.lock:
            self.closed = True
        for name in self.blocks:
            with contextlib.suppress(OSError):
                os.unlink(os.path.join("/dev/shm", name))
        self.blocks.clear()
        self.free.clear()


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
        if p.is_alive():  # still setting up after SIGTERM: killed, and reaped (a loaded
            with contextlib.suppress(Exception):  # machine may take seconds to end it)
                p.kill()
            with contextlib.suppress(Exception):
                p.join(10.0)


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
        # one BLAS thread per worker: idle OpenBLAS threads spin, taking a core from drawing
        with _env(OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1"):
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

    ``workers`` > 1 renders in that many spawned processes (at most ``workers + 2`` chunks of
    ``chunk`` frames in flight); 1 renders here. ``size``, ``samples``, ``skin`` and
    ``lighting`` and ``hidden`` are those of :class:`~mimika.render.Renderer`. A ``pool``
    started earlier for the same head, camera and settings renders instead (its workers
    count); it is closed when the track is done. Frames drawn by workers are views of shared
    memory, held (not copied) as long as they are referenced.
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
    ring = _Ring()
    frame_bytes = size[0] * size[1] * 3
    pending: deque = deque()
    try:
        for i0 in starts:
            block = ring.take(frame_bytes * len(values[i0:i0 + chunk]))
            pending.append((block, pool.executor.submit(
                _render_chunk, values[i0:i0 + chunk], list(channels), camera, block)))
            if len(pending) > pool.workers + 1:
                block, fut = pending.popleft()
                yield from ring.lease(block, fut.result())
        while pending:
            block, fut = pending.popleft()
            yield from ring.lease(block, fut.result())
    except BrokenProcessPool as exc:
        pool.stop()
        raise RenderError(
            f"the rendering processes stopped ({exc}); render with workers=1 (--workers 1) "
            "to see the error here, and start them from a script only under "
            "'if __name__ == \"__main__\":'") from None
    except BaseException:  # interrupted, terminated or abandoned: stop the workers now
        pool.stop()
        raise
    finally:
        ring.close()
    pool.close()
