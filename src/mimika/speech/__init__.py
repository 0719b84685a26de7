"""Speech and lip-sync in AU space.

text or SSML → sentences → espeak-ng audio + timed phonemes and written words
(:func:`synthesize`), or a recording + transcript → timed phonemes (:func:`align`:
pocketsphinx for English, DTW against espeak-ng for every language), or a recording alone →
recognised phones (:func:`recognise`) → phoneme classes → Cohen–Massaro coarticulation
in AU space with hard /p b m/ and /f v/ closure rules (:func:`mouth_track`) → mixing with
emotion tracks (:func:`combine`) and viseme exports (Oculus-15, Rhubarb, MPEG-4, seed 004).

``import mimika.speech`` is light: espeak-ng (ctypes) loads on the first synthesis.
"""

from __future__ import annotations

from typing import Any

from mimika.speech.utterance import Phone, Sentence, Utterance, Word

_LAZY = {
    "synthesize": "mimika.speech.tts",
    "split_sentences": "mimika.speech.tts",
    "align": "mimika.speech.alignment",
    "recognise": "mimika.speech.alignment",
    "read_media": "mimika.speech.audio",
    "mouth_track": "mimika.speech.coarticulation",
    "mouth_aus": "mimika.speech.coarticulation",
    "bilabial_apex_times": "mimika.speech.coarticulation",
    "labiodental_apex_times": "mimika.speech.coarticulation",
    "closure_ok": "mimika.speech.coarticulation",
    "combine": "mimika.speech.mixing",
    "classify": "mimika.speech.phonemes",
    "segments": "mimika.speech.phonemes",
    "viseme_cues": "mimika.speech.export",
    "viseme_document": "mimika.speech.export",
    "rhubarb_json": "mimika.speech.export",
    "write_visemes": "mimika.speech.export",
    "write_au_csv": "mimika.speech.export",
    "read_wav": "mimika.speech.audio",
    "write_wav": "mimika.speech.audio",
    "list_voices": "mimika.speech.espeak",
}

__all__ = ["Phone", "Sentence", "Utterance", "Word", *sorted(_LAZY)]


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'mimika.speech' has no attribute {name!r}")
