"""Newsreader benchmark: the example bulletin → MP4 at 640×480 and 1280×720, for the default
character, the built-in head and ICT — is ``mimika news`` faster than real time?

Per head and size it prints

* the stages in one process (wall and CPU time): deforming, drawing (one rendering process's
  work: the fixed shot, the frame's wrinkles, llvmpipe in the calling thread as each worker
  runs it) and encoding — CPU ms per frame is the steady figure on a shared machine;
* the whole bulletin end to end as ``mimika news`` renders it (one process per core): wall
  time against the audio (× real time, < 1 = faster) and CPU seconds of this process and its
  children. Wall times only mean something on a quiet machine: the load average is printed
  beside them.

    python bench/bench_news.py [--sizes 640x480,1280x720] [--frames N]
                               [--heads amara,builtin,ict] [--no-e2e] [--no-skin]

ICT runs when ``MIMIKA_ICT_DIR`` points at ICT-FaceKit.
"""

from __future__ import annotations

import argparse
import os
import resource
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))
# llvmpipe rasterises in the calling thread, as in each rendering process (render.parallel)
os.environ.setdefault("LP_NUM_THREADS", "0")

import numpy as np

from mimika.face.heads import DEFAULT_HEAD, load_head
from mimika.newsreader import FEATURES, example_bulletin, news_track, parse_article, speak_article
from mimika.newsreader.pipeline import news_camera
from mimika.render.lighting import NEWS as NEWS_LIGHTING
from mimika.render.parallel import _draw, _open
from mimika.render.skin import SkinParams
from mimika.render.video import VideoWriter


def cpu_seconds() -> float:
    """CPU seconds of this process and its finished children (user + system)."""
    return sum(u.ru_utime + u.ru_stime for u in (resource.getrusage(resource.RUSAGE_SELF),
                                                  resource.getrusage(resource.RUSAGE_CHILDREN)))


class Clock:
    """Wall and CPU (this process) time between laps."""

    def __init__(self) -> None:
        self.wall, self.cpu = time.perf_counter(), time.process_time()

    def lap(self) -> tuple[float, float]:
        w, c = time.perf_counter(), time.process_time()
        out = (w - self.wall, c - self.cpu)
        self.wall, self.cpu = w, c
        return out


def load() -> str:
    return f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores"


def bench_stages(name: str, speech: tuple, *, size: tuple[int, int], frames: int,
                 skin: bool) -> float:
    """The stages in this process; returns the drawing's CPU ms per frame."""
    clk = Clock()
    _, rig = load_head(name)
    t_load = clk.lap()
    art, utt, paras = speech
    nt = news_track(art, utterance=utt, paragraph_starts=paras, fps=25.0,
                    supported=rig.supported)
    t_tracks = clk.lap()
    track = nt.track
    n = min(frames, track.n_frames)
    vals = track.values[:n]
    rig.deform_batch(vals[:2], track.channels)  # warm-up
    clk.lap()
    rig.deform_batch(vals, track.channels)
    t_deform = clk.lap()
    cam = news_camera(rig.head, "front", size[0] / size[1])
    chunk = 50  # as render_news: each chunk starts afresh
    with _open(rig, size, 0, SkinParams(refresh=3) if skin else False, NEWS_LIGHTING) as r:
        list(_draw(r, rig, vals[:1], track.channels, cam))  # set-up, shaders compiled
        t_setup = clk.lap()
        imgs = [im for i0 in range(0, n, chunk)
                for im in _draw(r, rig, vals[i0:i0 + chunk], track.channels, cam)]
        t_render = clk.lap()
    t_render = (t_render[0] - t_deform[0], t_render[1] - t_deform[1])  # _draw deforms too
    with tempfile.TemporaryDirectory() as d:
        audio = utt.audio[: round(n / 25.0 * utt.sr)]
        with VideoWriter(Path(d) / "b.mp4", fps=25.0, size=size, audio=audio, sr=utt.sr,
                         threaded=False) as vw:
            for im in imgs:
                vw.write(im)
        t_encode = clk.lap()
    rows = [("tracks (whole bulletin)", t_tracks, track.n_frames),
            ("deform_batch", t_deform, n), ("draw", t_render, n), ("encode", t_encode, n)]
    print(f"\n{name}, {size[0]}x{size[1]}, skin shader {'on' if skin else 'off'}: {n} frames "
          f"in one process; head loaded in {t_load[0]:.2f} s, renderer set up in "
          f"{t_setup[1]:.2f} s CPU")
    print(f"  {'stage':<26}{'wall s':>8}{'cpu s':>8}{'cpu ms/frame':>14}")
    for label, (w, c), k in rows:
        print(f"  {label:<26}{w:8.2f}{c:8.2f}{1000 * c / k:14.1f}")
    per_frame = sum(r[1][1] for r in rows[1:]) / n
    print(f"  deform + draw + encode: {1000 * per_frame:.1f} ms CPU a frame → "
          f"{per_frame * track.n_frames:.1f} s CPU for the bulletin's {track.n_frames} frames "
          f"({utt.duration:.1f} s of audio); {load()}")
    return 1000 * t_render[1] / n


