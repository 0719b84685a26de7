"""Alignment on real speech: mimika's engines and pocketsphinx side by side (GRID corpus).

Data: ``$MIMIKA_SPEECH_DIR`` (default ``../shared/speech/grid-s1-dev``): ``wav/ID.wav`` and
``align/ID.align`` (word times in 1/25 000 s; ``sil``/``sp`` are silence). For every utterance
and condition it aligns the transcript and prints, per engine:

* word-boundary error (start and end of every word): median, p90, share within 50 ms;
* /p b m/ closures inside the true word: the apex of every bilabial phone lies inside the
  reference interval of the word it belongs to;
* warm compute in seconds per second of audio.

Engines: ``pocketsphinx`` (its word segmentation as is, the baseline), ``auto`` (what
``align`` does for English: mimika's pocketsphinx engine — written-word pronunciations, silence
between words, edge refinement — falling back to DTW when pocketsphinx fails), ``sphinx``
(that engine without the fallback), ``dtw`` (mimika's language-independent engine).
Conditions degrade the real recordings: ``clean``, ``edge`` (0–2 s of silence added at both
ends, plus low noise), ``noise20``/``noise10`` (white noise at 20/10 dB SNR), ``quiet``/
``loud`` (−20 dB / +12 dB with clipping), ``slow``/``fast`` (resampled to 0.9×/1.1× speed:
pitch and formants move too), ``pause`` (0.4 s silence inserted after the second word).

    .venv/bin/python bench/bench_align_real.py [--n 200] [--conditions clean,edge,…]
        [--engines pocketsphinx,auto,dtw] [--audio-only]
"""

from __future__ import annotations

import argparse
import functools
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import single_core

single_core()
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from mimika.speech.alignment import align
from mimika.speech.audio import read_wav, resample
from mimika.speech.coarticulation import bilabial_apex_times

_GRID = Path("shared", "speech", "grid-s1-dev")
DEFAULT_DIR = next((p / _GRID for p in Path(__file__).resolve().parents if (p / _GRID).is_dir()),
                   _GRID)
FALLBACKS: dict[str, int] = {}  #: alignments where ``auto`` fell back to DTW
CONDITIONS = ("clean", "edge", "noise20", "noise10", "quiet", "loud", "slow", "fast", "pause")


def load_truth(path: Path) -> list[tuple[str, float, float]]:
    out = []
    for line in path.read_text().split("\n"):
        if line.strip():
            s, e, w = line.split()
            if w not in ("sil", "sp"):
                out.append((w, int(s) / 25000, int(e) / 25000))
    return out


def degrade(a: np.ndarray, sr: int, truth, cond: str, rng: np.random.Generator):
    """The degraded recording and the reference word times that go with it."""
    rms = float(np.sqrt(np.mean(a ** 2)))
    if cond == "clean":
        return a, truth
    if cond == "edge":
        pre, post = rng.uniform(0, 2, 2)
        b = np.concatenate([np.zeros(round(pre * sr)), a, np.zeros(round(post * sr))])
        b = b + rng.normal(0, rms * 0.003, len(b))
        return b.astype(np.float32), [(w, s + pre, e + pre) for w, s, e in truth]
    if cond.startswith("noise"):
        snr = float(cond[5:])
        speech = np.sqrt(np.mean(a[np.abs(a) > 0.02 * np.abs(a).max()] ** 2))
        return (a + rng.normal(0, speech / 10 ** (snr / 20), len(a))).astype(np.float32), truth
    if cond == "quiet":
        return (a * 0.1).astype(np.float32), truth
    if cond == "loud":
        return np.clip(a * 4.0, -1, 1).astype(np.float32), truth
    if cond in ("slow", "fast"):
        f = 0.9 if cond == "slow" else 1.1
        b = resample(a, orig_sr=round(sr * f), target_sr=sr)
        return b, [(w, s / f, e / f) for w, s, e in truth]
    if cond == "pause":
        t = truth[1][2]
        k = round(t * sr)
        b = np.concatenate([a[:k], np.zeros(round(0.4 * sr), np.float32) +
                            rng.normal(0, rms * 0.003, round(0.4 * sr)).astype(np.float32),
                            a[k:]])
        return b.astype(np.float32), [(w, s + (0.4 if s >= t - 1e-9 else 0.0),
                                       e + (0.4 if e > t + 1e-9 else 0.0))
                                      for w, s, e in truth]
    raise SystemExit(f"unknown condition {cond!r}")


@functools.cache
def _baseline_decoder():
    import pocketsphinx

    return pocketsphinx.Decoder(samprate=16000, loglevel="FATAL")


def pocketsphinx_words(a: np.ndarray, sr: int, words: list[str]):
    """pocketsphinx 5.1.1 out of the box: word segmentation of its forced alignment."""
    from mimika.speech import sphinx

    dec = _baseline_decoder()
    pcm = sphinx._pcm(a, sr)
    dec.set_align_text(" ".join(words))
    sphinx._decode(dec, pcm)
    return [(s.word, s.start_frame / 100, (s.end_frame + 1) / 100) for s in dec.seg() or []
            if not s.word.startswith(("<", "[", "+"))]  # no segmentation: alignment failed


