"""Load test of mimika studio on loopback: N concurrent clients for S seconds.

A mix of AU Blender calls, timeline sampling, speech (HTTP and the live WebSocket), the head
GLB and pose glTF exports (the default head: a MakeHuman character, a 23 MB GLB) against a
studio server in a subprocess. Prints p50/p95/p99 latency and 503 answers per kind and exits 1
on any server error (5xx, dropped connection).

    python bench/bench_studio_load.py [--clients 50] [--seconds 60]
"""

from __future__ import annotations

import argparse
import asyncio
import json
import random
import socket
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

import httpx
import websockets

SERVER = """
import sys, uvicorn
from mimika.studio.app import create_app
app = create_app(sys.argv[1], library_path=sys.argv[2], warm_up=True)
uvicorn.run(app, host="127.0.0.1", port=int(sys.argv[3]), log_level="error",
            ws_max_size=2 * 1024 * 1024)
"""
SENTENCES = ["Good evening.", "Here is the news.", "The weather stays mild tonight.",
             "Markets closed higher.", "Thank you for watching.", "And now, sport.",
             "Rain is expected tomorrow morning.", "The minister spoke to reporters."]
# kind → weight
MIX = {"blend": 42, "sample": 14, "speak": 14, "live": 6, "head_glb": 10, "gltf_pose": 2,
       "expressions": 12}


def project(i: int) -> dict:
    return {"format": "mimika-project", "version": 1, "settings": {"head": "builtin"},
            "timeline": {"speech": {"attrs": [], "tokens": [{"text": SENTENCES[i % 8]}]},
                         "channels": [{"name": "face", "events": [
                             {"kind": "expression", "start": 0.1 * (i % 5), "duration": 1.0,
                              "name": random.choice(["happiness", "surprise", "sadness"])}]}]}}


async def one(kind: str, c: httpx.AsyncClient, base: str, etag: list[str]) -> int:
    rnd = random.random
    if kind == "blend":
        r = await c.post("/api/blend", json={"aus": {"AU12": rnd(), "AU15": rnd(), "AU06": rnd(),
                                                     "AU20": rnd()}})
    elif kind == "sample":
        r = await c.post("/api/timeline/sample", json={"project": project(random.randrange(99))})
    elif kind == "speak":
        r = await c.post("/api/speak", json={"text": random.choice(SENTENCES),
                                             "project": project(random.randrange(99))})
    elif kind == "head_glb":
        h = {"If-None-Match": etag[0]} if etag and rnd() < 0.7 else {}
        r = await c.get("/api/head.glb", headers=h)
        if r.status_code == 200:
            etag[:] = [r.headers["etag"]]
        return r.status_code
    elif kind == "gltf_pose":
        r = await c.post("/api/export/gltf", json={"aus": {"AU12": rnd(), "AU26": rnd()}})
    elif kind == "expressions":
        r = await c.get("/api/expressions")
    else:  # live
        async with websockets.connect(base.replace("http", "ws") + "/api/live",
                                      max_size=None) as ws:
            await ws.send(json.dumps({"type": "speak", "id": 1, "text": " ".join(
                random.sample(SENTENCES, 2))}))
            while True:
                m = await ws.recv()
                if isinstance(m, str):
                    t = json.loads(m)["type"]
                    if t == "done":
                        return 200
                    if t == "error":
                        return 500
    return r.status_code


async def client(base: str, until: float, stats, errors, etag, busy) -> None:
    kinds, weights = list(MIX), list(MIX.values())
    async with httpx.AsyncClient(base_url=base, timeout=60) as c:
        while time.perf_counter() < until:
            kind = random.choices(kinds, weights)[0]
            t = time.perf_counter()
            try:
                status = await asyncio.wait_for(one(kind, c, base, etag),
                                                120 if kind == "gltf_pose" else 30)
            except (httpx.HTTPError, websockets.WebSocketException, OSError,
                    TimeoutError) as e:
                errors.append(f"{kind}: {type(e).__name__}: {e}")
                continue
            stats[kind].append((time.perf_counter() - t) * 1000)
            busy[kind] += status == 503
            if status >= 500 or status not in (200, 201, 304):
                errors.append(f"{kind}: HTTP {status}")


def pct(xs: list[float], q: float) -> float:
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(q * len(xs)))] if xs else float("nan")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--clients", type=int, default=50)
    ap.add_argument("--seconds", type=float, default=60.0)
    a = ap.parse_args()
    if not (1 <= a.clients <= 200 and 1 <= a.seconds <= 300):
        ap.error("--clients must be 1…200 and --seconds 1…300")
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    tmp = Path(tempfile.mkdtemp(prefix="mimika-load-"))
    proc = subprocess.Popen([sys.executable, "-c", SERVER, str(tmp / "projects"),
                             str(tmp / "expr.json"), str(port)])
    base = f"http://127.0.0.1:{port}"
    try:
        for _ in range(300):
            try:
                if httpx.get(base + "/api/status", timeout=1).status_code == 200:
                    break
            except httpx.HTTPError:
                time.sleep(0.1)
        httpx.get(base + "/api/head.glb", timeout=60)  # warm up: head + GLB
        stats: dict[str, list[float]] = defaultdict(list)
        errors: list[str] = []
        etag: list[str] = []
        busy: dict[str, int] = defaultdict(int)
        until = time.perf_counter() + a.seconds

        async def run() -> None:
            await asyncio.gather(*(client(base, until, stats, errors, etag, busy)
                                   for _ in range(a.clients)))

        t0 = time.perf_counter()
        asyncio.run(run())
        wall = time.perf_counter() - t0
    finally:
        proc.terminate()
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()
    total = sum(len(v) for v in stats.values())
    print(f"studio load: {a.clients} clients, {wall:.1f} s, {total} requests "
          f"({total / wall:.1f}/s), {len(errors)} errors")
    print(f"{'kind':<12} {'n':>6} {'p50 ms':>9} {'p95 ms':>9} {'p99 ms':>9} {'503':>5}")
    for k in [*MIX, "all"]:
        v = stats.get(k, []) if k != "all" else [x for v in stats.values() for x in v]
        n503 = busy[k] if k != "all" else sum(busy.values())
        print(f"{k:<12} {len(v):>6} {pct(v, 0.5):>9.1f} {pct(v, 0.95):>9.1f} "
              f"{pct(v, 0.99):>9.1f} {n503:>5}")
    for e in errors[:10]:
        print("error:", e)
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
