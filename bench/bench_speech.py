"""espeak-ng speech throughput on one core: text → audio + mouth AU track (goal ≥ 100× real
time), mouth track alone, viseme export, and alignment of a recording (× real time). The
Piper voice is measured by bench_tts.py.

Run: ``.venv/bin/python bench/bench_speech.py``
"""

import os
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))
from _common import rate, report, single_core

single_core()
os.environ["MIMIKA_TTS"] = "espeak"

from mimika.speech.alignment import align
from mimika.speech.coarticulation import mouth_track
from mimika.speech.export import viseme_document
from mimika.speech.tts import synthesize

TEXTS = {
    "en": "Good evening. Here are the news. The city council met on Monday to discuss the new "
          "budget for public transport. Buses will run more often, and a new tram line is "
          "planned for the northern districts. Critics say the plan is too expensive, but the "
          "mayor promised that fares will not rise this year.",
    "de": "Guten Abend, meine Damen und Herren. Der Stadtrat hat am Montag über den neuen "
          "Haushalt für den öffentlichen Nahverkehr beraten. Busse sollen häufiger fahren, und "
          "eine neue Straßenbahnlinie ist für die nördlichen Stadtteile geplant.",
    "pl": "Dobry wieczór państwu. Rada miasta obradowała w poniedziałek nad nowym budżetem na "
          "transport publiczny. Autobusy będą kursować częściej, a nowa linia tramwajowa jest "
          "planowana dla północnych dzielnic.",
}


def main() -> None:
    for lang, text in TEXTS.items():
        u = synthesize(text, lang=lang)
        dur = u.duration
        print(f"-- {lang}: {dur:.1f} s of speech, {len(u.phonemes)} phones")
        report("  text → audio + mouth AUs (25 fps)",
               rate(lambda t=text, lg=lang: mouth_track(synthesize(t, lang=lg), fps=25),
                    min_time=2.0) * dur, "× real time", target=100)
        report("  text → audio only", rate(lambda t=text, lg=lang: synthesize(t, lang=lg))
               * dur, "× real time")
        report("  mouth AU track only (60 fps)",
               rate(lambda uu=u: mouth_track(uu, fps=60)) * dur, "× real time")
        report("  Rhubarb + Oculus exports",
               rate(lambda uu=u: (viseme_document(uu, format="rhubarb"),
                                  viseme_document(uu, format="oculus"))) * dur, "× real time")
        rec = synthesize(text, lang=lang, rate=150, pitch=65)
        report("  align recording + transcript",
               rate(lambda r=rec, t=text, lg=lang: align(r.audio, sr=r.sr, transcript=t,
                                                          lang=lg), min_time=2.0, warmup=1)
               * rec.duration, "× real time")


if __name__ == "__main__":
    main()
