"""``mimika serve`` latency: speak a short sentence over the WebSocket and time the first
frames and the first audio (warm server), per engine; then N clients speaking at once.

``listen`` (lip-sync frames from the agent's own audio, fed in 50 ms chunks):

* latency — audio instant → frame out of ``ListenStream.feed`` (its look-ahead included),
  median and 95th percentile, CPU seconds (thread time) per second of audio; one stream and
  N streams at once in one process, fed in real time;
* real-time factor of N streams — wall time to take N streams' audio as fast as it comes in
  one process (the server's threads), per second of audio (< 1: keeps up);
* on the GRID test split (``_grid.is_test``: never trained on), against the offline
  audio-only result (``recognise`` + ``mouth_track``: frames whose 13 mouth AUs all lie within
  0.05, frames with the same viseme; also per look-ahead) and against the transcript-aligned
  visemes (Oculus-15, per 30 fps frame), and the aligned /p b m/ whose lips close within ± 1
  frame — streamed, offline, and offline with pocketsphinx's phone recogniser (the engine
  before);
* the same agreement on written sentences of the Piper voice and espeak-ng against their
  own phone timing (voices other than GRID's speaker);
* the GRID test split degraded as in ``bench_align_real.py`` (noise at 20/10 dB SNR, −20 dB,
  +12 dB clipped, 0.9×/1.1× speed), offline, against the clean transcript's visemes;
* another speaker and language: the jaw of the recognised mouth against FACEGOOD's
  animation of its Mandarin takes (``$MIMIKA_FACEGOOD_DIR``).

Run: ``.venv/bin/python bench/bench_serve.py [--clients 8] [--part listen|speak]``  (goals,
issue 29: first audio and first frame ≤ 250 ms for a short sentence on 2 cores; listen: frame
≤ 150 ms after its instant, 8 streams in real time on 2 cores, ≥ 95 % of frames as offline,
≥ 70 % visemes as the aligned transcript)
"""

from __future__ import annotations

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
sys.path.insert(0, str(Path(__file__).resolve().parent))

CHUNK = 0.05  #: seconds of audio per listen message
LOOKAHEADS = (0.09, 0.15, 0.2, 0.3, 0.5)
SENTENCES = ("Bob bought a big map, and a blue pub.",
             "Please move the purple bottle beside my lamp.",
             "We might maybe meet by the bay before the rain comes.",
             "Good evening. The city council met on Monday to discuss the new budget.",
             "Thank you for calling; your order will ship on Friday morning.")
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


def stream(audio, sr: int, *, lookahead: float | None = None, clock: float | None = None,
           lat: list[float] | None = None, chunk: float = CHUNK) -> list[dict]:
    """Feed ``audio`` in ``chunk`` s pieces to a ``ListenStream``; its frames. With ``clock``
    (a perf_counter start) each piece waits until it "has been recorded" and each frame's
    latency (ms) goes to ``lat``."""
    from mimika.serve.listen import LOOKAHEAD, ListenStream

    st = ListenStream(sr, lookahead=LOOKAHEAD if lookahead is None else lookahead)
    step = int(chunk * sr)
    out: list[dict] = []
    for i, k in enumerate(range(0, len(audio), step)):
        if clock is not None:
            wait = clock + (i + 1) * chunk - time.perf_counter()
            if wait > 0:
                time.sleep(wait)
        got = st.feed(audio[k:k + step], final=k + step >= len(audio))
        if clock is not None and lat is not None:
            now = time.perf_counter() - clock
            lat += [(now - f["t"]) * 1000 for f in got]
        out += got
    return out


def listen_latency(audio, sr: int, n_streams: int, chunk: float = CHUNK
                   ) -> tuple[float, float, float]:
    """``n_streams`` listen streams fed in real time at once: the median and 95th percentile
    of (frame out − its instant) in ms, and CPU s per s of audio per stream."""
    import numpy as np

    lat: list[float] = []
    cpu: list[float] = []

    def run() -> None:
        c0 = time.thread_time()
        stream(audio, sr, clock=time.perf_counter(), lat=lat, chunk=chunk)
        cpu.append(time.thread_time() - c0)

    ths = [threading.Thread(target=run) for _ in range(n_streams)]
    for th in ths:
        th.start()
    for th in ths:
        th.join()
    return (float(np.median(lat)), float(np.percentile(lat, 95)),
            sum(cpu) / (n_streams * len(audio) / sr))


