"""Batch rendering throughput: images/s of one spec with 1 and 2 Dask worker processes.

The same 64-item spec (16 AU sets × 2 intensities × 2 views at 320×240) is rendered on a local
cluster of 1, then 2 worker processes. Each cluster is started and every worker warmed up (head
loaded, GL context made, one frame drawn) before the clock starts, so the figures are steady-state
throughput including PNG encoding, transfer to the client and atomic writes. Run:

    .venv/bin/python bench/bench_batch.py [--items 64] [--size 320x240]
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import report


def spec_for(n_items: int, size: str):
    from mimika.batch import parse_spec
    from mimika.facs import SEED_AUS

    face = [a for a in SEED_AUS if int(a[2:]) < 50]
    n_sets = max(1, n_items // 4)
    sets = [[face[i % len(face)], face[(3 * i + 1) % len(face)]] if i >= len(face)
            else [face[i]] for i in range(n_sets)]
    return parse_spec({"aus": sets, "intensities": [0.5, 1.0], "views": ["front", "three-quarter"],
                       "size": size})


def throughput(plan, workers: int, lp_threads: int | None = None) -> tuple[float, float]:
    """(images/s steady state, seconds to start and warm the cluster)."""
    from dask.distributed import Client, LocalCluster

    from mimika.batch.run import run_batch
    from mimika.batch.worker import warm

    t0 = time.perf_counter()
    cores = os.cpu_count() or 1
    # as `mimika batch` does: llvmpipe threads = cores / workers (unless fixed)
    env = {"LP_NUM_THREADS": str(lp_threads or max(1, cores // workers)), "OMP_NUM_THREADS": "1"}
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                      dashboard_address=":0", silence_logs=logging.ERROR, env=env) as cluster, \
            Client(cluster) as client:
        s = plan.spec
        client.run(warm, s.heads[0], None, list(s.size), s.samples)
        startup = time.perf_counter() - t0
        with tempfile.TemporaryDirectory() as d:
            r = run_batch(plan, d, client=client)
        assert r.rendered == len(plan) and not r.failed, r.errors
        return r.images_per_s, startup


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--items", type=int, default=64)
    ap.add_argument("--size", default="320x240")
    ap.add_argument("--lp-threads", type=int, help="llvmpipe threads per worker (default: "
                    "cores / workers, as mimika batch sets them)")
    args = ap.parse_args()
    from mimika.batch import make_plan

    plan = make_plan(spec_for(args.items, args.size))
    load = os.getloadavg()[0]
    print(f"{len(plan)} items at {args.size}, {os.cpu_count()} CPU cores, load average "
          f"{load:.1f}", flush=True)
    rates = {}
    for n in (1, 2):
        rates[n], startup = throughput(plan, n, args.lp_threads)
        report(f"batch {args.size}, {n} worker process(es)", rates[n], "images/s")
        report(f"  cluster start + warm-up, {n} worker(s)", startup, "s")
    print(f"scaling 2 workers / 1 worker: {rates[2] / rates[1]:.2f}x")


if __name__ == "__main__":
    main()
