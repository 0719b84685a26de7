"""Viseme files for other players: TalkingHead, Rhubarb Lip Sync, Meta/Unity (OVRLipSync).

The input is a list of cues ``{"start", "end", "value"}`` (seconds) in the Oculus-15 set
(``sil PP FF TH DD kk CH SS nn RR aa E ih oh ou``) or Rhubarb's ``A``–``H``, ``X``, as
:func:`mimika.speech.export.viseme_cues` makes them. Each writer produces what its player
reads:

* **TalkingHead** ``speakAudio`` object: ``visemes``/``vtimes``/``vdurations`` (ms) and the
  words; viseme names from TalkingHead's ``visemeNames`` (``I O U`` where Oculus says
  ``ih oh ou`` — TalkingHead looks up the morph ``viseme_`` + name and skips unknown ones).
* **Rhubarb** JSON: ``metadata.soundFile`` (absolute, as Rhubarb writes it) and ``duration``,
  ``mouthCues`` contiguous from 0 to the duration in centiseconds, ending on ``X`` (rest).
* **OVRLipSync** per-frame weights of the 15 visemes: the JSON of an ``OVRLipSyncSequence``
  (``entries`` of ``Frame`` {frameNumber, frameDelay, Visemes, laughterScore} and ``length``,
  played by ``OVRLipSyncContextCanned`` via ``GetFrameAtTime``) or a plain CSV
  ``time,sil,PP,…,ou``. Frame i covers [i, i+1)·length/N; its weights are the share of that
  interval each viseme holds (they sum to 1).

Readers for these files (:func:`read_rhubarb_json`, :func:`read_viseme_weights`) check them
and raise :class:`~mimika.errors.DataError` with the place of the problem.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from mimika.errors import DataError, ParameterError
from mimika.io.atomic import atomic_write
from mimika.io.csvread import check_frames, num, read_table

__all__ = ["OCULUS_15", "RHUBARB_SHAPES", "TALKINGHEAD_VISEMES", "ovr_sequence",
           "read_rhubarb_json", "read_viseme_weights", "rhubarb_document", "talkinghead_document",
           "talkinghead_name", "viseme_frames", "write_viseme_weights"]

#: the Oculus/Meta viseme set, in OVRLipSync's order (``Frame.Visemes`` indices)
OCULUS_15 = ("sil", "PP", "FF", "TH", "DD", "kk", "CH", "SS", "nn", "RR", "aa", "E", "ih", "oh",
             "ou")
#: TalkingHead's ``visemeNames`` (talkinghead.mjs)
TALKINGHEAD_VISEMES = ("aa", "E", "I", "O", "U", "PP", "SS", "TH", "DD", "FF", "kk", "nn", "RR",
                       "CH", "sil")
#: Rhubarb's mouth shapes (A–F basic, G H extended, X idle)
RHUBARB_SHAPES = ("A", "B", "C", "D", "E", "F", "G", "H", "X")
_TH = {"ih": "I", "oh": "O", "ou": "U"}
_MAX_JSON = 64 * 1024 * 1024


def talkinghead_name(oculus: str) -> str:
    """An Oculus viseme's name in TalkingHead (``ih`` → ``I``, ``oh`` → ``O``, ``ou`` → ``U``)."""
    if oculus not in OCULUS_15:
        raise ParameterError(f"{oculus!r} is not an Oculus viseme ({' '.join(OCULUS_15)})")
    return _TH.get(oculus, oculus)


def talkinghead_document(cues: Sequence[dict], words: Sequence[tuple[str, float, float]]
                         ) -> dict[str, list]:
    """TalkingHead's ``speakAudio`` fields (without the audio); silence cues are left out (the
    mouth rests between visemes). ``words``: (text, start s, end s)."""
    vis = [c for c in cues if c["value"] != "sil"]
    return {"words": [w for w, _, _ in words],
            "wtimes": [round(s * 1000) for _, s, _ in words],
            "wdurations": [round((e - s) * 1000) for _, s, e in words],
            "visemes": [talkinghead_name(c["value"]) for c in vis],
            "vtimes": [round(c["start"] * 1000) for c in vis],
            "vdurations": [round((c["end"] - c["start"]) * 1000) for c in vis]}