def listen_server(audio, sr: int, n_streams: int) -> tuple[float, float, float]:
    """``n_streams`` WebSocket clients streaming ``audio`` in real time to a ``mimika serve``
    process: frame latency at the client (median, p95 ms) and the server process's CPU
    seconds per second of audio, all streams together."""
    import base64
    import subprocess

    import numpy as np
    from websockets.sync.client import connect

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    src = str(Path(__file__).resolve().parents[1] / "src")
    proc = subprocess.Popen([sys.executable, "-m", "mimika", "serve", "--port", str(port), "-q"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            env={**os.environ, "PYTHONPATH": src})
    url = f"ws://127.0.0.1:{port}/ws"

    def cpu() -> float:
        f = Path(f"/proc/{proc.pid}/stat").read_text().rsplit(")", 1)[1].split()
        return (int(f[11]) + int(f[12])) / os.sysconf("SC_CLK_TCK")

    try:
        for _ in range(600):
            try:
                with connect(url) as ws:
                    ws.recv()
                    ws.send(json.dumps({"type": "listen", "id": "warm", "sr": sr, "final": True,
                                        "data": base64.b64encode(bytes(3200)).decode()}))
                    while json.loads(ws.recv())["type"] != "end":
                        pass
                break
            except OSError:
                time.sleep(0.1)
        pcm = (np.clip(audio, -1, 1) * 32767).astype("<i2").tobytes()
        step = 2 * int(CHUNK * sr)
        lat: list[float] = []

        def client() -> None:
            with connect(url, max_size=2**24) as ws:
                ws.recv()
                t0 = time.perf_counter()

                def read() -> None:
                    while (m := json.loads(ws.recv()))["type"] != "end":
                        now = time.perf_counter() - t0
                        lat.extend((now - f["t"]) * 1000 for f in m.get("frames", []))

                th = threading.Thread(target=read)
                th.start()
                for i, k in enumerate(range(0, len(pcm), step)):
                    wait = t0 + (i + 1) * CHUNK - time.perf_counter()
                    if wait > 0:
                        time.sleep(wait)
                    ws.send(json.dumps({"type": "listen", "id": 1, "sr": sr,
                                        "final": k + step >= len(pcm),
                                        "data": base64.b64encode(pcm[k:k + step]).decode()}))
                th.join()

        for _ in range(240):  # until its warm-up (voice, head) is done: the process idles
            c0 = cpu()
            time.sleep(0.5)
            if cpu() - c0 < 0.02:
                break
        c0 = cpu()
        ths = [threading.Thread(target=client) for _ in range(n_streams)]
        for th in ths:
            th.start()
        for th in ths:
            th.join()
        used = cpu() - c0
    finally:
        proc.terminate()
        proc.wait(10)
    return (float(np.median(lat)), float(np.percentile(lat, 95)),
            used / (len(audio) / sr))


def listen_rtf(audio, sr: int, n_streams: int) -> float:
    """Wall seconds for ``n_streams`` streams fed as fast as they are taken, in threads of one
    process, per second of audio (< 1: the streams keep up with real time)."""
    ths = [threading.Thread(target=stream, args=(audio, sr)) for _ in range(n_streams)]
    t0 = time.perf_counter()
    for th in ths:
        th.start()
    for th in ths:
        th.join()
    return (time.perf_counter() - t0) / (len(audio) / sr)


class Tally:
    """Per-frame agreement counts of one comparison."""

    def __init__(self) -> None:
        self.n = self.aus = self.vis = 0

    def add(self, a: list[dict], b: list[dict]) -> None:
        from mimika.speech.coarticulation import mouth_aus

        for f, g in zip(a, b, strict=False):
            self.n += 1
            self.aus += max(abs(f.get(c, 0) - g.get(c, 0)) for c in mouth_aus()) <= 0.05
            self.vis += f.get("viseme") == g.get("viseme")

    def pct(self, what: str) -> str:
        return f"{100 * getattr(self, what) / max(self.n, 1):5.1f} %"


def wire(u) -> list[dict]:
    """The 30 fps wire frames of an utterance's mouth (with visemes)."""
    from mimika.serve.frames import frames
    from mimika.serve.speech import FPS
    from mimika.speech.coarticulation import mouth_track
    from mimika.speech.export import viseme_cues

    return frames(mouth_track(u, fps=FPS), cues=viseme_cues(u))


def closed(frames: list[dict], apex: list[float]) -> int:
    """Aligned /p b m/ apexes whose lips close in ``frames`` within ± 1 frame (wire weights
    have 3 decimals: a closure that holds exactly may miss by rounding, hence the tolerance)."""
    from mimika.speech.coarticulation import closure_ok

    return sum(any(closure_ok(frames[j], tol=2e-3) for j in range(max(0, round(t * 30) - 1),
                                                         min(len(frames), round(t * 30) + 2)))
               for t in apex)


def listen_accuracy(items) -> None:
    """``items``: (name, audio, sr, reference Utterance). Prints agreement and closures."""
    from mimika.speech.alignment import recognise
    from mimika.speech.coarticulation import bilabial_apex_times

    off, per_la = Tally(), {la: Tally() for la in LOOKAHEADS}
    ref = {k: Tally() for k in ("stream", "offline", "sphinx")}
    hits = dict.fromkeys(ref, 0)
    n_b = 0
    for _, a, sr, truth in items:
        frames = {"stream": stream(a, sr), "offline": wire(recognise(a, sr=sr)),
                  "sphinx": wire(recognise(a, sr=sr, engine="sphinx"))}
        off.add(frames["stream"], frames["offline"])
        for la in LOOKAHEADS:
            per_la[la].add(stream(a, sr, lookahead=la), frames["offline"])
        truth_frames = wire(truth)
        apex = bilabial_apex_times(truth)
        n_b += len(apex)
        for k, fr in frames.items():
            ref[k].add(fr, truth_frames)
            hits[k] += closed(fr, apex)
    print(f"  streamed vs offline audio-only: {off.pct('aus')} of {off.n} frames with every "
          f"mouth AU within 0.05, {off.pct('vis')} with the same viseme (goal ≥ 95 %)")
    print("  by look-ahead: " + ", ".join(f"{1000 * la:.0f} ms {per_la[la].pct('aus')}"
                                         for la in LOOKAHEADS) + " (AUs within 0.05)")
    print(f"  visemes as the aligned transcript (goal ≥ 70 %): streamed {ref['stream'].pct('vis')}"
          f", offline {ref['offline'].pct('vis')}, offline pocketsphinx "
          f"{ref['sphinx'].pct('vis')}")
    print(f"  /p b m/ closed within ± 1 frame: streamed {hits['stream']}/{n_b}, offline "
          f"{hits['offline']}/{n_b}, offline pocketsphinx {hits['sphinx']}/{n_b}", flush=True)


def grid_items():
    from _grid import grid_dir, ids, is_test, load, references

    d = grid_dir()
    test = [u for u in ids(d) if is_test(u)]
    refs = references(d, test)
    return [(u, *load(d, u), refs[u]) for u in test]


def tts_items():
    from mimika.speech.tts import synthesize

    out = []
    for engine in ("piper", "espeak"):
        for text in SENTENCES:
            u = synthesize(text, engine=engine, rate=150)
            out.append((f"{engine}: {text}", u.audio, u.sr, u))
    return out


def facegood_jaw() -> None:
    """Another speaker and language: FACEGOOD's Mandarin takes (one woman, MIT) with their
    animator-solved jaw (ARKit jawOpen → AU27): Pearson correlation of the recognised mouth's
    jaw (AU26 + AU27) with it per 30 fps frame, each engine, weighted by frames."""
    import numpy as np

    from mimika.learn.facegood import load_facegood
    from mimika.speech.alignment import recognise
    from mimika.speech.audio import read_wav
    from mimika.speech.coarticulation import mouth_track

    d = Path(os.environ.get("MIMIKA_FACEGOOD_DIR", str(Path(__file__).resolve().parents[2] /
                                                           "shared" / "motion" / "facegood")))
    if not (d / "wav").is_dir():
        print("  (no FACEGOOD takes: set MIMIKA_FACEGOOD_DIR)")
        return
    r: dict[str, list[tuple[float, int]]] = {"frames": [], "sphinx": []}
    for take in load_facegood(d):
        a, sr = read_wav(d / "wav" / f"{take.name}.wav")
        ref = take.values[:, take.channels.index("AU27")]
        for eng, out in r.items():
            tr = mouth_track(recognise(a, sr=sr, engine=eng), fps=take.fps)
            n = min(len(ref), tr.n_frames)
            jaw = tr.values[:n, [tr.channels.index("AU26"), tr.channels.index("AU27")]].sum(1)
            out.append((float(np.corrcoef(jaw, ref[:n])[0, 1]), n))
    mean = {k: sum(c * n for c, n in v) / sum(n for _, n in v) for k, v in r.items()}
    print(f"  jaw opening vs FACEGOOD's animation (Mandarin, {len(r['frames'])} takes): "
          f"r = {mean['frames']:.2f} (pocketsphinx {mean['sphinx']:.2f})", flush=True)


def listen_conditions(items, conditions=("noise20", "noise10", "quiet", "loud", "slow",
                                          "fast")) -> None:
    """Offline audio-only lip-sync of degraded GRID test recordings (``bench_align_real``'s
    conditions) against the transcript-aligned visemes of the clean ones, both engines."""
    import numpy as np

    from bench_align_real import degrade
    from mimika.speech import Phone, Utterance
    from mimika.speech.alignment import recognise
    from mimika.speech.coarticulation import bilabial_apex_times

    for cond in conditions:
        rng = np.random.default_rng(0)
        f = {"slow": 0.9, "fast": 1.1}.get(cond, 1.0)
        tally = {"frames": Tally(), "sphinx": Tally()}
        hits = dict.fromkeys(tally, 0)
        n_b = 0
        for _, a, sr, truth in items:
            b, _ = degrade(a, sr, [], cond, rng)
            ref = Utterance(np.zeros(0, np.float32), 16000,
                            [Phone(p.symbol, p.start / f, p.end / f, p.stress)
                             for p in truth.phonemes], lang="en")
            truth_frames, apex = wire(ref), bilabial_apex_times(ref)
            n_b += len(apex)
            for eng, t in tally.items():
                fr = wire(recognise(b, sr=sr, engine=eng))
                t.add(fr, truth_frames)
                hits[eng] += closed(fr, apex)
        print(f"  {cond:8}: visemes as the aligned transcript {tally['frames'].pct('vis')} "
              f"(pocketsphinx {tally['sphinx'].pct('vis')}), /p b m/ closed "
              f"{hits['frames']}/{n_b} ({hits['sphinx']}/{n_b})", flush=True)


def listen(clients: int) -> None:
    from mimika.serve.listen import ListenStream
    from mimika.speech.tts import synthesize

    u = synthesize(LONG, engine="piper")
    print(f"listen: look-ahead {1000 * ListenStream(u.sr).lookahead:.0f} ms; a "
          f"{u.duration:.1f} s Piper recording; load average {os.getloadavg()[0]:.1f} on "
          f"{os.cpu_count()} cores")
    for chunk in (CHUNK, 0.02):
        for n in (1, clients):
            med, p95, cpu = listen_latency(u.audio, u.sr, n, chunk)
            print(f"  {n} stream(s) in {1000 * chunk:.0f} ms chunks in real time: frame latency "
                  f"median {med:.0f} ms, p95 {p95:.0f} ms (goal ≤ 150 ms); {cpu:.3f} s CPU per "
                  f"s of audio per stream", flush=True)
    print(f"  {clients} streams as fast as taken: {listen_rtf(u.audio, u.sr, clients):.3f} s "
          f"wall per s of audio (real-time factor; goal < 1)", flush=True)
    for n in (1, clients):
        med, p95, cpu = listen_server(u.audio, u.sr, n)
        print(f"  {n} WebSocket client(s) → a mimika serve process, 50 ms chunks in real time: "
              f"frame latency median {med:.0f} ms, p95 {p95:.0f} ms; server CPU {cpu:.3f} s per "
              f"s of audio for all ({cpu / 2:.3f} of 2 cores)", flush=True)
    print("GRID test split (speaker s1, utterances never trained on):")
    grid = grid_items()
    listen_accuracy(grid)
    print("… degraded (offline; pocketsphinx in brackets):")
    listen_conditions(grid)
    print("Other voices (written sentences; reference: the synthesiser's phone timing):")
    listen_accuracy(tts_items())
    facegood_jaw()


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--clients", type=int, default=8)
    ap.add_argument("--part", choices=("all", "listen", "speak"), default="all")
    args = ap.parse_args()
    if args.part in ("all", "listen"):
        listen(args.clients)
    if args.part in ("all", "speak"):
        speak_bench(args.clients)


def speak_bench(clients: int) -> None:
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
               for _ in range(clients)]
        t0 = time.perf_counter()
        for th in ths:
            th.start()
        for th in ths:
            th.join()
        wall = time.perf_counter() - t0
        speech = sum(r["duration"] for r in results) / 1000
        print(f"{engine:7} {clients} clients at once: first audio median "
              f"{statistics.median(r['audio'] for r in results):.0f} ms, worst "
              f"{max(r['audio'] for r in results):.0f} ms; {speech:.1f} s of speech in "
              f"{wall:.1f} s ({speech / wall:.1f}× real time in all)")
        srv.should_exit = True
        time.sleep(0.5)


if __name__ == "__main__":
    main()
