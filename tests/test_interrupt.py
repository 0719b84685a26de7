"""Killed or interrupted renders leave no processes and no temporary files (issue 20, item 5):
``mimika news`` rendering in worker processes is stopped with SIGTERM or SIGKILL halfway."""

from __future__ import annotations

import glob
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import mimika

pytestmark = [pytest.mark.render, pytest.mark.slow]

ARTICLE = ("Good evening. Here is the news. The council met today to discuss the new bridge, "
           "and after a long debate it voted to build it next spring.\n\n") * 3


def _session(sid: int) -> list[str]:
    """Live processes of session ``sid`` (the command and everything it started)."""
    out = []
    for d in glob.glob("/proc/[0-9]*"):
        try:
            fields = Path(d, "stat").read_text().rsplit(")", 1)[1].split()
            cmd = Path(d, "cmdline").read_bytes().replace(b"\0", b" ").decode()[:90]
        except (OSError, IndexError):
            continue
        if int(fields[3]) == sid and fields[0] != "Z":
            out.append(f"{d[6:]} {cmd}")
    return out


def _wait(cond, within: float, what: str) -> None:
    t0 = time.time()
    while not cond():
        if time.time() - t0 > within:
            pytest.fail(what)
        time.sleep(0.1)


def _semaphores() -> set[str]:
    """multiprocessing's named semaphores (the pool's queues and locks) in /dev/shm."""
    return set(glob.glob("/dev/shm/sem.mp-*"))


def _render_then(sig: int, tmp_path: Path, group: bool = False) -> tuple[subprocess.Popen, Path]:
    from mimika.render.context import egl_available

    if not egl_available():
        pytest.skip("needs headless OpenGL (Mesa EGL)")
    art = tmp_path / "article.txt"
    art.write_text(ARTICLE)
    out = tmp_path / "news.mp4"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(Path(mimika.__file__).parents[1]), os.environ.get("PYTHONPATH", "")]))
    p = subprocess.Popen([sys.executable, "-m", "mimika", "news", str(art), "-o", str(out),
                          "--head", "builtin", "--workers", "2", "--size", "160x120", "-q"],
                         env=env, start_new_session=True, stderr=subprocess.PIPE, text=True)
    # rendering: the temporary video exists and both workers are up
    _wait(lambda: (glob.glob(str(tmp_path / ".news.mp4.*")) and len(_session(p.pid)) >= 4)
          or p.poll() is not None, 240, "the render did not start")
    assert p.poll() is None, p.stderr.read()
    time.sleep(1.0)
    p.semaphores = _semaphores()  # type: ignore[attr-defined]
    (os.killpg if group else os.kill)(p.pid, sig)
    p.wait(60)
    return p, out


def test_sigterm_stops_workers_and_removes_the_temporary_video(tmp_path):
    p, out = _render_then(signal.SIGTERM, tmp_path)
    assert p.returncode == 128 + signal.SIGTERM
    assert "stopped by signal 15" in p.stderr.read()
    _wait(lambda: not _session(p.pid), 10, f"left running: {_session(p.pid)}")
    assert not list(tmp_path.glob(".news.mp4.*")) and not out.exists()
    assert not p.semaphores & _semaphores()  # released: none left in /dev/shm


def test_sigkill_orphans_exit_and_the_next_start_sweeps_the_temporary_video(tmp_path):
    p, out = _render_then(signal.SIGKILL, tmp_path)
    assert p.returncode == -signal.SIGKILL
    _wait(lambda: not _session(p.pid), 10, f"left running: {_session(p.pid)}")
    left = list(tmp_path.glob(".news.mp4.*"))
    assert left  # a killed process cannot clean up …
    from mimika.render.video import VideoWriter

    VideoWriter(out, fps=25, size=(32, 32), threaded=False).abort()  # … the next start does
    assert not any(p.exists() for p in left) and not out.exists()
    # the pool's semaphores: its resource tracker outlives the command and releases them
    _wait(lambda: not p.semaphores & _semaphores(), 10, "semaphores left in /dev/shm")


def test_a_process_group_killed_outright_leaves_semaphores_that_the_next_render_sweeps(tmp_path):
    from mimika.render.parallel import sweep_semaphores

    p, _ = _render_then(signal.SIGKILL, tmp_path, group=True)
    _wait(lambda: not _session(p.pid), 10, f"left running: {_session(p.pid)}")
    leaked = p.semaphores & _semaphores()
    if not leaked:
        pytest.skip("this Python released the semaphores itself")
    assert sweep_semaphores() >= len(leaked)  # what a render with workers runs first
    assert not leaked & _semaphores()
