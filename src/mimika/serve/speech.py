"""Speech for ``mimika serve``: a ``speak`` text as parts (sentences; an SSML document is one
part), each spoken, animated (mouth, behaviour layers with the mood, the faces asked for) and
turned into its ``frames``, ``audio`` and ``sentence`` messages."""

from __future__ import annotations

import base64
from dataclasses import dataclass
from typing import Any

import numpy as np

from mimika.tracks import AUTrack

FPS = 30.0


@dataclass
class Part:
    """One spoken part: its text, utterance (part-local times) and mouth track."""

    text: str
    utterance: Any
    mouth: AUTrack

    @property
    def duration(self) -> float:
        return self.utterance.duration


def sentences(body: str, ssml: bool, lang: str) -> list[str]:
    """The parts of a ``speak``: the sentences of a text (as ``mimika news`` splits them),
    or the whole SSML document."""
    if ssml:
        return [body]
    from mimika.newsreader.article import article_sentences

    return [s for s, _ in article_sentences(body, lang)]


def speak_part(state: Any, part: str, ssml: bool, *, lang: str, voice: str | None,
               rate: int) -> Part:
    from mimika.speech import mouth_track, synthesize

    with state.espeak_lock:
        u = synthesize(part, lang=lang, voice=voice, rate=rate, ssml=ssml)
    return Part(part, u, mouth_track(u, fps=FPS))


def face_of(mood: str | None) -> dict[str, float]:
    """The AUs of the face a mood sets (``serve/data/faces.json``)."""
    from mimika.knowledge.expressions import get_expression
    from mimika.serve.frames import mood_faces

    spec = mood_faces().get(mood or "neutral")
    return get_expression(spec[0], spec[1]) if spec else {}


def part_messages(part: Part, t0: float, *, index: int, mood: str | None,
                  faces: list[dict[str, float]], start: dict[str, float] | None,
                  mood_face: dict[str, float]) -> tuple[dict, dict, dict, dict[str, float]]:
    """The part's ``frames``, ``audio`` and ``sentence`` messages (times from ``t0`` s) and
    the last behaviour frame (where the next part starts from)."""
    from mimika.behaviour import merge_layers
    from mimika.behaviour.sentences import SPEECH_LAYERS, behaviour_track
    from mimika.serve.frames import frames
    from mimika.speech import combine
    from mimika.speech.export import viseme_cues

    u, mouth = part.utterance, part.mouth
    n = mouth.n_frames
    layers: dict[str, AUTrack] = {}
    beh = behaviour_track(u, fps=FPS, layers=SPEECH_LAYERS, seed=index, start=start, mood=mood)
    if beh is not None and beh.channels:
        layers["behaviour"] = beh
    face: dict[str, float] = dict(mood_face)
    for f in faces:
        for k, v in f.items():
            face[k] = max(face.get(k, 0.0), v)
    if face:
        chans = tuple(face)
        layers["face"] = AUTrack(np.tile(np.array([face[c] for c in chans], np.float32),
                                         (n, 1)), chans, FPS)
    track = mouth
    if layers:
        emotion = next(iter(layers.values())) if len(layers) == 1 else \
            merge_layers(layers, n_frames=n, fps=FPS)
        track = combine(mouth, emotion)
    last = {} if beh is None or not beh.n_frames else \
        dict(zip(beh.channels, (float(x) for x in beh.values[-1]), strict=True))
    pcm = (np.clip(u.audio, -1.0, 1.0) * 32767.0).astype("<i2").tobytes()
    frames_msg = {"type": "frames", "index": index, "relative": False, "t0": round(t0, 4),
                  "fps": FPS, "frames": frames(track, t0=t0, cues=viseme_cues(u))}
    audio_msg = {"type": "audio", "index": index, "t": round(t0, 4), "sr": int(u.sr),
                 "format": "s16le", "samples": len(u.audio),
                 "data": base64.b64encode(pcm).decode("ascii")}
    sentence_msg = {"type": "sentence", "index": index, "text": part.text if not
                    u.meta.get("ssml") else u.text, "start": round(t0, 4),
                    "end": round(t0 + part.duration, 4),
                    "words": [{"text": w.text, "start": round(t0 + w.start, 4),
                               "end": round(t0 + w.end, 4)} for w in u.words]}
    return frames_msg, audio_msg, sentence_msg, last
