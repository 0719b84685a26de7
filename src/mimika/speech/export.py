"""Exports of one utterance's timing: viseme cues (Oculus-15, Rhubarb A–X, MPEG-4, TalkingHead,
OVRLipSync per-frame weights), seed 004's five mouth parameters, and AU CSV.

The file layouts other players read live in :mod:`mimika.io.visemes`.

Cue boundaries sit at phoneme (segment) starts; consecutive equal visemes are merged.
Glottal /h ʔ/ take the viseme of the following sound (the lips already shape it).
"""

from __future__ import annotations

import csv
import io
import json
import os
from typing import Any

import numpy as np

from mimika.errors import ParameterError
from mimika.io import visemes as vfiles
from mimika.speech.phonemes import Segment, segments, viseme_table
from mimika.speech.utterance import Utterance, write_text_atomic
from mimika.tracks import AUTrack

FORMATS = ("oculus", "rhubarb", "mpeg4", "seed004", "talkinghead", "ovr")


def viseme_cues(utterance: Utterance, *, format: str = "oculus") -> list[dict[str, Any]]:
    """Viseme cues ``[{"start", "end", "value", "phonemes"}]`` (seconds) in ``format``
    (``oculus`` → names like ``PP``, ``rhubarb`` → ``A``…``X``, ``mpeg4`` → 0–14)."""
    key = {"oculus": "oculus", "rhubarb": "rhubarb", "mpeg4": "mpeg4",
           "talkinghead": "oculus", "ovr": "oculus"}.get(format)
    if key is None:
        raise ParameterError(f"viseme format {format!r} is not one of oculus, rhubarb, mpeg4")
    classes = viseme_table()["classes"]
    segs = segments(utterance)
    vals: list[Any] = []
    for i, s in enumerate(segs):
        c = s.cls
        if classes[c].get("transparent"):
            nxt = next((x.cls for x in segs[i + 1:] if not classes[x.cls].get("transparent")),
                       "sil")
            if nxt != "sil":
                c = nxt
        vals.append(classes[c][key])
    cues: list[dict[str, Any]] = []
    for s, v in zip(segs, vals, strict=True):
        if s.duration <= 0:
            continue
        if cues and cues[-1]["value"] == v:
            cues[-1]["end"] = s.end
            if cues[-1]["phonemes"][-1] != s.symbol or s.phone != cues[-1]["_phone"]:
                cues[-1]["phonemes"].append(s.symbol)
        else:
            cues.append({"start": s.start, "end": s.end, "value": v, "phonemes": [s.symbol]})
        cues[-1]["_phone"] = s.phone
    for c in cues:
        del c["_phone"]
    return cues


def rhubarb_json(utterance: Utterance, *, sound_file: str = "") -> dict[str, Any]:
    """Rhubarb Lip Sync's JSON (:func:`mimika.io.visemes.rhubarb_document`): cues from 0 to
    the end in centiseconds, ending on ``X``; ``soundFile`` absolute as Rhubarb writes it."""
    return vfiles.rhubarb_document(viseme_cues(utterance, format="rhubarb"),
                                   duration=utterance.duration, sound_file=sound_file)


def seed004_keyframes(utterance: Utterance, track: AUTrack | None = None) -> list[dict]:
    """Seed 004's five mouth parameters at every segment centre (keyframes for linear
    interpolation): ``[{"time", "phoneme", "mouthWidth", "mouthHeight", "lipTension",
    "upperTeethVisible", "lowerTeethVisible"}]``; computed from the coarticulated mouth track."""
    from mimika.speech.coarticulation import mouth_track

    tr = track if track is not None else mouth_track(utterance, fps=100)
    spec = {k: v for k, v in viseme_table()["seed004"].items() if k != "about"}
    out = []
    for s in segments(utterance):
        t = 0.5 * (s.start + s.end)
        f = t * tr.fps
        i0 = int(np.clip(np.floor(f), 0, tr.n_frames - 1))
        i1 = min(i0 + 1, tr.n_frames - 1)
        a = float(np.clip(f - i0, 0, 1))
        row = (1 - a) * tr.values[i0] + a * tr.values[i1]
        au = dict(zip(tr.channels, row.tolist(), strict=True))
        kf: dict[str, Any] = {"time": round(t, 4), "phoneme": s.symbol}
        for name, p in spec.items():
            v = sum(w * au.get(k, 0.0) for k, w in p["weights"].items())
            kf[name] = round(float(np.clip(v, *p["range"])), 4)
        out.append(kf)
    return out