def bench_end_to_end(name: str, *, size: tuple[int, int], skin: bool) -> dict:
    """The bulletin as ``mimika news`` renders it."""
    from mimika.newsreader import render_news

    layers = set(FEATURES) - (set() if skin else {"skin"})
    load0 = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as d:
        c0, t0 = cpu_seconds(), time.perf_counter()
        r = render_news(example_bulletin("en"), out=Path(d) / "news.mp4", head=name,
                        size=size, layers=layers)
        wall, cpu = time.perf_counter() - t0, cpu_seconds() - c0
    tm = r.timings
    print(f"  end to end (as mimika news, {tm['workers']} rendering processes): "
          f"{r.n_frames} frames, {r.duration:.1f} s of audio")
    print(f"    wall {wall:.1f} s = {wall / r.duration:.2f} × real time; CPU {cpu:.1f} s "
          f"({1000 * cpu / r.n_frames:.1f} ms a frame, all processes) = "
          f"{cpu / r.duration / (os.cpu_count() or 1):.2f} × real time on "
          f"{os.cpu_count()} idle cores; load average {load0:.1f} → {os.getloadavg()[0]:.1f}")
    return {"wall": wall, "cpu": cpu, "duration": r.duration, "frames": r.n_frames,
            "load": max(load0, os.getloadavg()[0])}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="640x480,1280x720")
    ap.add_argument("--frames", type=int, default=150, help="frames drawn in one process")
    ap.add_argument("--heads", default=f"{DEFAULT_HEAD},builtin,ict")
    ap.add_argument("--no-skin", action="store_true")
    ap.add_argument("--no-e2e", action="store_true", help="skip the end-to-end runs")
    a = ap.parse_args()
    sizes = [tuple(int(x) for x in s.split("x")) for s in a.sizes.split(",")]
    np.seterr(all="ignore")
    art = parse_article(example_bulletin("en"))
    clk = Clock()
    utt, paras = speak_article(art, lang="en")
    w, c = clk.lap()
    print(f"speech (whole bulletin, {utt.duration:.1f} s): {w:.2f} s wall, {c:.2f} s CPU")
    summary = []
    for name in a.heads.split(","):
        if name == "ict" and not os.environ.get("MIMIKA_ICT_DIR"):
            print("\nict: skipped (set MIMIKA_ICT_DIR=/work/shared/ict-facekit)")
            continue
        for size in sizes:
            ms = bench_stages(name, (art, utt, paras), size=size, frames=a.frames,
                              skin=not a.no_skin)
            e2e = None if a.no_e2e else bench_end_to_end(name, size=size, skin=not a.no_skin)
            summary.append((name, size, ms, e2e))
    print(f"\n{'head':<10}{'size':>10}{'draw ms/frame':>15}{'e2e CPU s':>11}"
          f"{'CPU ms/frame':>14}{'e2e wall s':>12}{'× real time':>13}{'load':>6}")
    for name, (w, h), ms, e in summary:
        tail = "" if e is None else (
            f"{e['cpu']:11.1f}{1000 * e['cpu'] / e['frames']:14.1f}{e['wall']:12.1f}"
            f"{e['wall'] / e['duration']:13.2f}{e['load']:6.1f}")
        print(f"{name:<10}{f'{w}x{h}':>10}{ms:15.1f}{tail}")


if __name__ == "__main__":
    main()