def run_engine(engine: str, a, sr, truth):
    """(word (start, end) list, bilabial apex times with their word index)."""
    text = " ".join(w for w, _, _ in truth)
    if engine == "pocketsphinx":
        ws = pocketsphinx_words(a, sr, [w for w, _, _ in truth])
        return [(s, e) for _, s, e in ws], []
    u = align(a, sr=sr, transcript=text, lang="en", engine=engine)
    if engine == "auto" and u.meta["engine"] == "dtw":
        FALLBACKS[engine] = FALLBACKS.get(engine, 0) + 1
    spans = [(w.start, w.end) for w in u.words]
    apex = []
    for t in bilabial_apex_times(u):
        k = next((i for i, w in enumerate(u.words) if w.start - 1e-6 <= t <= w.end + 1e-6), -1)
        apex.append((t, k))
    return spans, apex


def audio_only(data, fps: float = 25.0) -> None:
    """Lip-sync without a transcript against the transcript-aligned result: viseme agreement
    per frame (Oculus-15) and the share of aligned /p b m/ whose lips also close (within one
    frame) in the recognised track."""
    from mimika.speech.alignment import recognise
    from mimika.speech.coarticulation import closure_ok, mouth_track
    from mimika.speech.export import viseme_cues

    def frames(u, n):
        out = np.empty(n, object)
        for c in viseme_cues(u, format="oculus"):
            out[int(np.ceil(c["start"] * fps - 1e-9)):int(np.ceil(c["end"] * fps - 1e-9))] = \
                c["value"]
        return out

    agree = total = hit = n_b = 0
    secs = audio_s = 0.0
    for _i, a, truth, sr in data:
        ref = align(a, sr=sr, transcript=" ".join(w for w, _, _ in truth), lang="en")
        t0 = time.perf_counter()
        rec = recognise(a, sr=sr)
        tr = mouth_track(rec, fps=fps)
        secs += time.perf_counter() - t0
        audio_s += len(a) / sr
        n = tr.n_frames
        fa, fb = frames(ref, n), frames(rec, n)
        agree += int(np.sum(fa == fb))
        total += n
        for t in bilabial_apex_times(ref):
            n_b += 1
            k = round(t * fps)
            hit += any(closure_ok(dict(zip(tr.channels, tr.values[j], strict=True)))
                       for j in range(max(0, k - 1), min(n, k + 2)))
    print(f"audio-only (no transcript) vs aligned transcript: viseme agreement per frame "
          f"{100 * agree / total:.1f}%, /p b m/ closed within one frame {100 * hit / n_b:.1f}% "
          f"({n_b} closures), {secs / audio_s:.4f} s per s")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--dir", default=os.environ.get("MIMIKA_SPEECH_DIR", str(DEFAULT_DIR)))
    ap.add_argument("--n", type=int, default=200, help="utterances (first N by name)")
    ap.add_argument("--conditions", default="clean,edge,noise20,noise10,quiet,loud,slow,fast,"
                                            "pause")
    ap.add_argument("--engines", default="pocketsphinx,auto,dtw")
    ap.add_argument("--audio-only", action="store_true",
                    help="also measure lip-sync without a transcript (clean audio)")
    args = ap.parse_args()
    d = Path(args.dir)
    if not (d / "wav").is_dir():
        raise SystemExit(f"no GRID data in {d} (set MIMIKA_SPEECH_DIR)")
    ids = sorted(p.stem for p in (d / "wav").glob("*.wav"))[: args.n]
    engines = args.engines.split(",")
    print(f"{len(ids)} utterances from {d}")
    print(f"{'condition':<9} {'engine':<13} {'median':>7} {'p90':>6} {'≤50ms':>6} "
          f"{'closures':>9} {'s per s':>8}")
    for cond in args.conditions.split(","):
        rng = np.random.default_rng(0)
        data = []
        for i in ids:
            a, sr = read_wav(d / "wav" / f"{i}.wav")
            data.append((i, *degrade(a, sr, load_truth(d / "align" / f"{i}.align"), cond,
                                     rng), sr))
        for eng in engines:
            errs, inside, n_apex, secs, audio_s, fails = [], 0, 0, 0.0, 0.0, 0
            run_engine(eng, data[0][1], data[0][3], data[0][2])  # warm-up
            FALLBACKS.clear()
            for _i, a, truth, sr in data:
                t0 = time.perf_counter()
                spans, apex = run_engine(eng, a, sr, truth)
                secs += time.perf_counter() - t0
                audio_s += len(a) / sr
                if len(spans) != len(truth):
                    fails += 1
                    continue
                for (_, s, e), (s2, e2) in zip(truth, spans, strict=True):
                    errs += [abs(s2 - s), abs(e2 - e)]
                for t, k in apex:
                    n_apex += 1
                    inside += k >= 0 and truth[k][1] <= t <= truth[k][2]
            # both sides lie on a 10 ms grid: round away float noise, or an error of exactly
            # 50 ms (0.76 - 0.71 = 0.05000000000000004 s) would count as outside
            e = np.round(np.array(errs) * 1000, 3)
            clos = f"{100 * inside / n_apex:8.1f}%" if n_apex else f"{'—':>9}"
            print(f"{cond:<9} {eng:<13} {np.median(e):5.1f}ms {np.percentile(e, 90):4.0f}ms "
                  f"{100 * np.mean(e <= 50):5.1f}% {clos} {secs / audio_s:8.4f}"
                  + (f"  ({fails} failed)" if fails else "")
                  + (f"  ({FALLBACKS[eng]} by DTW)" if FALLBACKS.get(eng) else ""), flush=True)
        if args.audio_only and cond == "clean":
            audio_only(data)


if __name__ == "__main__":
    main()
