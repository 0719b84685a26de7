"""English speech through pocketsphinx (the recogniser inside Rhubarb Lip Sync): forced
alignment of a transcript and phone recognition without one.

pocketsphinx 5 ships its en-us acoustic model, the CMU pronouncing dictionary and a phone
language model. Every written token (``bin``, ``$100``, ``3.14159``) becomes one decoder word
whose pronunciation is espeak-ng's reading in the chosen accent, mapped to ARPAbet
(``data/arpabet.json``), so its time is the time of what was said for it.
Recognised ARPAbet phones become espeak mnemonics, so the viseme layer sees the same symbols
as from synthesis. Decoders are cached per process and used under one lock; the features are
normalised per utterance (batch CMN) and feature extraction is set up afresh for every
decode, so a result does not depend on what was decoded before.
"""

from __future__ import annotations

import functools
import hashlib
import json
import logging
import os
import re
import threading
from importlib import resources
from typing import Any

import numpy as np

from mimika.errors import DataError, ParameterError
from mimika.speech.audio import resample, valid_audio
from mimika.speech.utterance import Phone
from mimika.speech.words import Token, phonemize

log = logging.getLogger(__name__)

SR = 16000
FRAME = 0.01  #: pocketsphinx frame step (s)
_LOCK = threading.Lock()
_VOWELS = frozenset({"AA", "AE", "AH", "AO", "AW", "AY", "EH", "ER", "EY", "IH", "IY", "OW",
                     "OY", "UH", "UW"})


def available() -> bool:
    """True when pocketsphinx and its en-us model are installed."""
    try:
        import pocketsphinx
    except ImportError:
        return False
    return os.path.isdir(os.path.join(pocketsphinx.get_model_path(), "en-us"))


def serves(lang: str) -> bool:
    """True when pocketsphinx's model fits ``lang`` (English: en, en-us, en-gb …)."""
    return lang.split("-")[0] == "en" and available()


@functools.cache
def _table() -> dict[str, dict[str, str]]:
    return json.loads(resources.files("mimika.speech").joinpath("data/arpabet.json")
                      .read_text("utf-8"))


@functools.cache
def _decoder(kind: str) -> Any:
    try:
        import pocketsphinx
    except ImportError as e:
        raise DataError("English alignment and phone recognition need pocketsphinx: "
                        "pip install 'pocketsphinx==5.1.1'") from e
    # silprob 0.1 (default 0.005): real recordings pause between words; an optional silence
    # that is likely enough keeps a stop's closure from swallowing the pause before it
    kw: dict[str, Any] = {"samprate": SR, "loglevel": "FATAL", "bestpath": False,
                          "silprob": 0.1}
    if kind == "align-wide":  # the retry when the default beams lose the transcript (noise)
        kw.update(beam=1e-80, wbeam=1e-60, pbeam=1e-80)
    if kind == "align-widest":  # voices far from its model (formant synthesis) need more
        kw.update(beam=1e-200, wbeam=1e-150, pbeam=1e-200)
    if kind == "phones":
        # a weak phone language model (lw 1 instead of ≈ 6.5) lets the acoustics decide: on the
        # GRID dev set it doubles the /p b m/ that are heard (bench_align_real.py --audio-only)
        kw.update(allphone=os.path.join(pocketsphinx.get_model_path(), "en-us",
                                        "en-us-phone.lm.bin"), lm=None, lw=1.0)
    return pocketsphinx.Decoder(**kw)


def _pcm(audio: np.ndarray, sr: int) -> bytes:
    a = resample(valid_audio(audio, sr=sr), orig_sr=int(sr), target_sr=SR)
    return (np.clip(a, -1.0, 1.0) * 32767.0).astype("<i2").tobytes()


def _fresh(dec: Any) -> Any:
    """``dec`` with its feature extraction set up afresh: its noise estimate
    (``remove_noise``) would otherwise carry over from the last recording and move
    boundaries by 10–30 ms. The passes over one recording share it, as in a new process."""
    dec.reinit_feat()
    return dec


