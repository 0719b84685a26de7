"""Speech for the studio: synthesise sentence by sentence, mix each sentence's mouth track
with the project's timeline, and serialise audio and frames for the page."""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from mimika.studio.state import SpeechEntry, SpeechSegment, StudioState

log = logging.getLogger(__name__)


def speak_request(text: str, project: Any, *, fps: float) -> Any:
    """The :class:`SpeakRequest` for a project's text; a text over the studio's limit is
    refused (never cut)."""
    from mimika.errors import ParameterError
    from mimika.studio.schemas import MAX_TEXT, SpeakRequest

    if len(text) > MAX_TEXT:
        raise ParameterError(f"the text is {len(text):,} characters long; the studio speaks at "
                             f"most {MAX_TEXT:,} at a time: shorten it or split it into two "
                             "projects")
    return SpeakRequest(text=text, lang=str(project.settings.get("lang", "en")), fps=fps)


def synth_segment(state: StudioState, text: str, char0: int, t0: float, *, lang: str,
                  rate: int, fps: float) -> SpeechSegment:
    """Synthesise one sentence (the default voice for ``lang``, serialised; kept by the
    state, so a sentence is synthesised once whatever text it comes in) and its mouth
    track."""
    from mimika.speech import mouth_track, synthesize

    key = (text, lang, rate)
    utt = state.sentence(key)
    if utt is None:
        with state.espeak_lock:
            utt = state.sentence(key)  # a request waiting for the lock may find it made
            if utt is None:
                utt = synthesize(text, lang=lang, rate=rate)
                state.put_sentence(key, utt)
    return SpeechSegment(text, char0, t0, utt, mouth_track(utt, fps=fps))


def warm(state: StudioState) -> None:
    """Load the voice and the behaviour layers' data, so the first Speak is quick."""
    from mimika.behaviour.sentences import SPEECH_LAYERS, behaviour_track

    seg = synth_segment(state, "Good evening.", 0, 0.0, lang="en", rate=175, fps=30.0)
    behaviour_track(seg.utterance, fps=30.0, layers=SPEECH_LAYERS)


def synth_all(state: StudioState, entry: SpeechEntry, *, fps: float) -> SpeechEntry:
    """Fill ``entry`` with every sentence of its text (for the non-streaming endpoints)."""
    from mimika.newsreader.article import article_sentences

    t0 = 0.0
    for sent, char0 in article_sentences(entry.text, entry.lang):
        seg = synth_segment(state, sent, char0, t0, lang=entry.lang, rate=entry.rate, fps=fps)
        entry.segments.append(seg)
        t0 += seg.duration
    entry.done = True
    return entry


@dataclass(frozen=True)
class Mix:
    """What a project adds to speech: its timeline, behaviour layers and AU Blender settings."""

    timeline: Any = None
    layers: tuple[str, ...] = ()
    blend: bool = False
    disabled: tuple[str, ...] = ()
    library: Any = None


def mix_of(project: dict[str, Any] | None, state: StudioState | None = None, *,
           blend: bool | None = None) -> Mix:
    """The :class:`Mix` of a project document (validated; None: speech only).

    ``blend`` overrides the project's AU Blender switch (the page sends its checkbox)."""
    if not project:
        return Mix(blend=bool(blend))
    from mimika.behaviour.sentences import SPEECH_LAYERS
    from mimika.markup.project import project_from_dict

    proj = project_from_dict(project, source="project")
    st = proj.settings
    layers = st.get("behaviour", [])
    layers = tuple(x for x in SPEECH_LAYERS if isinstance(layers, list) and x in layers)
    off = st.get("blender_off", [])
    off = tuple(str(x) for x in off) if isinstance(off, list) else ()
    return Mix(proj.timeline, layers, bool(st.get("blend")) if blend is None else blend, off,
               state.library() if state is not None else None)


def segment_behaviour(segments: list[SpeechSegment], index: int, mix: Mix, *, fps: float
                      ) -> Any:
    """Behaviour track of sentence ``index`` (cached; sentences join without a jump)."""
    from mimika.behaviour.sentences import behaviour_track

    if not mix.layers:
        return None
    key = (mix.layers, round(fps, 6))
    seg = segments[index]
    if key not in seg.behaviour:
        start = None
        if index > 0:
            prev = segment_behaviour(segments, index - 1, mix, fps=fps)
            if prev is not None and prev.n_frames:
                start = dict(zip(prev.channels, (float(x) for x in prev.values[-1]),
                                 strict=True))
        seg.behaviour[key] = behaviour_track(seg.utterance, fps=fps, layers=mix.layers,
                                             seed=index, start=start)
    return seg.behaviour[key]


