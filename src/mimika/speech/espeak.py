"""ctypes binding to espeak-ng (through the ``espeakng-loader`` wheel).

espeak-ng is a process-global C library with global state (voice, rate, callback), so every
call goes through one lock. Synthesis runs in ``AUDIO_OUTPUT_SYNCHRONOUS`` mode: the callback
is called on the calling thread and nothing runs in the background, which also makes the
library safe to use after ``fork``.

Part of that state survives ``espeak_Terminate``/``espeak_Initialize`` (static variables of the
wave generator), so the same text could sound a few samples different depending on what was
spoken before. Every :func:`synth` therefore starts from a freshly loaded library: mimika
loads a private copy of ``libespeak-ng.so`` and unloads (``dlclose``) and reloads it before a
synthesis when anything was synthesised since the last load (≈ 6 ms), and seeds espeak-ng's
random numbers (voice variants draw from them). The same input gives the same audio whatever
ran before in the process, and the same as in a fresh process.

Nothing here is imported by ``import mimika``; ctypes and the library load on first use.
"""

from __future__ import annotations

import difflib
import logging
import os
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from mimika.errors import DataError, ParameterError

log = logging.getLogger(__name__)

_LOCK = threading.RLock()
_STATE: dict[str, Any] = {}

# espeak_EVENT_TYPE
EV_LIST_TERMINATED, EV_WORD, EV_SENTENCE, EV_MARK, EV_PLAY, EV_END = 0, 1, 2, 3, 4, 5
EV_MSG_TERMINATED, EV_PHONEME, EV_SAMPLERATE = 6, 7, 8
# espeak_Initialize options, espeak_Synth flags, espeak_PARAMETER
_AUDIO_OUTPUT_SYNCHRONOUS = 2
_INIT_PHONEME_EVENTS = 0x0001
_CHARS_UTF8 = 1
_SSML = 0x10
_PHONEMES = 0x100  # [[mnemonics]] in the text are phonemes
_RATE, _VOLUME, _PITCH, _RANGE = 1, 2, 3, 4

RAND_SEED = 1  #: seed of espeak-ng's random numbers, set before every synthesis
RATE_RANGE = (80, 450)  #: words per minute espeak accepts
PITCH_RANGE = (0, 100)


@dataclass(frozen=True)
class Voice:
    """One espeak-ng voice: ``name`` ("English (America)"), ``identifier`` ("gmw/en-US"),
    ``languages`` (codes it speaks, best first) and ``gender`` ("male" | "female" | "")."""

    name: str
    identifier: str
    languages: tuple[str, ...]
    gender: str


@dataclass
class RawSynthesis:
    """What one ``espeak_Synth`` call produced.

    ``audio`` int16 samples at ``sr``; ``events`` as tuples
    ``(type, text_position, length, sample, payload)`` where payload is the phoneme mnemonic
    (str) for phoneme events and the event's number otherwise.
    """

    audio: np.ndarray
    sr: int
    events: list[tuple[int, int, int, int, Any]]


def _private_copy(path: str) -> str:
    """A copy of the library under its own name, so that unloading it really unloads it even
    if something else in the process opened the original. The copy lives in the per-user
    cache (one per library version, reused by every run: a killed run leaves nothing behind);
    where the cache cannot be written, in a temporary folder removed at exit."""
    import shutil

    from mimika.cachedir import cache_dir

    if "copy" in _STATE:
        return _STATE["copy"]
    st = os.stat(path)
    d = cache_dir("espeak", f"{st.st_size:x}-{int(st.st_mtime):x}")
    dst = d / os.path.basename(path)
    try:
        if not dst.is_file() or dst.stat().st_size != st.st_size:
            d.mkdir(parents=True, exist_ok=True)
            tmp = d / f".{dst.name}.{os.getpid()}"
            shutil.copy2(path, tmp)
            os.replace(tmp, dst)  # atomic: a concurrent run sees the old copy or the new one
    except OSError:
        import atexit
        import tempfile

        t = tempfile.mkdtemp(prefix="mimika-espeak-")
        atexit.register(shutil.rmtree, t, True)
        dst = Path(t) / os.path.basename(path)
        shutil.copy2(path, dst)
    _STATE["copy"] = str(dst)
    return _STATE["copy"]