def rhubarb_document(cues: Sequence[dict], *, duration: float, sound_file: str = ""
                     ) -> dict[str, Any]:
    """Rhubarb Lip Sync's JSON for ``cues`` (values ``A``–``H``, ``X``) over ``duration`` s."""
    end_all = round(duration, 2)
    out: list[dict] = []

    def put(s: float, e: float, v: str) -> None:
        if e <= s:
            return
        if out and out[-1]["value"] == v:
            out[-1]["end"] = e
            return
        if out and out[-1]["end"] < s:  # a hole: the mouth rests
            put(out[-1]["end"], s, "X")
        if out:
            s = out[-1]["end"]
        out.append({"start": s, "end": e, "value": v})

    if cues and round(cues[0]["start"], 2) > 0:
        put(0.0, round(cues[0]["start"], 2), "X")
    for c in cues:
        if c["value"] not in RHUBARB_SHAPES:
            raise ParameterError(f"{c['value']!r} is not a Rhubarb mouth shape")
        put(round(c["start"], 2), min(round(c["end"], 2), end_all), c["value"])
    if not out:
        out.append({"start": 0.0, "end": end_all, "value": "X"})
    if out[-1]["end"] < end_all:
        put(out[-1]["end"], end_all, "X")
    if out[-1]["value"] != "X":  # Rhubarb ends at rest: the last centisecond closes the mouth
        last = out[-1]
        cut = round(last["end"] - 0.01, 2)
        if cut > last["start"]:
            last["end"] = cut
            out.append({"start": cut, "end": end_all, "value": "X"})
    sound = str(Path(sound_file).resolve()) if sound_file else ""
    return {"metadata": {"soundFile": sound, "duration": end_all}, "mouthCues": out}


def viseme_frames(cues: Sequence[dict], *, fps: float, duration: float) -> np.ndarray:
    """Per-frame weights (N, 15) of the Oculus visemes: frame i covers
    [i/fps, (i+1)/fps) and each viseme's weight is the share of that interval it holds (time
    no cue covers counts as ``sil``). N = ceil(duration·fps)."""
    if not (math.isfinite(fps) and fps > 0 and math.isfinite(duration) and duration >= 0):
        raise ParameterError(f"fps={fps!r} and duration={duration!r} must be positive numbers")
    n = max(1, math.ceil(duration * fps - 1e-9))
    check_frames(n, "viseme weights", "the utterance")
    w = np.zeros((n, len(OCULUS_15)))
    edges = np.arange(n + 1) / fps
    for c in cues:
        j = OCULUS_15.index(c["value"]) if c["value"] in OCULUS_15 else None
        if j is None:
            raise ParameterError(f"{c['value']!r} is not an Oculus viseme")
        lo = np.clip(edges[:-1], c["start"], c["end"])
        hi = np.clip(edges[1:], c["start"], c["end"])
        w[:, j] += (hi - lo) * fps
    w[:, 0] += np.clip(1.0 - w.sum(axis=1), 0.0, 1.0)
    return w / w.sum(axis=1, keepdims=True)


def ovr_sequence(weights: np.ndarray, *, length: float) -> dict[str, Any]:
    """An ``OVRLipSyncSequence`` as JSON (Unity's ``JsonUtility`` field names)."""
    delay = round(1000 * length / max(len(weights), 1))
    return {"entries": [{"frameNumber": i, "frameDelay": delay,
                         "Visemes": [round(float(x), 4) for x in row], "laughterScore": 0.0}
                        for i, row in enumerate(weights)],
            "length": round(float(length), 4)}


def write_viseme_weights(path: str | os.PathLike, cues: Sequence[dict], *, fps: float,
                         duration: float) -> Path:
    """Per-frame Oculus viseme weights: ``.json`` (OVRLipSyncSequence) or ``.csv``."""
    p = Path(path)
    w = viseme_frames(cues, fps=fps, duration=duration)
    if p.suffix.lower() == ".json":
        return atomic_write(p, json.dumps(ovr_sequence(w, length=duration), indent=1))
    if p.suffix.lower() != ".csv":
        raise ParameterError(f"viseme weights {str(p)!r} must end in .json or .csv")
    buf = io.StringIO()
    out = csv.writer(buf, lineterminator="\n")
    out.writerow(["time", *OCULUS_15])
    for i, row in enumerate(w):
        out.writerow([f"{i / fps:.4f}", *(f"{x:.4f}" for x in row)])
    return atomic_write(p, buf.getvalue())