def viseme_document(utterance: Utterance, *, format: str = "oculus", sound_file: str = "",
                    track: AUTrack | None = None, fps: float = 100.0) -> dict[str, Any]:
    """The JSON document ``mimika say --visemes`` writes for ``format`` (docs/speech.md);
    ``ovr`` is an OVRLipSyncSequence with frames at ``fps``."""
    if format not in FORMATS:
        raise ParameterError(f"viseme format {format!r} must be one of {', '.join(FORMATS)}")
    if format == "rhubarb":
        return rhubarb_json(utterance, sound_file=sound_file)
    meta = {"soundFile": sound_file, "duration": round(utterance.duration, 4),
            "lang": utterance.lang, "text": utterance.text}
    if format == "seed004":
        return {"format": "mimika-visemes", "version": 1, "visemes": "seed004",
                "metadata": meta, "parameters": [k for k in viseme_table()["seed004"]
                                                 if k != "about"],
                "keyframes": seed004_keyframes(utterance, track)}
    if format == "talkinghead":
        words = [(w.text, w.start, w.end) for w in utterance.words if w.text]
        return vfiles.talkinghead_document(viseme_cues(utterance, format="oculus"), words)
    if format == "ovr":
        w = vfiles.viseme_frames(viseme_cues(utterance, format="oculus"), fps=fps,
                                 duration=utterance.duration)
        return vfiles.ovr_sequence(w, length=utterance.duration)
    cues = viseme_cues(utterance, format=format)
    names = viseme_table()[format]
    return {"format": "mimika-visemes", "version": 1, "visemes": format, "metadata": meta,
            "inventory": names,
            "cues": [{"start": round(c["start"], 4), "end": round(c["end"], 4),
                      "value": c["value"],
                      **({"name": names[str(c["value"])]} if format == "mpeg4" else {}),
                      "phonemes": c["phonemes"]} for c in cues]}


def write_visemes(path: str | os.PathLike, utterance: Utterance, *, format: str = "oculus",
                  sound_file: str = "", track: AUTrack | None = None,
                  fps: float = 100.0) -> None:
    """Write :func:`viseme_document` as JSON (atomically); a ``.csv`` path gets the per-frame
    Oculus viseme weights at ``fps`` (formats ``oculus`` and ``ovr``)."""
    if str(path).lower().endswith(".csv"):
        if format not in ("oculus", "ovr"):
            raise ParameterError(f"a .csv viseme file holds per-frame Oculus weights; "
                                 f"--format {format} writes JSON")
        vfiles.write_viseme_weights(path, viseme_cues(utterance, format="oculus"), fps=fps,
                                    duration=utterance.duration)
        return
    doc = viseme_document(utterance, format=format, sound_file=sound_file, track=track, fps=fps)
    write_text_atomic(path, json.dumps(doc, ensure_ascii=False, indent=1))


def au_csv_text(track: AUTrack) -> str:
    """AU track as CSV: header ``time,AU10,…``, time in seconds, values with 4 decimals."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["time", *track.channels])
    for t, row in zip(track.times, track.values, strict=True):
        w.writerow([f"{t:.4f}", *(f"{x:.4f}" for x in row)])
    return buf.getvalue()


def write_au_csv(path: str | os.PathLike, track: AUTrack) -> None:
    """Write :func:`au_csv_text` (atomically)."""
    write_text_atomic(path, au_csv_text(track))


def segment_starts(utterance: Utterance) -> list[float]:
    """Start times of all class segments (where cues may begin)."""
    return [s.start for s in segments(utterance)]


__all__ = ["FORMATS", "Segment", "au_csv_text", "rhubarb_json", "seed004_keyframes",
           "segment_starts", "viseme_cues", "viseme_document", "write_au_csv", "write_visemes"]
