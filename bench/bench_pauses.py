"""Word boundaries next to pauses, in every language the DTW aligner serves.

"Recordings" with known timing: SSML texts with sentence ends and ``<break>`` pauses in
German, Polish and English, spoken by other espeak-ng voices than the aligner's reference
(variants f3, m2, klatt at other rates and pitches; the Piper voice for English), with white
noise (15 dB SNR) and room reverb (exponentially decaying noise, RT60 0.4 s) on top. Each is
aligned to its plain transcript; the bench prints the share of word boundaries within 50 ms
and the worst error of a boundary next to a pause (≥ 0.1 s of silence) per language and
condition. Goal (issue 28): ≥ 95 % within 50 ms, none next to a pause off by more than 100 ms.

    .venv/bin/python bench/bench_pauses.py [--langs de,pl]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from mimika.speech.alignment import align
from mimika.speech.ssml import parse, plain_text
from mimika.speech.tts import synthesize
from mimika.speech.utterance import Utterance

TEXTS = {
    "de": ['<speak>Er gehe nicht weit genug, hieß es. <break time="400ms"/> Wird die '
           'Regierung nachbessern?</speak>',
           '<speak>Der Stadtrat hat am Montag beraten. <break time="700ms"/> Busse sollen '
           'häufiger fahren, sagte die Bürgermeisterin. Kritiker sind skeptisch.</speak>',
           '<speak>Guten Abend, meine Damen und Herren. <break time="300ms"/> Zuerst das '
           'Wetter: Morgen wird es regnen.</speak>'],
    "pl": ['<speak>Rada miasta obradowała w poniedziałek. <break time="500ms"/> Autobusy '
           'będą kursować częściej.</speak>',
           '<speak>Dobry wieczór państwu. <break time="400ms"/> Najpierw pogoda: jutro będzie '
           'padać, a potem wyjdzie słońce.</speak>',
           '<speak>Minister zapowiedział zmiany. <break time="800ms"/> Opozycja krytykuje '
           'ten plan.</speak>'],
    "en": ['<speak>The council met on Monday. <break time="500ms"/> Buses will run more '
           'often, the mayor said.</speak>',
           '<speak>Good evening. <break time="400ms"/> First, the weather: rain tomorrow, '
           'and sunshine later.</speak>'],
}
VOICES = {"f3 150 wpm": dict(voice="f3", rate=150), "m2 190 wpm": dict(voice="m2", rate=190),
          "klatt pitch 30": dict(voice="klatt", pitch=30)}
PAUSE = 0.1  #: a boundary next to at least this much silence counts as "next to a pause"


def noisy(u: Utterance, rng: np.random.Generator, *, snr: float | None, rt60: float | None
          ) -> np.ndarray:
    a = u.audio.astype(np.float64)
    if rt60:
        n = int(rt60 * u.sr)
        ir = rng.standard_normal(n) * np.exp(-6.9 * np.arange(n) / n)
        ir[0] = 1.0
        wet = np.convolve(a, ir * 0.25)[:len(a)]
        a = wet / (np.abs(wet).max() + 1e-9) * np.abs(a).max()
    if snr is not None:
        p = float(np.mean(a[np.abs(a) > 1e-4] ** 2))
        a = a + rng.normal(0, np.sqrt(p / 10 ** (snr / 10)), len(a))
    return a.astype(np.float32)


def errors(truth: Utterance, est: Utterance) -> tuple[np.ndarray, np.ndarray]:
    """|error| of every word start and end; and of those next to a pause."""
    pauses = [(p.start, p.end) for p in truth.phonemes if p.is_pause and p.duration >= PAUSE]

    def near(t: float) -> bool:
        return any(s - 1e-3 <= t <= e + 1e-3 for s, e in pauses)

    allv, near_v = [], []
    assert [w.text for w in truth.words] == [w.text for w in est.words], "word lists differ"
    for w, v in zip(truth.words, est.words, strict=True):
        for t, s in ((w.start, v.start), (w.end, v.end)):
            allv.append(abs(t - s))
            if near(t):
                near_v.append(abs(t - s))
    return np.array(allv), np.array(near_v)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--langs", default="de,pl,en")
    args = ap.parse_args()
    rng = np.random.default_rng(7)
    pooled: dict[str, list[np.ndarray]] = {}
    print(f"{'lang':4} {'condition':32} {'n':>4} {'≤50 ms':>7} {'median':>7} "
          f"{'near pause: n':>13} {'max ms':>7}")
    for lang in args.langs.split(","):
        voices = dict(VOICES)
        if lang == "en":
            voices["Piper joe"] = dict(engine="piper")
        for vname, kw in voices.items():
            for cond, extra in (("clean", {}), ("noise 15 dB", {"snr": 15}),
                                ("reverb 0.4 s + noise 15 dB", {"snr": 15, "rt60": 0.4})):
                a_all, a_near = [], []
                for doc in TEXTS[lang]:
                    truth = synthesize(doc, lang=lang, ssml=kw.get("engine") != "piper",
                                       **({"engine": "espeak"} | kw)) \
                        if kw.get("engine") != "piper" else \
                        synthesize(plain_text(parse(doc)), lang=lang, engine="piper")
                    rec = noisy(truth, rng, snr=extra.get("snr"), rt60=extra.get("rt60"))
                    est = align(rec, sr=truth.sr, transcript=plain_text(parse(doc)), lang=lang,
                                engine="dtw")
                    e, n = errors(truth, est)
                    a_all.append(e)
                    a_near.append(n)
                e, n = np.concatenate(a_all) * 1000, np.concatenate(a_near) * 1000
                pooled.setdefault(lang, []).append(e)
                pooled.setdefault(lang + " near", []).append(n)
                print(f"{lang:4} {vname + ', ' + cond:32} {len(e):4d} "
                      f"{100 * np.mean(e <= 50):6.1f}% {np.median(e):6.1f} "
                      f"{len(n):13d} {n.max() if len(n) else 0:7.0f}")
    print()
    for lang in args.langs.split(","):
        e = np.concatenate(pooled[lang])
        n = np.concatenate(pooled[lang + " near"])
        print(f"{lang}: {100 * np.mean(e <= 50):.1f} % of {len(e)} word boundaries within 50 ms"
              f" (goal ≥ 95 %); next to a pause: {int(np.sum(n > 100))} of {len(n)} off by "
              f"> 100 ms, worst {n.max():.0f} ms (goal: none)")


if __name__ == "__main__":
    main()
