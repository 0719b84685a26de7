"""Speech engines side by side: synthesis speed (× real time), time to first audio of a short
sentence, and how the phone timing of the Piper voice (its own durations) agrees with two
independent aligners run on its audio (pocketsphinx and mimika's DTW), plus /p b m/ inside
their words.

Run: ``.venv/bin/python bench/bench_tts.py`` (``--threads N`` for ONNX Runtime; default all
cores, as ``mimika news`` runs it)
"""

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))
from _common import rate, report

PARAGRAPH = ("Good evening. The city council met on Monday to discuss the new budget for "
             "public transport. Buses will run more often, and a new tram line is planned for "
             "the northern districts. Critics say the plan is too expensive, but the mayor "
             "promised that fares will not rise this year.")
SHORT = "Here is the news."
CHECK = [
    "Peter bought a map, and the prime minister met the press.",
    "The government announced a new budget plan on Monday, promising more money for public "
    "hospitals.",
    "Scientists in Oslo have mapped the behaviour of bumblebees in a warming climate.",
    "Members of parliament will vote on the proposal in the spring.",
    "Police say a man was arrested after a brief chase through the city centre.",
    "The bank expects prices to stabilise by the beginning of next year.",
]


def agreement() -> None:
    import numpy as np

    from mimika.speech.alignment import align
    from mimika.speech.tts import synthesize

    inside, total = 0, 0
    for eng in ("sphinx", "dtw"):
        d, bias = [], []
        for text in CHECK:
            u = synthesize(text, engine="piper")
            a = align(u.audio, sr=u.sr, transcript=text, engine=eng)
            for w1, w2 in zip(u.words, a.words, strict=False):
                d += [abs(w1.start - w2.start), abs(w1.end - w2.end)]
                bias += [w1.start - w2.start, w1.end - w2.end]
            if eng == "dtw":
                for p in u.phonemes:
                    if p.symbol in ("p", "b", "m"):
                        mid = 0.5 * (p.start + p.end)
                        total += 1
                        inside += any(w.start <= mid <= w.end and any(c in w.text.lower()
                                                                      for c in "pbm")
                                      for w in u.words)
        d = np.array(d)
        print(f"  Piper timing vs {eng:6}: word boundaries median {1000 * np.median(d):5.1f} ms,"
              f" {100 * np.mean(d < 0.05):5.1f} % within 50 ms, median signed "
              f"{1000 * np.median(bias):+5.1f} ms ({len(d)} boundaries)")
    print(f"  /p b m/ midpoints inside a word spelt with p, b or m: {inside}/{total} "
          f"({100 * inside / max(total, 1):.1f} %)")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--threads", type=int, default=0)
    args = ap.parse_args()
    if args.threads:
        import os

        os.environ["OMP_NUM_THREADS"] = str(args.threads)
    from mimika.speech import piper
    from mimika.speech.tts import synthesize

    if args.threads:
        piper.THREADS = args.threads
    engines = ["espeak"] + (["piper"] if piper.default_voice("en") else [])
    for eng in engines:
        t0 = time.perf_counter()
        u = synthesize(SHORT, engine=eng)
        cold = time.perf_counter() - t0
        print(f"-- {eng} ({u.meta['voice']}, {u.sr} Hz)")
        report("  first sentence incl. loading the voice", cold * 1000, "ms")
        t0 = time.perf_counter()
        synthesize(SHORT, engine=eng)
        report(f"  time to audio of {SHORT!r} (warm)", (time.perf_counter() - t0) * 1000,
               "ms", target=250)
        dur = synthesize(PARAGRAPH, engine=eng).duration
        report(f"  paragraph ({dur:.1f} s of speech)",
               rate(lambda e=eng: synthesize(PARAGRAPH, engine=e), warmup=1, min_time=2.0)
               * dur, "× real time")
    if "piper" in engines:
        agreement()


if __name__ == "__main__":
    main()
