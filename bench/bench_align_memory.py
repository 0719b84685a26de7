"""Peak memory and accuracy of ``mimika align`` on long recordings (GRID utterances end to end).

Builds a recording of each duration by concatenating GRID utterances
(``$MIMIKA_SPEECH_DIR``: ``wav/ID.wav`` and ``align/ID.align``; one sentence per utterance in
the transcript), runs ``mimika align`` on it in a child process per engine and prints its peak
resident memory (``wait4``'s ``ru_maxrss``), wall time and word-boundary accuracy against the
corpus' own word times (median error, share within 50 ms). A child over ``--cap-mb`` is killed
and reported as such, so an unbounded version can be measured without taking the machine down.

    .venv/bin/python bench/bench_align_memory.py [--durations 60,240,480,900,1800]
        [--engines auto,dtw] [--cap-mb 8000] [--src DIR] [--rate 48000]

``--src`` runs another source tree (e.g. an older version unpacked with ``git archive``).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from mimika.speech.audio import read_wav, resample, write_wav
from mimika.speech.utterance import Utterance

_GRID = Path("shared", "speech", "grid-s1-dev")
DEFAULT_DIR = next((p / _GRID for p in ROOT.parents if (p / _GRID).is_dir()), _GRID)


def build(d: Path, seconds: float, out: Path, rate: int | None = None
          ) -> list[tuple[float, float]]:
    """Write ``out.wav`` (at ``rate`` Hz, default GRID's own) and ``out.txt`` (GRID utterances
    end to end, as many as fit in ``seconds``); return the true (start, end) of every word."""
    ids = sorted(p.stem for p in (d / "wav").glob("*.wav"))
    parts, sents, truth, t, k, sr = [], [], [], 0.0, 0, 16000
    while True:
        i = ids[k % len(ids)]
        k += 1
        a, sr = read_wav(d / "wav" / f"{i}.wav")
        if parts and t + len(a) / sr > seconds:
            break
        words = []
        for line in (d / "align" / f"{i}.align").read_text().split("\n"):
            if line.strip():
                s, e, w = line.split()
                if w not in ("sil", "sp"):
                    words.append(w)
                    truth.append((t + int(s) / 25000, t + int(e) / 25000))
        parts.append(a)
        sents.append(" ".join(words) + ".")
        t += len(a) / sr
    audio = np.concatenate(parts)
    if rate and rate != sr:
        audio, sr = resample(audio, orig_sr=sr, target_sr=rate), rate
    write_wav(out.with_suffix(".wav"), audio, sr=sr)
    out.with_suffix(".txt").write_text(" ".join(sents) + "\n")
    return truth


def _rss_mb(pid: int) -> float:
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    except OSError:
        pass
    return 0.0


def run(cmd: list[str], env: dict, cap_mb: float, timeout: float) -> tuple[float, float, str]:
    """(peak RSS in MB, wall seconds, status) of ``cmd``, killed over ``cap_mb`` or
    ``timeout``."""
    t0 = time.perf_counter()
    state = {"peak": 0.0, "why": ""}
    done = threading.Event()
    with tempfile.TemporaryFile() as errf:
        p = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=errf)

        def watch() -> None:  # polls /proc only: the child is reaped by wait4 below
            while not done.is_set():
                rss = _rss_mb(p.pid)
                state["peak"] = max(state["peak"], rss)
                if rss > cap_mb or time.perf_counter() - t0 > timeout:
                    state["why"] = f"killed over {cap_mb:.0f} MB" if rss > cap_mb else "timeout"
                    p.kill()
                time.sleep(0.05)

        w = threading.Thread(target=watch, daemon=True)
        w.start()
        _, status, usage = os.wait4(p.pid, 0)
        done.set()
        p.returncode = os.waitstatus_to_exitcode(status)
        w.join()
        errf.seek(0)
        err = errf.read().decode(errors="replace").strip()
    peak = max(state["peak"], usage.ru_maxrss / 1024)
    why = state["why"] or ("ok" if p.returncode == 0 else f"exit {p.returncode}: {err[-200:]}")
    return peak, time.perf_counter() - t0, why


def accuracy(timing: Path, truth: list[tuple[float, float]]) -> tuple[float, float]:
    """(median boundary error in ms, share of boundaries within 50 ms) of the aligned words."""
    u = Utterance.load_timing(timing)
    if len(u.words) != len(truth):
        return float("nan"), float("nan")
    err = np.abs(np.array([(w.start, w.end) for w in u.words]) - np.array(truth)).ravel()
    return float(np.median(err) * 1000), float(np.mean(err <= 0.05) * 100)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--dir", default=os.environ.get("MIMIKA_SPEECH_DIR", str(DEFAULT_DIR)))
    ap.add_argument("--durations", default="60,240,480,900,1800",
                    help="recording lengths in seconds")
    ap.add_argument("--engines", default="auto,dtw")
    ap.add_argument("--cap-mb", type=float, default=8000, help="kill a run above this RSS")
    ap.add_argument("--timeout", type=float, default=1800, help="kill a run after this (s)")
    ap.add_argument("--src", default=str(ROOT / "src"), help="source tree to run")
    ap.add_argument("--rate", type=int, help="write the recordings at this rate (Hz)")
    args = ap.parse_args()
    d = Path(args.dir)
    if not (d / "wav").is_dir():
        raise SystemExit(f"no GRID data in {d} (set MIMIKA_SPEECH_DIR)")
    env = dict(os.environ, PYTHONPATH=args.src, OPENBLAS_NUM_THREADS="1",
               OMP_NUM_THREADS="1")
    print(f"source {args.src}; GRID utterances from {d}" +
          (f", written at {args.rate} Hz" if args.rate else ""))
    print(f"{'seconds':>8} {'engine':<6} {'peak MB':>8} {'MB/min':>7} {'wall s':>7} "
          f"{'median ms':>9} {'≤50ms':>6}  status")
    with tempfile.TemporaryDirectory() as tmp:
        for secs in (float(s) for s in args.durations.split(",")):
            base = Path(tmp, f"rec{secs:g}")
            truth = build(d, secs, base, args.rate)
            a, sr = read_wav(base.with_suffix(".wav"))
            dur = len(a) / sr
            del a
            for eng in args.engines.split(","):
                out = base.with_name(f"{base.name}-{eng}.json")
                cmd = [sys.executable, "-m", "mimika", "align", str(base.with_suffix(".wav")),
                       "--transcript-file", str(base.with_suffix(".txt")), "--engine", eng,
                       "-o", str(out), "-q"]
                peak, wall, why = run(cmd, env, args.cap_mb, args.timeout)
                med, within = accuracy(out, truth) if why == "ok" else (float("nan"),) * 2
                print(f"{dur:8.0f} {eng:<6} {peak:8.0f} {peak / dur * 60:7.1f} {wall:7.1f} "
                      f"{med:9.1f} {within:6.1f}  {why}", flush=True)


if __name__ == "__main__":
    main()
