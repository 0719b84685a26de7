"""AU → vertices frames/s on one core (issue 2 target: ≥ 2 000 frames/s on the ICT head).

Run: ``MIMIKA_ICT_DIR=../shared/ict-facekit .venv/bin/python bench/bench_rig.py``
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _common import ict_available, rate, report, single_core

single_core()

import numpy as np

from mimika.face.heads import load_head


def bench(name: str) -> None:
    head, rig = load_head(name)
    chans = [c for c in rig.supported_bilateral if c[2] < "5"]  # the face AUs
    rng = np.random.default_rng(0)
    values = rng.uniform(0, 1, (1000, len(chans))).astype(np.float32)
    frames = [dict(zip(chans, row.tolist(), strict=True)) for row in values[:50]]
    it = iter(range(10**9))
    one = rate(lambda: rig.deform(frames[next(it) % 50]))
    batch = rate(lambda: rig.deform_batch(values, chans), per_call=len(values))
    print(f"{name}: {head.n_vertices} vertices, {len(chans)} face AU channels")
    report(f"  {name} deform() one frame at a time", one, "frames/s", 2000)
    report(f"  {name} deform_batch() 1000 frames", batch, "frames/s", 2000)


if __name__ == "__main__":
    bench("builtin")
    if ict_available():
        bench("ict")
    else:
        print("ict: skipped (set MIMIKA_ICT_DIR)")