def _unload() -> None:
    """Terminate and unload the library (its static state goes with it)."""
    import _ctypes

    lib = _STATE.pop("lib", None)
    if lib is None:
        return
    lib.espeak_Terminate()
    handle = lib._handle
    for k in ("cb", "voice"):
        _STATE.pop(k, None)
    del lib
    _ctypes.dlclose(handle)


def _fresh(*, after_phonemes: bool = True) -> None:
    """Reload the library if anything was synthesised since it was loaded (or, with
    ``after_phonemes``, anything phonemised: that may leave state a synthesis would hear)."""
    if _STATE.get("dirty") or (after_phonemes and _STATE.get("phonemised")):
        _unload()
        _STATE["dirty"] = _STATE["phonemised"] = False


def _lib():
    """Load and initialise libespeak-ng (under the lock); return (lib, ctypes types)."""
    if "lib" in _STATE:
        return _STATE["lib"], _STATE["types"]
    import ctypes

    try:
        import espeakng_loader
    except ImportError as e:  # pragma: no cover - dependency is declared
        raise DataError(
            "speech synthesis needs the 'espeakng-loader' package: pip install espeakng-loader"
        ) from e

    class _Id(ctypes.Union):
        _fields_ = [("number", ctypes.c_int), ("name", ctypes.c_void_p),
                    ("string", ctypes.c_char * 8)]

    class _Event(ctypes.Structure):
        _fields_ = [("type", ctypes.c_int), ("unique_identifier", ctypes.c_uint),
                    ("text_position", ctypes.c_int), ("length", ctypes.c_int),
                    ("audio_position", ctypes.c_int), ("sample", ctypes.c_int),
                    ("user_data", ctypes.c_void_p), ("id", _Id)]

    class _Voice(ctypes.Structure):
        _fields_ = [("name", ctypes.c_char_p), ("languages", ctypes.c_void_p),
                    ("identifier", ctypes.c_char_p), ("gender", ctypes.c_ubyte),
                    ("age", ctypes.c_ubyte), ("variant", ctypes.c_ubyte),
                    ("xx1", ctypes.c_ubyte), ("score", ctypes.c_int),
                    ("spare", ctypes.c_void_p)]

    callback_t = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.POINTER(ctypes.c_short), ctypes.c_int,
                                  ctypes.POINTER(_Event))
    try:
        lib = ctypes.CDLL(_private_copy(espeakng_loader.get_library_path()))
    except OSError as e:
        raise DataError(f"cannot load libespeak-ng from espeakng-loader: {e}") from e
    lib.espeak_Initialize.argtypes = [ctypes.c_int, ctypes.c_int, ctypes.c_char_p, ctypes.c_int]
    lib.espeak_SetSynthCallback.argtypes = [callback_t]
    lib.espeak_SetVoiceByName.argtypes = [ctypes.c_char_p]
    lib.espeak_SetParameter.argtypes = [ctypes.c_int, ctypes.c_int, ctypes.c_int]
    lib.espeak_Synth.argtypes = [ctypes.c_char_p, ctypes.c_size_t, ctypes.c_uint, ctypes.c_int,
                                 ctypes.c_uint, ctypes.c_uint, ctypes.c_void_p, ctypes.c_void_p]
    lib.espeak_ng_SetRandSeed.argtypes = [ctypes.c_long]
    lib.espeak_TextToPhonemes.argtypes = [ctypes.POINTER(ctypes.c_char_p), ctypes.c_int,
                                          ctypes.c_int]
    lib.espeak_TextToPhonemes.restype = ctypes.c_char_p
    lib.espeak_ListVoices.argtypes = [ctypes.c_void_p]
    lib.espeak_ListVoices.restype = ctypes.POINTER(ctypes.POINTER(_Voice))
    data_path = espeakng_loader.get_data_path()
    sr = lib.espeak_Initialize(_AUDIO_OUTPUT_SYNCHRONOUS, 500, data_path.encode(),
                               _INIT_PHONEME_EVENTS)
    if sr <= 0:
        raise DataError(f"espeak_Initialize failed (data path {data_path!r})")

    sink: dict[str, Any] = {"chunks": [], "events": []}

    def _callback(wav, n, events) -> int:
        if n > 0:
            sink["chunks"].append(np.ctypeslib.as_array(wav, shape=(n,)).copy())
        i = 0
        while events[i].type != EV_LIST_TERMINATED:
            e = events[i]
            if e.type == EV_PHONEME:
                payload: Any = e.id.string.decode("utf-8", "replace")
            else:
                payload = e.id.number
            sink["events"].append((e.type, e.text_position, e.length, e.sample, payload))
            i += 1
        return 0

    cb = callback_t(_callback)  # keep a reference: the C side holds only the pointer
    lib.espeak_SetSynthCallback(cb)
    _STATE.update(lib=lib, types=(ctypes, _Voice), cb=cb, sink=sink, sr=sr, voice=None,
                  data_path=data_path)
    log.debug("espeak-ng initialised: sr=%d data=%s", sr, data_path)
    return lib, (ctypes, _Voice)


