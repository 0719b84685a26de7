"""Alignment accuracy on speech with known timing.

The "recordings" are espeak-ng renditions whose phone boundaries are known exactly, made
different from the reference that ``align`` synthesises internally (rate 175, pitch 50, default
voice): other speaking rates, speed change by resampling (shifts formants and pitch too),
other pitch, another voice variant, and white noise at 20 / 10 dB SNR on top of a rate+pitch
change. Prints median / 90th-percentile absolute phone-boundary error per condition.

    .venv/bin/python bench/bench_align.py [--quick]
"""

from __future__ import annotations

import argparse
import difflib
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))
os.environ.setdefault("MIMIKA_TTS", "espeak")  # the "recordings" are espeak-ng variants

from mimika.speech.alignment import align
from mimika.speech.audio import resample
from mimika.speech.tts import synthesize
from mimika.speech.utterance import Phone, Utterance

TEXTS = {
    "en": "Good evening. The city council met on Monday to discuss the new budget for "
          "public transport. Buses will run more often, and a new tram line is planned.",
    "de": "Guten Abend, meine Damen und Herren. Der Stadtrat hat am Montag über den neuen "
          "Haushalt beraten. Busse sollen häufiger fahren.",
    "pl": "Dobry wieczór państwu. Rada miasta obradowała w poniedziałek nad nowym budżetem. "
          "Autobusy będą kursować częściej.",
}


def speed(u: Utterance, factor: float) -> Utterance:
    """Play ``u`` ``factor`` times faster by resampling (pitch and formants scale too)."""
    sr2 = round(u.sr / factor)
    a = resample(u.audio, orig_sr=u.sr, target_sr=sr2)
    ph = [Phone(p.symbol, p.start / factor, p.end / factor, p.stress) for p in u.phonemes]
    return Utterance(a, u.sr, ph, lang=u.lang, text=u.text)