def _fit(track: Any, n: int) -> Any:
    from mimika.tracks import AUTrack

    v = track.values[:n]
    if len(v) < n:
        v = np.concatenate([v, np.repeat(v[-1:], n - len(v), axis=0)]) if len(v) else \
            np.zeros((n, len(track.channels)), np.float32)
    return AUTrack(v, track.channels, track.fps, dict(track.meta))


def segment_track(seg: SpeechSegment, mix: Mix, *, fps: float, behaviour: Any = None) -> Any:
    """The sentence's AU track: its mouth mixed with the behaviour layers and the timeline
    over the same seconds (as the newsreader mixes speech, behaviour and script)."""
    from mimika.speech import combine, mouth_track
    from mimika.tracks import AUTrack

    mouth = seg.mouth if math.isclose(seg.mouth.fps, fps) else mouth_track(seg.utterance, fps=fps)
    n = mouth.n_frames
    parts = {}
    if behaviour is not None and behaviour.channels:
        parts["behaviour"] = _fit(behaviour, n)
    tl = mix.timeline
    if tl is not None and tl.channels:
        from mimika.timeline import sample_times

        vals, codes = sample_times(tl, seg.t0 + np.arange(n) / fps, library=mix.library)
        if codes:
            parts["timeline"] = AUTrack(vals.astype(np.float32), codes, fps)
    if not parts:
        return mouth
    if len(parts) == 1:
        emotion = next(iter(parts.values()))
    else:
        from mimika.behaviour import merge_layers

        emotion = merge_layers(parts)
    return combine(mouth, emotion)


def blended(values: np.ndarray, chans: Any, mix: Mix) -> tuple[np.ndarray, Any]:
    if not (mix.blend and len(chans)):
        return values, chans
    from mimika.facs.blender import blend_frames

    return blend_frames(values, chans, disabled=mix.disabled)


def segment_frames(seg: SpeechSegment, mix: Mix, *, fps: float, behaviour: Any = None
                   ) -> dict[str, Any]:
    """The sentence's frames for the page: :func:`segment_track`, blended if asked."""
    track = segment_track(seg, mix, fps=fps, behaviour=behaviour)
    values, chans = blended(track.values, track.channels, mix)
    return {"type": "frames", "t0": round(seg.t0, 6), "fps": fps, "channels": list(chans),
            "values": np.round(np.asarray(values, np.float64), 4).tolist()}


def entry_frames(entry: SpeechEntry, mix: Mix, *, fps: float) -> list[dict[str, Any]]:
    """Frames of every sentence of ``entry``."""
    return [segment_frames(s, mix, fps=fps,
                           behaviour=segment_behaviour(entry.segments, i, mix, fps=fps))
            for i, s in enumerate(entry.segments)]


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


def entry_track(entry: SpeechEntry, mix: Mix, *, fps: float) -> Any:
    """One AUTrack over the whole utterance (+ the timeline after the speech ends)."""
    from mimika.tracks import AUTrack

    segs = [segment_track(s, mix, fps=fps,
                          behaviour=segment_behaviour(entry.segments, i, mix, fps=fps))
            for i, s in enumerate(entry.segments)]
    tl = mix.timeline
    speech_end = entry.duration
    tl_end = tl.end if tl is not None else 0.0
    from mimika.limits import check_timeline

    n = check_timeline(max(speech_end, tl_end), fps, "the speech and timeline")
    t = np.arange(n) / fps
    chans: list[str] = []
    for s in segs:
        chans += [c for c in s.channels if c not in chans]
    tl_vals, tl_codes = (None, ())
    if tl is not None and tl.channels:
        from mimika.timeline import sample_times

        tl_vals, tl_codes = sample_times(tl, t, library=mix.library)
        chans += [c for c in tl_codes if c not in chans]
    out = np.zeros((n, len(chans)), np.float32)
    col = {c: j for j, c in enumerate(chans)}
    if tl_vals is not None:
        for j, c in enumerate(tl_codes):
            out[:, col[c]] = tl_vals[:, j]
    for seg, s in zip(entry.segments, segs, strict=True):
        i0 = round(seg.t0 * fps)
        i1 = min(n, i0 + s.n_frames)
        for j, c in enumerate(s.channels):
            out[i0:i1, col[c]] = s.values[: i1 - i0, j]
    track = AUTrack(out, tuple(chans), fps, {"source": "studio"})
    if mix.blend and chans:
        from mimika.facs.blender import blend_track

        track = blend_track(track, disabled=mix.disabled)
    return track
