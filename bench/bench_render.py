"""Render frames/s at 640×480 on the CPU (Mesa llvmpipe) — targets: built-in ≥ 60, ICT ≥ 30,
the default character (whole person, textured, hair blended) ≥ 25; what the lights cost
(``studio`` with soft shadows and occlusion, the wrinkles of the frame's AUs, against ``flat``);
and the character's load time (first build, then from the cache).

Run: ``MIMIKA_ICT_DIR=../shared/ict-facekit .venv/bin/python bench/bench_render.py``
Times a full frame: AU → vertices, normals, upload, draw with 4× MSAA, read back to RGB.
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
import numpy as np

from _common import ict_available, rate, report
from mimika.face.heads import load_head
from mimika.render import Renderer


def bench(name: str, target: float) -> None:
    head, rig = load_head(name)
    t = np.linspace(0, 1, 50)
    aus = [{"AU12": float(x), "AU25": float(x) / 2, "AU51": float(x) / 3}
           for x in 0.5 - 0.5 * np.cos(2 * np.pi * t)]
    frames = [rig.deform(a) for a in aus]
    print(f"{name}: {head.n_triangles} triangles")
    for samples, light in ((4, "studio"), (0, "studio"), (0, "flat")):
        with Renderer(head, size=(640, 480), samples=samples, lighting=light) as r:
            it = iter(range(10**9))

            def frame(r=r, it=it) -> None:
                i = next(it) % 50
                r.render(frames[i], aus=aus[i])

            fps = rate(frame, min_time=2.0)
        report(f"  {name} render 640x480 samples={samples} {light}", fps, "frames/s", target)


def bench_character_load() -> None:
    import os
    import tempfile
    import time

    from mimika.face.heads import DEFAULT_HEAD
    from mimika.face.heads import character as ch

    with tempfile.TemporaryDirectory() as tmp:
        os.environ["MIMIKA_CACHE_DIR"] = tmp
        for label in ("first load (build)", "second load (cache)"):
            ch._LOADED.clear()
            t0 = time.perf_counter()
            load_head(DEFAULT_HEAD)
            report(f"  {DEFAULT_HEAD} {label}", time.perf_counter() - t0, "s")
    del os.environ["MIMIKA_CACHE_DIR"]


if __name__ == "__main__":
    from mimika.face.heads import DEFAULT_HEAD

    bench_character_load()
    bench(DEFAULT_HEAD, 25)
    bench("builtin", 60)
    if ict_available():
        bench("ict", 30)
    else:
        print("ict: skipped (set MIMIKA_ICT_DIR)")