def stretch(u: Utterance, factor: float) -> Utterance:
    """Phase-vocoder time stretch: duration × ``factor``, pitch and formants kept."""
    n_fft, hop = 1024, 256
    a = u.audio.astype(np.float64)
    win = np.hanning(n_fft)
    frames = np.lib.stride_tricks.sliding_window_view(np.pad(a, (n_fft, n_fft)), n_fft)[::hop]
    spec = np.fft.rfft(frames * win, axis=1)
    steps = np.arange(0, len(spec) - 1, 1 / factor)
    omega = 2 * np.pi * hop * np.arange(n_fft // 2 + 1) / n_fft
    phase = np.angle(spec[0])
    out = np.zeros(int(len(steps) * hop + n_fft))
    norm = np.zeros_like(out)
    for k, st in enumerate(steps):
        i = int(st)
        frac = st - i
        mag = (1 - frac) * np.abs(spec[i]) + frac * np.abs(spec[i + 1])
        frame = np.fft.irfft(mag * np.exp(1j * phase), n=n_fft) * win
        out[k * hop:k * hop + n_fft] += frame
        norm[k * hop:k * hop + n_fft] += win ** 2
        dphi = np.angle(spec[i + 1]) - np.angle(spec[i]) - omega
        phase = phase + omega + (dphi + np.pi) % (2 * np.pi) - np.pi
    out = (out / np.maximum(norm, 1e-6))[n_fft:]
    n = round(len(a) * factor)
    out = np.pad(out, (0, max(0, n - len(out))))[:n].astype(np.float32)
    ph = [Phone(p.symbol, p.start * factor, p.end * factor, p.stress) for p in u.phonemes]
    return Utterance(out, u.sr, ph, lang=u.lang, text=u.text)


def add_noise(u: Utterance, snr_db: float, rng: np.random.Generator) -> Utterance:
    """White noise at ``snr_db`` relative to the mean power of the non-silent samples."""
    a = u.audio
    p_sig = float(np.mean(a[np.abs(a) > 1e-4] ** 2))
    noise = rng.normal(0, np.sqrt(p_sig / 10 ** (snr_db / 10)), len(a)).astype(np.float32)
    return Utterance(a + noise, u.sr, u.phonemes, lang=u.lang, text=u.text)


def boundary_errors(truth: Utterance, est: Utterance) -> np.ndarray:
    """|error| in seconds of every phone start matched by symbol sequence (first phone excluded)."""
    a = [p.symbol for p in truth.phonemes]
    b = [p.symbol for p in est.phonemes]
    errs = []
    for blk in difflib.SequenceMatcher(a=a, b=b, autojunk=False).get_matching_blocks():
        for k in range(blk.size):
            i, j = blk.a + k, blk.b + k
            if i == 0 or j == 0:
                continue
            errs.append(abs(truth.phonemes[i].start - est.phonemes[j].start))
    return np.array(errs)


def conditions(lang: str, rng: np.random.Generator) -> dict[str, Utterance]:
    t = TEXTS[lang]
    slow = synthesize(t, lang=lang, rate=140)
    return {
        "rate 0.8x (140 wpm)": slow,
        "rate 1.25x (219 wpm)": synthesize(t, lang=lang, rate=219),
        "stretch 1.25x phase vocoder": stretch(synthesize(t, lang=lang), 1.25),
        "stretch 0.8x phase vocoder": stretch(synthesize(t, lang=lang), 0.8),
        "speed 0.9x resampled": speed(synthesize(t, lang=lang, rate=160), 0.9),
        "speed 1.1x resampled": speed(synthesize(t, lang=lang, rate=190), 1.1),
        "pitch 20": synthesize(t, lang=lang, pitch=20),
        "pitch 85": synthesize(t, lang=lang, pitch=85),
        "voice f3 + rate 150": synthesize(t, lang=lang, voice="f3", rate=150),
        "noise 20 dB (0.8x, pitch 70)": add_noise(
            synthesize(t, lang=lang, rate=140, pitch=70), 20, rng),
        "noise 10 dB (0.8x, pitch 70)": add_noise(
            synthesize(t, lang=lang, rate=140, pitch=70), 10, rng),
        "noise 10 dB + f3 + 1.25x PV": add_noise(
            stretch(synthesize(t, lang=lang, voice="f3", pitch=65), 1.25), 10, rng),
    }


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="English only")
    ap.add_argument("--engine", default="dtw", choices=("dtw", "sphinx", "auto"),
                    help="alignment engine (dtw: the one every language gets)")
    args = ap.parse_args()
    rng = np.random.default_rng(4)
    langs = ["en"] if args.quick else list(TEXTS)
    per_cond: dict[str, list[np.ndarray]] = {}
    print(f"{'lang':5} {'condition':30} {'n':>4} {'median ms':>10} {'p90 ms':>8} {'xRT':>6}")
    for lang in langs:
        for name, rec in conditions(lang, rng).items():
            t0 = time.perf_counter()
            est = align(rec.audio, sr=rec.sr, transcript=TEXTS[lang], lang=lang,
                        engine=args.engine if lang == "en" else "dtw")
            dt = time.perf_counter() - t0
            e = boundary_errors(rec, est) * 1000
            per_cond.setdefault(name, []).append(e)
            print(f"{lang:5} {name:30} {len(e):4d} {np.median(e):10.1f} "
                  f"{np.percentile(e, 90):8.1f} {rec.duration / dt:6.1f}")
    print("\nall languages pooled:")
    allv = []
    for name, es in per_cond.items():
        e = np.concatenate(es)
        allv.append(e)
        print(f"  {name:30} median {np.median(e):5.1f} ms   p90 {np.percentile(e, 90):5.1f} ms")
    e = np.concatenate(allv)
    print(f"  {'ALL':30} median {np.median(e):5.1f} ms   p90 {np.percentile(e, 90):5.1f} ms"
          f"   (goal: median <= 30 ms)")


if __name__ == "__main__":
    main()
