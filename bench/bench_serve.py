"""``mimika serve`` latency: speak a short sentence over the WebSocket and time the first
frames and the first audio (warm server), per engine; then N clients speaking at once.

Run: ``.venv/bin/python bench/bench_serve.py [--clients 8]``  (goal, issue 29: first audio and
first frame ≤ 250 ms for a short sentence on 2 cores)
"""

import argparse
import json
import os
import socket
import statistics
import sys
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

SHORT = "Here is the news."
LONG = ("Good evening. The city council met on Monday to discuss the new budget for public "
        "transport. Buses will run more often.")


def serve():
    import uvicorn

    from mimika.serve.app import create_app

    app = create_app(head="builtin", warm_up=True)
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    srv = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=port, log_level="warning"))
    threading.Thread(target=srv.run, daemon=True).start()
    while not srv.started:
        time.sleep(0.05)
    return srv, f"ws://127.0.0.1:{port}/ws"


def speak(url: str, text: str) -> dict[str, float]:
    from websockets.sync.client import connect

    with connect(url, max_size=2**24) as ws:
        json.loads(ws.recv())
        t0 = time.perf_counter()
        ws.send(json.dumps({"type": "speak", "id": 1, "text": text}))
        out: dict[str, float] = {}
        while True:
            m = json.loads(ws.recv())
            dt = (time.perf_counter() - t0) * 1000
            if m["type"] == "frames" and "frames" not in out:
                out["frames"] = dt
            if m["type"] == "audio" and "audio" not in out:
                out["audio"] = dt
            if m["type"] in ("end", "error"):
                out["end"] = dt
                out["duration"] = m.get("duration", 0.0) * 1000
                return out


def listen_latency(audio, sr: int, n_streams: int) -> tuple[float, float, float]:
    """``n_streams`` listen streams fed in real time (50 ms chunks) at once: the median and
    95th percentile of (frame received − its instant) in ms, and CPU s per s of audio."""
    import numpy as np

    from mimika.serve.listen import ListenStream

    lat: list[float] = []
    cpu: list[float] = []

    def run() -> None:
        st = ListenStream(sr)
        step = int(0.05 * sr)
        t_start = time.perf_counter()
        c0 = time.thread_time()
        for i, k in enumerate(range(0, len(audio), step)):
            wait = t_start + (i + 1) * 0.05 - time.perf_counter()
            if wait > 0:
                time.sleep(wait)  # the chunk has been "recorded"
            for f in st.feed(audio[k:k + step], final=k + step >= len(audio)):
                lat.append((time.perf_counter() - t_start - f["t"]) * 1000)
        cpu.append(time.thread_time() - c0)

    ths = [threading.Thread(target=run) for _ in range(n_streams)]
    for th in ths:
        th.start()
    for th in ths:
        th.join()
    return (float(np.median(lat)), float(np.percentile(lat, 95)),
            sum(cpu) / (n_streams * len(audio) / sr))


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--clients", type=int, default=8)
    args = ap.parse_args()
    from mimika.speech.tts import synthesize

    u = synthesize(LONG, engine="piper")
    for n in (1, args.clients):
        med, p95, cpu = listen_latency(u.audio, u.sr, n)
        print(f"listen  {n} stream(s) in real time: frame latency median {med:.0f} ms, p95 "
              f"{p95:.0f} ms (goal ≤ 150 ms); {cpu:.2f} s CPU per s of audio per stream")
    for engine in ("piper", "espeak"):
        os.environ["MIMIKA_TTS"] = engine
        srv, url = serve()
        speak(url, "Warming up.")
        runs = [speak(url, SHORT) for _ in range(5)]
        fr = statistics.median(r["frames"] for r in runs)
        au = statistics.median(r["audio"] for r in runs)
        print(f"{engine:7} {SHORT!r}: first frames {fr:6.0f} ms, first audio {au:6.0f} ms "
              f"(median of 5; goal ≤ 250 ms → ratio {max(fr, au) / 250:.2f})")
        results: list[dict[str, float]] = []
        ths = [threading.Thread(target=lambda r=results, u=url: r.append(speak(u, LONG)))
               for _ in range(args.clients)]
        t0 = time.perf_counter()
        for th in ths:
            th.start()
        for th in ths:
            th.join()
        wall = time.perf_counter() - t0
        speech = sum(r["duration"] for r in results) / 1000
        print(f"{engine:7} {args.clients} clients at once: first audio median "
              f"{statistics.median(r['audio'] for r in results):.0f} ms, worst "
              f"{max(r['audio'] for r in results):.0f} ms; {speech:.1f} s of speech in "
              f"{wall:.1f} s ({speech / wall:.1f}× real time in all)")
        srv.should_exit = True
        time.sleep(0.5)


if __name__ == "__main__":
    main()
