"""Speech for the studio: synthesise sentence by sentence, mix each sentence's mouth track
with the project's timeline, and serialise audio and frames for the page."""

from __future__ import annotations

import logging
import math
from typing import Any

import numpy as np

from mimika.studio.state import SpeechEntry, SpeechSegment, StudioState

log = logging.getLogger(__name__)


def sentences(text: str) -> list[tuple[str, int]]:
    """``[(sentence, char_offset)]`` as the TTS splits them."""
    from mimika.errors import ParameterError
    from mimika.speech.tts import split_sentences

    out = split_sentences(text)
    if not out:
        raise ParameterError("text is empty; type something to speak")
    return out


def synth_segment(state: StudioState, text: str, char0: int, t0: float, *, lang: str,
                  rate: int, fps: float) -> SpeechSegment:
    """Synthesise one sentence (espeak-ng, serialised) and its mouth track."""
    from mimika.speech import mouth_track, synthesize

    with state.espeak_lock:
        utt = synthesize(text, lang=lang, rate=rate)
    return SpeechSegment(text, char0, t0, utt, mouth_track(utt, fps=fps))


def synth_all(state: StudioState, entry: SpeechEntry, *, fps: float) -> SpeechEntry:
    """Fill ``entry`` with every sentence of its text (for the non-streaming endpoints)."""
    t0 = 0.0
    for sent, char0 in sentences(entry.text):
        seg = synth_segment(state, sent, char0, t0, lang=entry.lang, rate=entry.rate, fps=fps)
        entry.segments.append(seg)
        t0 += seg.duration
    entry.done = True
    return entry


def timeline_of(project: dict[str, Any] | None) -> Any:
    """The validated timeline of a project document (None for none)."""
    if not project:
        return None
    from mimika.markup.project import project_from_dict

    return project_from_dict(project, source="project").timeline


def segment_frames(seg: SpeechSegment, timeline: Any, *, fps: float, blend: bool = False
                   ) -> dict[str, Any]:
    """The sentence's frames: mouth AUs mixed with the timeline's AUs over the same seconds."""
    from mimika.speech import combine, mouth_track
    from mimika.tracks import AUTrack

    mouth = seg.mouth if math.isclose(seg.mouth.fps, fps) else mouth_track(seg.utterance, fps=fps)
    track = mouth
    if timeline is not None and timeline.channels:
        from mimika.timeline import sample_times

        times = seg.t0 + np.arange(mouth.n_frames) / fps
        vals, codes = sample_times(timeline, times)
        if codes:
            track = combine(mouth, AUTrack(vals.astype(np.float32), codes, fps))
    values, chans = track.values, track.channels
    if blend and len(chans):
        from mimika.facs.blender import blend_frames

        values, chans = blend_frames(values, chans)
    return {"type": "frames", "t0": round(seg.t0, 6), "fps": fps, "channels": list(chans),
            "values": np.round(np.asarray(values, np.float64), 4).tolist()}


def segment_info(seg: SpeechSegment, index: int) -> dict[str, Any]:
    """Subtitle data of one sentence: its text, start/end and words (whole-utterance times)."""
    u = seg.utterance
    return {"type": "sentence", "index": index, "text": seg.text, "start": round(seg.t0, 4),
            "end": round(seg.t0 + seg.duration, 4), "sr": int(u.sr),
            "words": [{"text": w.text, "start": round(seg.t0 + w.start, 4),
                       "end": round(seg.t0 + w.end, 4)} for w in u.words]}


def pcm16(seg: SpeechSegment) -> bytes:
    """The sentence's audio as little-endian int16 PCM."""
    a = np.clip(np.asarray(seg.utterance.audio, np.float32), -1.0, 1.0)
    return (a * 32767.0).astype("<i2").tobytes()


def wav_bytes(entry: SpeechEntry) -> bytes:
    """The whole utterance as a 16-bit mono WAV file."""
    import io
    import wave

    audio, sr = entry.audio()
    buf = io.BytesIO()
    with wave.open(buf, "wb") as w:
        w.setnchannels(1)
        w.setsampwidth(2)
        w.setframerate(sr)
        w.writeframes((np.clip(audio, -1, 1) * 32767.0).astype("<i2").tobytes())
    return buf.getvalue()


def entry_track(entry: SpeechEntry, timeline: Any, *, fps: float, blend: bool) -> Any:
    """One AUTrack over the whole utterance (+ the timeline after the speech ends)."""
    from mimika.tracks import AUTrack

    segs = [segment_frames(s, timeline, fps=fps, blend=False) for s in entry.segments]
    from mimika.limits import check_timeline

    speech_end = entry.duration
    tl_end = timeline.end if timeline is not None else 0.0
    n = check_timeline(max(speech_end, tl_end), fps, "the speech and timeline")
    t = np.arange(n) / fps
    chans: list[str] = []
    for s in segs:
        chans += [c for c in s["channels"] if c not in chans]
    tl_vals, tl_codes = (None, ())
    if timeline is not None and timeline.channels:
        from mimika.timeline import sample_times

        tl_vals, tl_codes = sample_times(timeline, t)
        chans += [c for c in tl_codes if c not in chans]
    out = np.zeros((n, len(chans)), np.float32)
    col = {c: j for j, c in enumerate(chans)}
    if tl_vals is not None:
        for j, c in enumerate(tl_codes):
            out[:, col[c]] = tl_vals[:, j]
    for s in segs:
        v = np.asarray(s["values"], np.float32)
        i0 = round(s["t0"] * fps)
        i1 = min(n, i0 + len(v))
        for j, c in enumerate(s["channels"]):
            out[i0:i1, col[c]] = v[: i1 - i0, j]
    track = AUTrack(out, tuple(chans), fps, {"source": "studio"})
    if blend and chans:
        from mimika.facs.blender import blend_track

        track = blend_track(track)
    return track
