"""Encoding benchmark: what turning rendered news frames into H.264 costs, per setting.

Renders ``--frames`` frames of the example bulletin (default character, 1280×720, as ``mimika
news`` draws them), then times in this process, one thread, CPU ms per frame:

* RGB → YUV 4:2:0 (swscale) with its default filter and with point-sampled chroma, and how
  close each comes back to the image (PSNR of RGB → YUV → RGB);
* libx264 at crf 23 with CAVLC: the ``veryfast`` preset as it is, and with the cheaper
  sub-pixel and partition search that :class:`mimika.render.video.VideoWriter` uses — bytes
  per frame and PSNR against the frames (whole frame and the face).

    python bench/bench_encode.py [--frames 150] [--head amara]
"""

from __future__ import annotations

import argparse
import io
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))
os.environ.setdefault("LP_NUM_THREADS", "0")

import av
import numpy as np

from mimika.face.heads import load_head
from mimika.newsreader import example_bulletin, news_track, parse_article, speak_article
from mimika.newsreader.pipeline import news_camera
from mimika.render.lighting import NEWS
from mimika.render.parallel import _draw, _open
from mimika.render.skin import SkinParams

SIZE = (1280, 720)


def frames(head: str, n: int) -> list[np.ndarray]:
    art = parse_article(example_bulletin("en"))
    utt, paras = speak_article(art, lang="en")
    _, rig = load_head(head)
    track = news_track(art, utterance=utt, paragraph_starts=paras, fps=25.0,
                       supported=rig.supported).track
    cam = news_camera(rig.head, "front", SIZE[0] / SIZE[1])
    vals = track.values[100:100 + n]
    with _open(rig, SIZE, 0, SkinParams(refresh=3), NEWS) as r:
        return [im for i in range(0, len(vals), 25)
                for im in _draw(r, rig, vals[i:i + 25], track.channels, cam)]


def psnr(a: list[np.ndarray], b: list[np.ndarray], box: tuple[slice, slice] | None = None
         ) -> float:
    box = box or (slice(None), slice(None))
    mse = np.mean([np.mean((x[box].astype(np.float64) - y[box]) ** 2)
                   for x, y in zip(a, b, strict=True)])
    return float(10 * np.log10(255.0 ** 2 / max(mse, 1e-12)))


def cpu_ms(fn, n: int, reps: int = 3) -> float:
    best = np.inf
    for _ in range(reps):
        t = time.process_time()
        fn()
        best = min(best, time.process_time() - t)
    return 1000 * best / n


def to_yuv(imgs: list[np.ndarray], interpolation: str | None) -> list[av.VideoFrame]:
    return [av.VideoFrame.from_ndarray(im, format="rgb24").reformat(
        format="yuv420p", interpolation=interpolation) for im in imgs]


def encode(yuv: list[av.VideoFrame], params: str) -> bytes:
    buf = io.BytesIO()
    with av.open(buf, mode="w", format="mp4") as out:
        s = out.add_stream("libx264", rate=25)
        s.width, s.height = SIZE
        s.pix_fmt = "yuv420p"
        s.options = {"crf": "23", "preset": "veryfast", "threads": "1", "x264-params": params}
        for i, f in enumerate(yuv):
            f.pts = i
            out.mux(s.encode(f))
        out.mux(s.encode())
    return buf.getvalue()


def decode(data: bytes) -> list[np.ndarray]:
    with av.open(io.BytesIO(data)) as c:
        return [f.to_ndarray(format="rgb24") for f in c.decode(video=0)]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=150)
    ap.add_argument("--head", default="amara")
    a = ap.parse_args()
    imgs = frames(a.head, a.frames)
    n = len(imgs)
    face = (slice(150, 450), slice(500, 780))
    print(f"{n} news frames of {a.head}, {SIZE[0]}x{SIZE[1]}; CPU ms per frame, one thread\n")
    print(f"{'RGB -> YUV 4:2:0':<34}{'ms':>7}{'PSNR dB':>9}")
    for interp in (None, "POINT"):
        ms = cpu_ms(lambda i=interp: to_yuv(imgs, i), n)
        back = [f.to_ndarray(format="rgb24") for f in to_yuv(imgs, interp)]
        print(f"  {interp or 'default (bilinear)':<32}{ms:7.2f}{psnr(back, imgs):9.2f}")
    yuv = to_yuv(imgs, "POINT")
    print(f"\n{'libx264 veryfast, crf 23':<42}{'ms':>7}{'kB/frame':>10}{'PSNR':>7}{'face':>7}")
    base = None
    for label, params in (("CAVLC", "cabac=0"),
                          ("CAVLC, subme=1, partitions=none (used)",
                           "cabac=0:subme=1:partitions=none")):
        ms = cpu_ms(lambda p=params: encode(yuv, p), n)
        data = encode(yuv, params)
        out = decode(data)
        base = base or ms
        print(f"  {label:<40}{ms:7.2f}{len(data) / n / 1000:10.2f}{psnr(out, imgs):7.2f}"
              f"{psnr(out, imgs, face):7.2f}   {ms / base:.2f}x")


if __name__ == "__main__":
    main()