def sample_rate() -> int:
    """espeak-ng's output sample rate in Hz (22 050)."""
    with _LOCK:
        _lib()
        return int(_STATE["sr"])


def data_path() -> str:
    """The espeak-ng-data folder in use."""
    with _LOCK:
        _lib()
        return str(_STATE["data_path"])


def _decode_languages(ctypes, addr: int | None) -> tuple[str, ...]:
    out: list[str] = []
    if not addr:
        return ()
    k = 0
    while ctypes.c_ubyte.from_address(addr + k).value != 0:
        s = ctypes.string_at(addr + k + 1)
        out.append(s.decode("utf-8", "replace"))
        k += 2 + len(s)
    return tuple(out)


def _list(spec_language: str | None) -> list[Voice]:
    lib, (ctypes, voice_t) = _lib()
    spec = None
    if spec_language is not None:
        buf = ctypes.create_string_buffer(spec_language.encode())
        v = voice_t()
        v.languages = ctypes.cast(buf, ctypes.c_void_p)
        spec = ctypes.byref(v)
    p = lib.espeak_ListVoices(spec)
    out: list[Voice] = []
    i = 0
    while p[i]:
        v = p[i].contents
        out.append(Voice(
            name=(v.name or b"").decode("utf-8", "replace"),
            identifier=(v.identifier or b"").decode("utf-8", "replace"),
            languages=_decode_languages(ctypes, v.languages),
            gender={1: "male", 2: "female"}.get(v.gender, ""),
        ))
        i += 1
    return out


def list_voices(lang: str | None = None) -> list[Voice]:
    """espeak-ng voices, all or those speaking ``lang`` (prefix match: "en" lists en-us too)."""
    with _LOCK:
        voices = _list(None)
    if lang is None:
        return voices
    code = normalize_lang(lang)
    return [v for v in voices if any(x == code or x.startswith(code + "-") for x in v.languages)]


def list_variants() -> list[str]:
    """Voice variants (``f3``, ``m2``, ``klatt`` …) usable as ``voice=`` with any language."""
    with _LOCK:
        return sorted(v.identifier.split("/", 1)[-1] for v in _list("variant"))


def normalize_lang(lang: str) -> str:
    """``"en_US"`` → ``"en-us"``."""
    return str(lang).strip().lower().replace("_", "-")


def languages() -> list[str]:
    """Every language code some espeak-ng voice speaks, sorted (read once per process)."""
    if "languages" not in _STATE:
        _STATE["languages"] = sorted({x for v in list_voices() for x in v.languages
                                      if x != "variant"})
    return list(_STATE["languages"])


def check_lang(lang: str) -> str:
    """Return the normalised code or raise ``ParameterError`` listing close languages."""
    code = normalize_lang(lang)
    known = languages()
    if code in known:
        return code
    close = difflib.get_close_matches(code, known, n=5, cutoff=0.5)
    close += [k for k in known if k.split("-")[0] == code.split("-")[0] and k not in close]
    hint = f"; close: {', '.join(close[:6])}" if close else ""
    raise ParameterError(
        f"unknown language {lang!r}{hint} (run 'mimika voices' for all {len(known)} languages)"
    )


def _voice_name(lang: str, voice: str | None) -> str:
    """The name to pass to ``espeak_SetVoiceByName`` for ``lang`` and optional ``voice``."""
    code = check_lang(lang)
    if not voice:
        return code
    v = voice.strip()
    if "+" in v:
        base, var = v.split("+", 1)
        return f"{_voice_name(base, None)}+{_check_variant(var)}"
    if v.lower() in {x.lower() for x in list_variants()}:
        return f"{code}+{_check_variant(v)}"
    by_name = {x.name.lower(): x for x in list_voices()}
    if v.lower() in by_name:
        return by_name[v.lower()].languages[0]
    if normalize_lang(v) in languages():
        return normalize_lang(v)
    names = [*list_variants(), *(x.name for x in list_voices(code))]
    close = difflib.get_close_matches(v, names, n=4, cutoff=0.4)
    hint = f"; did you mean {', '.join(close)}?" if close else ""
    raise ParameterError(
        f"unknown voice {voice!r}{hint} (a variant like 'f3', 'm2' or a voice name; "
        f"run 'mimika voices --lang {code}')"
    )