# -- reading --------------------------------------------------------------------------------------
def _load_json(path: str | os.PathLike) -> Any:
    p = Path(path)
    try:
        if p.stat().st_size > _MAX_JSON:
            raise DataError(f"{p}: {p.stat().st_size:,} bytes is too large for a viseme file")
        return json.loads(p.read_text("utf-8-sig"))
    except FileNotFoundError:
        raise DataError(f"{p} does not exist") from None
    except UnicodeDecodeError:
        raise DataError(f"{p}: not UTF-8 text") from None
    except json.JSONDecodeError as e:
        raise DataError(f"{p}:{e.lineno}:{e.colno}: not JSON ({e.msg})") from None
    except RecursionError:
        raise DataError(f"{p}: the JSON is nested too deeply") from None
    except OSError as e:
        raise DataError(f"cannot read {p}: {e.strerror or e}") from None


def _number(p, where: str, v: Any) -> float:
    try:
        f = float(v) if isinstance(v, int | float) and not isinstance(v, bool) else math.nan
    except OverflowError:
        f = math.inf
    if not math.isfinite(f):
        shown = repr(v) if len(repr(v)) <= 40 else repr(v)[:40] + "…"
        raise DataError(f"{p}: {where}: {shown} is not a finite number")
    return f


def read_rhubarb_json(path: str | os.PathLike) -> tuple[float, list[dict]]:
    """Rhubarb JSON → (duration, cues); cues must be ordered, non-overlapping shapes A–H, X."""
    doc = _load_json(path)
    if not isinstance(doc, dict) or not isinstance(doc.get("mouthCues"), list):
        raise DataError(f"{path}: not Rhubarb JSON (expected an object with 'mouthCues')")
    meta = doc.get("metadata", {})
    duration = _number(path, "metadata.duration", meta.get("duration", 0.0)) \
        if isinstance(meta, dict) else 0.0
    cues = []
    for i, c in enumerate(doc["mouthCues"]):
        where = f"mouthCues[{i}]"
        if not isinstance(c, dict):
            raise DataError(f"{path}: {where} is not an object")
        s, e = _number(path, f"{where}.start", c.get("start")), \
            _number(path, f"{where}.end", c.get("end"))
        v = c.get("value")
        if v not in RHUBARB_SHAPES:
            raise DataError(f"{path}: {where}.value {v!r} is not a Rhubarb shape (A–H, X)")
        if e < s or (cues and s < cues[-1]["end"] - 1e-9):
            raise DataError(f"{path}: {where} ({s:g}–{e:g} s) is out of order")
        cues.append({"start": s, "end": e, "value": v})
    return max(duration, cues[-1]["end"] if cues else 0.0), cues


def read_viseme_weights(path: str | os.PathLike) -> tuple[np.ndarray, float]:
    """Per-frame Oculus viseme weights (``.json`` OVRLipSyncSequence or ``.csv``) →
    (weights (N, 15), length in seconds)."""
    p = Path(path)
    if p.suffix.lower() == ".json":
        doc = _load_json(p)
        if not isinstance(doc, dict) or not isinstance(doc.get("entries"), list):
            raise DataError(f"{p}: not an OVRLipSyncSequence (expected 'entries' and 'length')")
        length = _number(p, "length", doc.get("length"))
        check_frames(len(doc["entries"]), p)
        rows = []
        for i, e in enumerate(doc["entries"]):
            v = e.get("Visemes") if isinstance(e, dict) else None
            if not isinstance(v, list) or len(v) != len(OCULUS_15):
                raise DataError(f"{p}: entries[{i}].Visemes must list {len(OCULUS_15)} weights")
            rows.append([_number(p, f"entries[{i}].Visemes[{j}]", x) for j, x in enumerate(v)])
        w = np.array(rows, np.float64).reshape(len(rows), len(OCULUS_15))
    else:
        t = read_table(p)
        if t.header != ["time", *OCULUS_15]:
            raise DataError(f"{p}:1: expected the header time,{','.join(OCULUS_15)}")
        check_frames(len(t.rows), p)
        times, rows = [], []
        for line, r in t.rows:
            if len(r) != len(t.header):
                raise DataError(f"{p}:{line}: {len(r)} fields, but the header has "
                                f"{len(t.header)}")
            times.append(num(p, line, "time", r[0]))
            rows.append([num(p, line, n, x) for n, x in zip(OCULUS_15, r[1:], strict=True)])
        w = np.array(rows, np.float64).reshape(len(rows), len(OCULUS_15))
        step = (times[-1] - times[0]) / (len(times) - 1) if len(times) > 1 else 0.0
        if len(times) > 1 and (step <= 0 or np.any(np.abs(np.diff(times) - step) > 1e-3)):
            raise DataError(f"{p}: the time column must rise in equal steps")
        length = len(times) * step
    if np.any(w < -1e-6) or np.any(w > 1 + 1e-6):
        raise DataError(f"{p}: viseme weights must be within [0, 1]")
    return w, length
