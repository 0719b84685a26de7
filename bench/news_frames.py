"""Frames of a newsreader video as a contact sheet (the README's and docs' news picture).

Each tile is labelled with its time and the subtitle being spoken then (from the video's
``.srt`` when there is one). The sheet is quantised to 256 colours to keep the PNG small.

    mimika news --example en -o out/news.mp4
    python bench/news_frames.py out/news.mp4 -o docs/img/news_frames.png [--times 3,12,21,30]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

import av
import numpy as np
from PIL import Image

from mimika.newsreader import parse_srt
from mimika.render.sheet import contact_sheet


def grab(video: Path, times: list[float], width: int) -> list[np.ndarray]:
    """The first frame at or after each of ``times`` (seconds), scaled to ``width``."""
    out: list[np.ndarray] = []
    with av.open(str(video)) as c:
        want = iter(sorted(times))
        t = next(want, None)
        for f in c.decode(video=0):
            if t is None:
                break
            if f.time is not None and f.time >= t:
                img = f.to_image()
                out.append(np.asarray(img.resize((width, img.height * width // img.width),
                                                 Image.Resampling.LANCZOS)))
                t = next(want, None)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("video", type=Path)
    ap.add_argument("-o", "--out", type=Path, default=Path("docs/img/news_frames.png"))
    ap.add_argument("--times", default="3,12,21,30", help="seconds, comma-separated")
    ap.add_argument("--width", type=int, default=320, help="tile width in pixels")
    ap.add_argument("--columns", type=int, default=2)
    a = ap.parse_args()
    times = sorted(float(x) for x in a.times.split(","))
    frames = grab(a.video, times, a.width)
    srt = a.video.with_suffix(".srt")
    cues = parse_srt(srt.read_text("utf-8")) if srt.exists() else []
    labels = []
    for t in times[:len(frames)]:
        said = next((c.text for c in cues if c.start <= t <= c.end), "")
        labels.append(f"{t:.0f} s  {said}".strip())
    sheet = Image.fromarray(contact_sheet(frames, labels, columns=a.columns))
    # dithered: undithered, the skin and the studio's gradients broke into bands
    sheet = sheet.quantize(256, method=Image.Quantize.MEDIANCUT,
                           dither=Image.Dither.FLOYDSTEINBERG)
    a.out.parent.mkdir(parents=True, exist_ok=True)
    sheet.save(a.out, optimize=True)
    print(f"wrote {a.out} ({len(frames)} frames, {a.out.stat().st_size // 1024} kB)")


if __name__ == "__main__":
    main()
