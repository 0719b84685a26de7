"""The release fuzz run (issues 20, 27): ≥ 100 000 cases over script, project, batch spec,
expression library, every CSV reader, character files and recordings; goal 0 crashes and
0 hangs. Prints the process's peak resident memory after each target.

The cases are those of ``tests/fuzzing.py`` (which CI samples through hypothesis), made from
seeds 0, 1, 2, … so that any failure is reproduced by its target and seed.

Run: ``make fuzz`` or
``.venv/bin/python bench/fuzz.py [--cases 100000] [--target csv] [--seed 1234]``
"""

from __future__ import annotations

import argparse
import logging
import os
import random
import resource
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent.parent / "tests"))
from fuzzing import HANG_SECONDS, TARGETS, WALL_SECONDS, check


def _peak_mb() -> float:
    """Peak resident memory of this process so far (MB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=100_000, help="cases in all (100 000)")
    ap.add_argument("--target", choices=list(TARGETS), action="append",
                    help="only these targets (repeatable)")
    ap.add_argument("--seed", type=int, help="run this one seed (of each --target) and show it")
    args = ap.parse_args()
    os.environ["MIMIKA_DATA_DIR"] = tempfile.mkdtemp(prefix="mimika-fuzz-home-")
    logging.disable(logging.WARNING)  # readers log what they repair
    names = args.target or list(TARGETS)
    if args.seed is not None:
        for name in names:
            gen, run = TARGETS[name]
            case = gen(random.Random(args.seed))
            print(f"{name} seed {args.seed}: {case!r:.2000}\n  → {check(run, case) or 'ok'}")
        return 0
    per = -(-args.cases // len(names))
    total = crashes = hangs = 0
    t_all = time.perf_counter()
    print(f"fuzzing {per * len(names)} cases ({per} per target), a case over "
          f"{HANG_SECONDS:g} s of CPU or {WALL_SECONDS:g} s is a hang", flush=True)
    for name in names:
        gen, run = TARGETS[name]
        seen: dict[str, int] = {}
        t0 = time.perf_counter()
        for seed in range(per):
            broke = check(run, gen(random.Random(seed)))
            if broke is not None:
                key = broke[:80]
                if key not in seen:
                    print(f"  {name} seed {seed}: {broke}  (rerun: bench/fuzz.py "
                          f"--target '{name}' --seed {seed})", flush=True)
                seen[key] = seen.get(key, 0) + 1
                hangs += broke.startswith("hang")
                crashes += not broke.startswith("hang")
        dt = time.perf_counter() - t0
        total += per
        print(f"{name:<12} {per:8d} cases in {dt:7.1f} s ({per / dt:6.0f}/s), "
              f"{sum(seen.values())} failed ({len(seen)} distinct), peak RSS so far "
              f"{_peak_mb():.0f} MB", flush=True)
    dt = time.perf_counter() - t_all
    print(f"total        {total:8d} cases in {dt:7.1f} s: {crashes} crashes, {hangs} hangs, "
          f"peak RSS {_peak_mb():.0f} MB")
    return 1 if crashes or hangs else 0


if __name__ == "__main__":
    raise SystemExit(main())
