"""Character paint: first paint and cached load per preset, texture sizes on disk.

    PYTHONPATH=src python bench/bench_paint.py [PRESET ...]

For each preset the geometry is built first (not timed); then every piece is painted into an
empty cache (first paint: CPU and wall seconds per piece kind), and painted again from the warm
cache (cached load). Prints the cache's size per texture kind.
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _common import report


def main(names: list[str]) -> None:
    from mimika.face.makehuman.build import Outfit, build
    from mimika.face.makehuman.character_file import load_character_spec, preset_names
    from mimika.face.makehuman.paint import parts_of

    for name in names or preset_names():
        c = load_character_spec(name)
        built = build(c.phenotype_values(),
                      Outfit(c.hair, c.eyebrows, c.eyelashes, c.clothes))
        with tempfile.TemporaryDirectory() as tmp:
            os.environ["MIMIKA_CACHE_DIR"] = tmp
            cpu = defaultdict(float)
            w0, c0 = time.perf_counter(), time.process_time()
            for p in built.pieces:
                t = time.process_time()
                parts_of(p, c)
                cpu[p.name.rstrip("0123456789")] += time.process_time() - t
            first_wall, first_cpu = time.perf_counter() - w0, time.process_time() - c0
            w0 = time.perf_counter()
            for p in built.pieces:
                parts_of(p, c)
            cached = time.perf_counter() - w0
            files = list((Path(tmp) / "paint").glob("*.png"))
            size = defaultdict(int)
            for f in files:
                size[f.name.split("-")[0]] += f.stat().st_size
        print(f"== {name}")
        report("first paint, CPU", first_cpu, "s")
        report("first paint, wall", first_wall, "s")
        for k, v in sorted(cpu.items(), key=lambda kv: -kv[1]):
            if v > 0.05:
                report(f"  {k}, CPU", v, "s")
        report("cached load (all pieces), wall", cached, "s")
        report("cache on disk", sum(size.values()) / 2**20, "MiB")
        for k, v in sorted(size.items(), key=lambda kv: -kv[1]):
            report(f"  {k}", v / 2**20, "MiB")


if __name__ == "__main__":
    main(sys.argv[1:])
