"""Shared helpers for the benchmarks: timing with warm-up, printing figures and ratios."""

from __future__ import annotations

import os
import time
from collections.abc import Callable


def single_core() -> None:
    """Pin BLAS to one thread (call before importing numpy)."""
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ[var] = "1"


def rate(fn: Callable[[], object], *, per_call: int = 1, min_time: float = 1.0,
         warmup: int = 2) -> float:
    """Items per second of ``fn`` (each call handles ``per_call`` items), after warm-up."""
    for _ in range(warmup):
        fn()
    n, t0 = 0, time.perf_counter()
    while (elapsed := time.perf_counter() - t0) < min_time:
        fn()
        n += 1
    return n * per_call / elapsed


def report(name: str, value: float, unit: str, target: float | None = None) -> None:
    line = f"{name:<48} {value:10.1f} {unit}"
    if target:
        line += f"   target {target:g} → ratio {value / target:5.2f}x"
    print(line, flush=True)


def ict_available() -> bool:
    d = os.environ.get("MIMIKA_ICT_DIR")
    return bool(d) and os.path.isdir(d)