def _decode(dec: Any, pcm: bytes) -> None:
    dec.start_utt()
    dec.process_raw(pcm, full_utt=True)
    dec.end_utt()


def _pronunciation(token: Token, lang: str) -> str:
    """ARPAbet of how espeak-ng reads ``token`` in ``lang`` (its accent: en is British,
    non-rhotic; en-us rhotic)."""
    t = _table()
    arpa = dict(t["from_espeak"])
    if lang not in t["rhotic_langs"]:
        arpa.update(t["non_rhotic"])
    out = []
    for sym, _ in phonemize(token.say, lang=lang):
        if sym in arpa:
            out.append(arpa[sym])
        else:  # another language's phoneme: the English phone of its mouth class
            from mimika.speech.phonemes import classify

            out += [t["by_class"].get(c, "") for c in classify(sym, lang=lang)]
    return " ".join(x for x in out if x)


def _dict_word(dec: Any, token: Token, lang: str) -> str:
    """The decoder's word for ``token``: a pseudo-word with espeak-ng's pronunciation in the
    chosen accent (on GRID's British speaker this aligns better than the American CMU
    dictionary: 87.7 % vs 86.7 % of boundaries within 50 ms), the dictionary's entry when
    espeak gives nothing usable."""
    pron = _pronunciation(token, lang)
    if not pron:
        w = re.sub(r"[’`]", "'", token.say.lower())
        if re.fullmatch(r"[a-z][a-z']*", w) and dec.lookup_word(w) is not None:
            return w
        pron = "SIL"
    name = "w" + hashlib.sha1(pron.encode()).hexdigest()[:12]
    if dec.lookup_word(name) is None:
        dec.add_word(name, pron, False)  # the alignment search is built afterwards
    return name


def _to_espeak(arpa: str, stress: int) -> str:
    a = arpa.split("(")[0].rstrip("012")
    if a == "AH":
        return "V" if stress else "@"
    if a == "ER":
        return "3:" if stress else "3"
    return _table()["to_espeak"].get(a, "_")


def _stresses(token: Token, lang: str) -> list[int]:
    """Stress of each vowel of ``token`` as espeak reads it (primary 2, secondary 1)."""
    from mimika.speech.phonemes import classify

    out = []
    for sym, st in phonemize(token.say, lang=lang):
        if classify(sym, lang=lang)[0].startswith("vowel"):
            out.append(st)
    return out


#: speech this far above its quietest frames (dB) may take the widest beams, which clean
#: synthetic voices need (espeak-ng: 6 of 11 bulletin sentences failed without); on noisy
#: speech they find worse paths than the DTW fallback (GRID at 10 dB SNR: 57.8 % vs 63.7 %
#: of boundaries within 50 ms). Clean GRID ≈ 37 dB, at 10 dB SNR ≈ 8 dB, espeak-ng ≈ 95 dB.
CLEAN_DB = 30.0


def _clean(audio: np.ndarray, sr: int) -> bool:
    from mimika.speech.vad import frame_energy

    e = frame_energy(audio, sr=sr)
    return bool(len(e)) and float(np.percentile(e, 95) - np.percentile(e, 1)) >= CLEAN_DB


