"""Studio exports as jobs: bounded in time, cancellable, and in two lanes so that one long
export never holds up the short ones.

Every export runs in a worker thread as a :class:`Job`. The work calls :meth:`Job.check`
between stages and once per rendered frame; it raises when the job was cancelled (``DELETE
/api/export/jobs/{id}``, or the client went away) or ran past ``max_export_seconds``
(:mod:`mimika.limits`). Exports of up to :data:`SMALL_FRAMES` frames run in the *small*
lane, longer ones in the *large* lane (``max_exports`` at once); a request that finds its lane
full waits up to :data:`WAIT` seconds, then gets 503.
"""

from __future__ import annotations

import asyncio
import re
import threading
import time
import uuid
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from fastapi import HTTPException
from starlette.concurrency import run_in_threadpool

from mimika import limits
from mimika.errors import MimikaError

#: exports of at most this many frames (an MP4 frame counts as 50) use the small lane
SMALL_FRAMES = 3000
#: exports the small lane runs at once
SMALL_SLOTS = 2
#: seconds a request waits for a free slot before 503
WAIT = 10.0
#: weight of one MP4 frame against one CSV/glTF frame
MP4_WEIGHT = 50
_JOB_ID = re.compile(r"^[A-Za-z0-9_\-]{1,40}$")


class Cancelled(MimikaError):
    """The export was cancelled (by request or because the client went away)."""


@dataclass
class Job:
    """One running export; ``check`` is its cancellation point (also a progress callback)."""

    id: str
    kind: str
    name: str
    frames: int
    lane: str
    deadline: float
    started: float = field(default_factory=time.monotonic)
    done_frames: int = 0
    reason: str | None = None
    _cancel: threading.Event = field(default_factory=threading.Event, repr=False)

    def cancel(self, reason: str) -> None:
        if not self._cancel.is_set():
            self.reason = reason
            self._cancel.set()

    @property
    def cancelled(self) -> bool:
        return self._cancel.is_set()

    def error(self) -> MimikaError:
        if self.reason == "timeout":
            return limits.over("max_export_seconds", f"the {self.kind} export ran "
                                                     f"{time.monotonic() - self.started:.0f} s")
        return Cancelled(f"the {self.kind} export {self.id!r} was cancelled ({self.reason})")

    def check(self, done: int | None = None, total: int | None = None) -> None:
        """Raise if cancelled or past the deadline; ``done`` counts rendered frames."""
        if done is not None:
            self.done_frames = done
        if not self.cancelled and time.monotonic() > self.deadline:
            self.cancel("timeout")
        if self.cancelled:
            raise self.error()

    def info(self) -> dict[str, Any]:
        return {"id": self.id, "kind": self.kind, "name": self.name, "frames": self.frames,
                "lane": self.lane, "seconds": round(time.monotonic() - self.started, 2),
                "done_frames": self.done_frames, "cancelled": self.cancelled}


class Jobs:
    """The running exports of one studio."""

    def __init__(self, *, large_slots: int | None = None):
        n = large_slots or limits.current().max_exports
        self._lanes = {"small": threading.BoundedSemaphore(SMALL_SLOTS),
                       "large": threading.BoundedSemaphore(n)}
        self._jobs: dict[str, Job] = {}
        self._lock = threading.Lock()

    def list(self) -> list[dict[str, Any]]:
        with self._lock:
            return [j.info() for j in self._jobs.values()]

    def cancel(self, job_id: str, reason: str = "cancelled by request") -> bool:
        with self._lock:
            job = self._jobs.get(job_id)
        if job is not None:
            job.cancel(reason)
        return job is not None

    def cancel_all(self, reason: str) -> None:
        with self._lock:
            jobs = list(self._jobs.values())
        for j in jobs:
            j.cancel(reason)

    async def run(self, request: Any, work: Callable[[Job], bytes], *, kind: str, name: str,
                  frames: int, job_id: str | None = None) -> bytes:
        """Run ``work(job)`` in a thread as a job; return its bytes or raise its error."""
        if job_id is not None and not _JOB_ID.match(job_id):
            raise HTTPException(422, "job: 1–40 letters, digits, '-' or '_'")
        jid = job_id or uuid.uuid4().hex[:12]
        with self._lock:
            if jid in self._jobs:
                raise HTTPException(409, f"an export {jid!r} is already running")
        lane = "small" if frames <= SMALL_FRAMES else "large"
        sem = self._lanes[lane]
        waited = time.monotonic()
        while not sem.acquire(blocking=False):
            if time.monotonic() - waited > WAIT:
                raise HTTPException(503, f"the studio is busy with other {lane} exports; try "
                                         "again in a moment", headers={"Retry-After": "10"})
            await asyncio.sleep(0.05)
        lim = limits.current()
        job = Job(jid, kind, name, frames, lane, time.monotonic() + lim.max_export_seconds)
        with self._lock:
            self._jobs[jid] = job

        def target() -> bytes:
            try:
                job.check()
                return work(job)
            finally:
                with self._lock:
                    self._jobs.pop(jid, None)
                sem.release()

        task = asyncio.ensure_future(run_in_threadpool(target))
        task.add_done_callback(lambda t: t.cancelled() or t.exception())  # retrieved
        while True:
            done, _ = await asyncio.wait({task}, timeout=0.2)
            if done:
                return task.result()
            if not job.cancelled and time.monotonic() > job.deadline:
                job.cancel("timeout")
            if not job.cancelled and await request.is_disconnected():
                job.cancel("the client went away")
            if job.cancelled:  # answer now; the thread stops at its next check
                raise job.error()
