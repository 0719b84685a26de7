"""Newsreader benchmark: a ~30-second bulletin → MP4, per stage, for the default character, the
built-in head and ICT.

Prints frames/s of every stage in one process (wall and CPU time: on a shared machine the CPU
seconds are the steadier figure), then renders the whole bulletin end to end as ``mimika news``
does (rendering spread over one process per core) and prints its wall time against the audio
duration (ratio < 1 = faster than real time). ICT runs when ``MIMIKA_ICT_DIR`` points at
ICT-FaceKit.

    python bench/bench_news.py [--size 640x480] [--frames N] [--heads amara,builtin,ict] [--no-e2e]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

import numpy as np

from mimika.face.heads import load_head
from mimika.newsreader import example_bulletin, news_track, parse_article, speak_article
from mimika.newsreader.pipeline import news_camera
from mimika.render import Renderer
from mimika.render.lighting import NEWS as NEWS_LIGHTING
from mimika.render.skin import SkinParams
from mimika.render.video import VideoWriter


class Clock:
    def __init__(self) -> None:
        self.wall, self.cpu = time.perf_counter(), time.process_time()

    def lap(self) -> tuple[float, float]:
        w, c = time.perf_counter(), time.process_time()
        out = (w - self.wall, c - self.cpu)
        self.wall, self.cpu = w, c
        return out


def bench_head(name: str, *, size: tuple[int, int], frames: int | None, skin: bool) -> None:
    clk = Clock()
    _, rig = load_head(name)
    t_load = clk.lap()
    art = parse_article(example_bulletin("en"))
    utt, paras = speak_article(art, lang="en")
    t_tts = clk.lap()
    nt = news_track(art, utterance=utt, paragraph_starts=paras, fps=25.0,
                    supported=rig.supported)
    t_tracks = clk.lap()
    track = nt.track
    n = track.n_frames if frames is None else min(frames, track.n_frames)
    vals = track.values[:n]
    pos = rig.deform_batch(vals[:2], track.channels)  # warm-up
    clk.lap()
    pos = rig.deform_batch(vals, track.channels)
    t_deform = clk.lap()
    cam = news_camera(rig.head, "front", size[0] / size[1])
    imgs = []
    skin_params = SkinParams(refresh=3) if skin else False  # as the newsreader renders video
    with Renderer(rig.head, size=size, samples=0, skin_shader=skin_params,
                  lighting=NEWS_LIGHTING) as r:
        r.render({k: v[0] for k, v in pos.items()}, camera=cam)  # warm-up (compiles shaders)
        clk.lap()
        for i in range(n):
            imgs.append(r.render({k: v[i] for k, v in pos.items()}, camera=cam))
        t_render = clk.lap()
    with tempfile.TemporaryDirectory() as d:
        audio = utt.audio[: round(n / 25.0 * utt.sr)]
        with VideoWriter(Path(d) / "b.mp4", fps=25.0, size=size, audio=audio, sr=utt.sr,
                         threaded=False) as vw:
            for im in imgs:
                vw.write(im)
        t_encode = clk.lap()
    audio_s = n / 25.0
    rows = [("tts (whole bulletin)", t_tts, track.n_frames), ("tracks", t_tracks,
            track.n_frames), ("deform_batch", t_deform, n), ("render", t_render, n),
            ("encode", t_encode, n)]
    print(f"\n{name} head, {size[0]}x{size[1]}, skin shader {'on' if skin else 'off'}, "
          f"{n} frames ({audio_s:.1f} s of {utt.duration:.1f} s audio); load {t_load[0]:.2f} s")
    print(f"  {'stage':<22}{'wall s':>9}{'cpu s':>9}{'fps wall':>10}{'fps cpu':>10}")
    for label, (w, c), k in rows:
        print(f"  {label:<22}{w:9.2f}{c:9.2f}{k / max(w, 1e-9):10.1f}{k / max(c, 1e-9):10.1f}")
    per_frame_w = sum(r[1][0] for r in rows[2:]) / n
    per_frame_c = sum(r[1][1] for r in rows[2:]) / n
    total_w = t_tts[0] + t_tracks[0] + per_frame_w * track.n_frames
    total_c = t_tts[1] + t_tracks[1] + per_frame_c * track.n_frames
    print(f"  one process, extrapolated to the bulletin ({utt.duration:.1f} s audio): wall "
          f"{total_w:.1f} s (ratio {total_w / utt.duration:.2f}), cpu {total_c:.1f} s")
    print(f"  load average now: {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")


def bench_end_to_end(name: str, *, size: tuple[int, int], skin: bool) -> None:
    from mimika.newsreader import FEATURES, render_news

    layers = set(FEATURES) - (set() if skin else {"skin"})
    with tempfile.TemporaryDirectory() as d:
        t0 = time.perf_counter()
        r = render_news(example_bulletin("en"), out=Path(d) / "news.mp4", head=name,
                        size=size, layers=layers)
        wall = time.perf_counter() - t0
    tm = r.timings
    print(f"  end to end (as mimika news, {tm['workers']} rendering process(es)): "
          f"{r.n_frames} frames in {wall:.1f} s for {r.duration:.1f} s of audio = ratio "
          f"{wall / r.duration:.2f} ({r.n_frames / wall:.1f} frames/s; waiting for frames "
          f"{tm['render']:.1f} s, encoder thread "
          f"{tm['encode']:.1f} s)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", default="640x480")
    ap.add_argument("--frames", type=int, default=150, help="frames to render (0: all)")
    ap.add_argument("--heads", default="amara,builtin,ict")
    ap.add_argument("--no-skin", action="store_true")
    ap.add_argument("--no-e2e", action="store_true", help="skip the end-to-end run")
    a = ap.parse_args()
    size = tuple(int(x) for x in a.size.split("x"))
    np.seterr(all="ignore")
    for h in a.heads.split(","):
        if h == "ict" and not os.environ.get("MIMIKA_ICT_DIR"):
            print("\nict: skipped (set MIMIKA_ICT_DIR=/work/shared/ict-facekit)")
            continue
        bench_head(h, size=size, frames=a.frames or None, skin=not a.no_skin)
        if not a.no_e2e:
            bench_end_to_end(h, size=size, skin=not a.no_skin)


if __name__ == "__main__":
    main()