def force_align(audio: np.ndarray, *, sr: int, toks: list[Token], lang: str = "en"
                ) -> tuple[list[Phone], list[int]]:
    """Phones of a recording of ``toks`` and the token index of each (-1 for pauses).

    Raises :class:`~mimika.errors.ParameterError` when pocketsphinx cannot align them.
    """
    if not toks:
        raise ParameterError("transcript has no words to align")
    pcm = _pcm(audio, sr)
    dur = len(audio) / sr
    with _LOCK:
        items = None
        for kind in ("align", "align-wide", "align-widest")[:3 if _clean(audio, sr) else 2]:
            dec = _fresh(_decoder(kind))
            words = [_dict_word(dec, t, lang) for t in toks]
            try:
                dec.set_align_text(" ".join(words))
                _decode(dec, pcm)  # the noise estimate learns this recording
                _decode(dec, pcm)
                dec.set_alignment()
                _decode(dec, pcm)
                items = [(w.name, [(p.name, p.start, p.duration) for p in w])
                         for w in dec.get_alignment()]
                break
            except RuntimeError as e:
                err = e
        if items is None:
            raise ParameterError(f"pocketsphinx cannot align the transcript to the audio "
                                 f"({err})") from None
    phones: list[Phone] = []
    owner: list[int] = []
    k = 0
    for name, segs in items:
        base = name.split("(")[0]
        is_word = not (base.startswith("<") or base.startswith("[") or base.startswith("+"))
        if is_word and k >= len(toks):
            is_word = False
        stress = _stresses(toks[k], lang) if is_word else []
        v = 0
        for ph, start, n in segs:
            if n <= 0:
                continue
            s, e = start * FRAME, min((start + n) * FRAME, dur)
            if not is_word or ph.startswith("SIL") or ph.startswith("+"):
                sym, st = "_", 0
            else:
                st = 0
                if ph.rstrip("012") in _VOWELS:
                    st = stress[v] if v < len(stress) else 0
                    v += 1
                sym = _to_espeak(ph, st)
            if phones and sym == "_" and phones[-1].is_pause:
                phones[-1] = Phone("_", phones[-1].start, e)
                continue
            phones.append(Phone(sym, s, e, st))
            owner.append(k if is_word and sym != "_" else -1)
        if is_word:
            k += 1
    if k != len(toks):
        raise ParameterError(f"pocketsphinx aligned {k} of {len(toks)} words")
    return _tile(phones, owner, dur)


def recognise_phones(audio: np.ndarray, *, sr: int) -> list[Phone]:
    """Phones heard in a recording without a transcript (en-us phone model), tiling it."""
    pcm = _pcm(audio, sr)
    dur = len(audio) / sr
    with _LOCK:
        dec = _fresh(_decoder("phones"))
        _decode(dec, pcm)
        segs = [(s.word, s.start_frame, s.end_frame) for s in dec.seg()]
    return seg_phones(segs, dur)


def seg_phones(segs: list[tuple[str, int, int]], dur: float) -> list[Phone]:
    """Phone-model segments ``(ARPAbet, first frame, last frame)`` as phones tiling
    ``[0, dur]``."""
    phones: list[Phone] = []
    owner: list[int] = []
    for ph, f0, f1 in segs:
        s, e = f0 * FRAME, min((f1 + 1) * FRAME, dur)
        if e <= s:
            continue
        sym = "_" if ph.startswith(("SIL", "+", "<", "[")) else _to_espeak(ph, 2)
        if phones and sym == "_" and phones[-1].is_pause:
            phones[-1] = Phone("_", phones[-1].start, e)
            continue
        phones.append(Phone(sym, s, e, 2 if sym != "_" else 0))
        owner.append(-1)
    return _tile(phones, owner, dur)[0]


def _tile(phones: list[Phone], owner: list[int], dur: float
          ) -> tuple[list[Phone], list[int]]:
    """Close gaps so the phones tile [0, dur]."""
    out: list[Phone] = []
    own: list[int] = []
    t = 0.0
    for p, o in zip(phones, owner, strict=True):
        if p.start > t + 1e-9:
            if out and out[-1].is_pause:
                out[-1] = Phone("_", out[-1].start, p.start)
            else:
                out.append(Phone("_", t, p.start))
                own.append(-1)
        s = max(p.start, t)
        if p.end <= s:
            continue
        out.append(Phone(p.symbol, s, p.end, p.stress))
        own.append(o)
        t = p.end
    if t < dur - 1e-9:
        if out and out[-1].is_pause:
            out[-1] = Phone("_", out[-1].start, dur)
        else:
            out.append(Phone("_", t, dur))
            own.append(-1)
    elif out:
        last = out[-1]
        out[-1] = Phone(last.symbol, last.start, dur, last.stress)
    return out, own