def _check_variant(var: str) -> str:
    for x in list_variants():
        if x.lower() == var.lower():
            return x
    close = difflib.get_close_matches(var, list_variants(), n=4, cutoff=0.4)
    hint = f"; did you mean {', '.join(close)}?" if close else ""
    raise ParameterError(f"unknown voice variant {var!r}{hint}")


def synth(text: str, *, lang: str = "en", voice: str | None = None, rate: int = 175,
          pitch: int = 50, volume: int = 100, ssml: bool = False,
          phonemes: bool = False) -> RawSynthesis:
    """Synthesise ``text`` with one ``espeak_Synth`` call; returns int16 audio and raw events.

    ``rate`` in words per minute (80–450), ``pitch`` 0–100, ``volume`` 0–200; ``phonemes``:
    ``[[…]]`` in the text holds espeak phoneme mnemonics.
    """
    if not RATE_RANGE[0] <= rate <= RATE_RANGE[1]:
        raise ParameterError(f"rate={rate} must be in {RATE_RANGE[0]}…{RATE_RANGE[1]} wpm")
    if not PITCH_RANGE[0] <= pitch <= PITCH_RANGE[1]:
        raise ParameterError(f"pitch={pitch} must be in {PITCH_RANGE[0]}…{PITCH_RANGE[1]}")
    if not 0 <= volume <= 200:
        raise ParameterError(f"volume={volume} must be in 0…200")
    data = text.encode("utf-8")
    with _LOCK:
        name = _voice_name(lang, voice)
        _fresh()
        lib, _ = _lib()
        lib.espeak_ng_SetRandSeed(RAND_SEED)  # variants (f3, klatt …) draw from rand()
        _STATE["dirty"] = True
        if _STATE["voice"] != name:
            if lib.espeak_SetVoiceByName(name.encode()) != 0:
                raise ParameterError(f"espeak-ng cannot load voice {name!r}")
            _STATE["voice"] = name
        lib.espeak_SetParameter(_RATE, int(rate), 0)
        lib.espeak_SetParameter(_PITCH, int(pitch), 0)
        lib.espeak_SetParameter(_VOLUME, int(volume), 0)
        sink = _STATE["sink"]
        sink["chunks"], sink["events"] = [], []
        flags = _CHARS_UTF8 | (_SSML if ssml else 0) | (_PHONEMES if phonemes else 0)
        err = lib.espeak_Synth(data, len(data) + 1, 0, 0, 0, flags, None, None)
        if err != 0:
            raise DataError(f"espeak_Synth failed with code {err}")
        chunks, events = sink["chunks"], sink["events"]
        sink["chunks"], sink["events"] = [], []
        sr = int(_STATE["sr"])
    audio = np.concatenate(chunks) if chunks else np.zeros(0, np.int16)
    return RawSynthesis(audio=audio.astype(np.int16, copy=False), sr=sr, events=events)


def text_to_phonemes(text: str, *, lang: str = "en") -> list[str]:
    """espeak-ng's phonemes for ``text``, one string per clause: words separated by spaces,
    phonemes by ``|``, stress marks in front (``"h|@|l|'oU w|'3:|l|d"``)."""
    with _LOCK:
        name = _voice_name(lang, None)
        _fresh(after_phonemes=False)
        lib, (ctypes, _) = _lib()
        _STATE["phonemised"] = True
        if _STATE["voice"] != name:
            if lib.espeak_SetVoiceByName(name.encode()) != 0:
                raise ParameterError(f"espeak-ng cannot load voice {name!r}")
            _STATE["voice"] = name
        buf = ctypes.c_char_p(text.encode("utf-8"))
        ptr = ctypes.pointer(buf)
        out: list[str] = []
        while ptr.contents.value:
            r = lib.espeak_TextToPhonemes(ptr, _CHARS_UTF8, ord("|") << 8)
            out.append((r or b"").decode("utf-8", "replace"))
    return out
