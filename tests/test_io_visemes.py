"""Viseme files as their players read them: TalkingHead's speakAudio, a Rhubarb cue player and
Unity's OVRLipSyncSequence — our export → the player's logic → back, per viseme."""

import itertools
import json
from pathlib import Path

import numpy as np
import pytest

from mimika.errors import DataError
from mimika.io.visemes import (
    OCULUS_15,
    TALKINGHEAD_VISEMES,
    read_rhubarb_json,
    read_viseme_weights,
    rhubarb_document,
    talkinghead_document,
    viseme_frames,
    write_viseme_weights,
)

#: a sentence's worth of Oculus cues: every viseme, silence at both ends
OCULUS_CUES = [{"start": round(0.05 * i, 3), "end": round(0.05 * (i + 1), 3), "value": v}
               for i, v in enumerate(["sil", "PP", "aa", "ih", "oh", "ou", "E", "FF", "TH", "DD",
                                      "kk", "CH", "SS", "nn", "RR", "ih", "ou", "sil"])]
RHUBARB_CUES = [{"start": 0.0, "end": 0.12, "value": "X"}, {"start": 0.12, "end": 0.2,
                "value": "A"}, {"start": 0.2, "end": 0.333, "value": "D"},
                {"start": 0.333, "end": 0.41, "value": "B"}]


def talkinghead_frames(doc, morphs, fps=1000):
    """TalkingHead's speakAudio(r) for r.visemes: each viseme becomes an animation keyed at
    ts = [t − 2d/3, t + d/2, t + 3d/2] (ms) on the morph 'viseme_' + name, peaking at 0.9 for
    PP/FF and 0.6 otherwise; a name without such a morph target moves nothing. Returns the
    per-frame weight of each morph (max over overlapping visemes)."""
    end = max(t + 1.5 * d for t, d in zip(doc["vtimes"], doc["vdurations"], strict=True))
    t = np.arange(0, end + 1, 1000 / fps)
    out = {m: np.zeros(len(t)) for m in morphs}
    for v, t0, d in zip(doc["visemes"], doc["vtimes"], doc["vdurations"], strict=True):
        name = "viseme_" + v
        if name not in out:
            continue
        peak = 0.9 if v in ("PP", "FF") else 0.6
        curve = np.interp(t, [t0 - 2 * d / 3, t0 + d / 2, t0 + 1.5 * d], [0, peak, 0],
                          left=0, right=0)
        out[name] = np.maximum(out[name], curve)
    return t, out


def test_talkinghead_every_viseme_moves_its_morph():
    words = [("hello", 0.05, 0.45), ("there", 0.45, 0.85)]
    doc = talkinghead_document(OCULUS_CUES, words)
    assert doc["words"] == ["hello", "there"] and doc["wtimes"] == [50, 450]
    morphs = ["viseme_" + v for v in TALKINGHEAD_VISEMES]  # an avatar with TalkingHead's set
    assert set(doc["visemes"]) <= set(TALKINGHEAD_VISEMES)  # none is skipped
    t, w = talkinghead_frames(doc, morphs)
    back = {"I": "ih", "O": "oh", "U": "ou"}
    for v, t0, d in zip(doc["visemes"], doc["vtimes"], doc["vdurations"], strict=True):
        at = np.argmin(np.abs(t - (t0 + d / 2)))
        assert w["viseme_" + v][at] >= 0.6 - 1e-9  # the cue's own morph is at its peak
        cue = next(c for c in OCULUS_CUES if round(c["start"] * 1000) == t0)
        assert back.get(v, v) == cue["value"]
    assert len(doc["visemes"]) == len([c for c in OCULUS_CUES if c["value"] != "sil"])


def rhubarb_player(doc, t):
    """A Rhubarb cue player (Rhubarb's JSON exporter semantics, as its Spine, After Effects and
    Godot consumers read it): the shape at time t is the value of the cue with start ≤ t < end;
    before the first or after the last cue, the rest shape X."""
    for c in doc["mouthCues"]:
        if c["start"] <= t < c["end"]:
            return c["value"]
    return "X"


def test_rhubarb_cues_cover_the_clip_and_end_at_rest(tmp_path):
    cues = [{"start": 0.05, "end": 0.2, "value": "A"}, {"start": 0.2, "end": 0.333,
            "value": "D"}, {"start": 0.4, "end": 0.5, "value": "B"}]  # a hole at 0.333–0.4
    doc = rhubarb_document(cues, duration=0.5, sound_file="speech.wav")
    assert doc["metadata"] == {"soundFile": str(Path("speech.wav").resolve()), "duration": 0.5}
    mc = doc["mouthCues"]
    assert mc[0]["start"] == 0 and mc[-1]["end"] == 0.5 and mc[-1]["value"] == "X"
    assert all(a["end"] == b["start"] for a, b in itertools.pairwise(mc))  # contiguous
    assert all(round(c["start"], 2) == c["start"] for c in mc)  # centiseconds
    for t, want in ((0.02, "X"), (0.1, "A"), (0.3, "D"), (0.36, "X"), (0.45, "B"),
                    (0.495, "X")):
        assert rhubarb_player(doc, t) == want, t
    p = tmp_path / "r.json"
    p.write_text(json.dumps(doc))
    duration, back = read_rhubarb_json(p)
    assert duration == 0.5 and [c["value"] for c in back] == [c["value"] for c in mc]
    assert rhubarb_document(RHUBARB_CUES, duration=0.41)["mouthCues"][-1]["value"] == "X"


def ovr_canned_frame(seq, time):
    """Unity's OVRLipSyncSequence.GetFrameAtTime (played by OVRLipSyncContextCanned): if
    time < length, entries[(int)(entries.Count * time / length)], else null."""
    if not (time < seq["length"] and seq["entries"]):
        return None
    return seq["entries"][int(len(seq["entries"]) * (time / seq["length"]))]


@pytest.mark.parametrize("fps", [25, 60, 100])
def test_ovr_weights_play_the_cue_at_each_time(tmp_path, fps):
    duration = OCULUS_CUES[-1]["end"]
    p = write_viseme_weights(tmp_path / "v.json", OCULUS_CUES, fps=fps, duration=duration)
    seq = json.loads(p.read_text())
    assert len(seq["entries"][0]["Visemes"]) == 15 and seq["length"] == duration
    edges = sorted({c["start"] for c in OCULUS_CUES})
    for t in np.arange(0, duration, 0.003):
        if min(abs(t - e) for e in edges) < 1 / fps:  # a frame straddling two cues blends
            continue
        frame = ovr_canned_frame(seq, t)
        cue = next(c for c in OCULUS_CUES if c["start"] <= t < c["end"])
        # OVRLipSyncContextMorphTarget: SetBlendShapeWeight(target[i], Visemes[i] * 100)
        assert OCULUS_15[int(np.argmax(frame["Visemes"]))] == cue["value"], t
        assert max(frame["Visemes"]) == pytest.approx(1.0)
    assert ovr_canned_frame(seq, duration) is None
    w, length = read_viseme_weights(p)
    assert length == duration and np.allclose(w.sum(axis=1), 1, atol=1e-3)
    c = write_viseme_weights(tmp_path / "v.csv", OCULUS_CUES, fps=fps, duration=duration)
    w2, length2 = read_viseme_weights(c)
    assert np.allclose(w2, w, atol=1e-4)
    assert length2 == pytest.approx(np.ceil(duration * fps - 1e-9) / fps, abs=1e-4)


def test_weights_blend_where_a_frame_spans_two_cues():
    w = viseme_frames([{"start": 0.0, "end": 0.05, "value": "PP"},
                       {"start": 0.05, "end": 0.1, "value": "aa"}], fps=10, duration=0.1)
    assert w.shape == (1, 15)
    assert w[0, OCULUS_15.index("PP")] == pytest.approx(0.5)
    assert w[0, OCULUS_15.index("aa")] == pytest.approx(0.5)


@pytest.mark.parametrize("text, message", [
    ('{"mouthCues": [{"start": 0, "end": 0.1, "value": "Q"}]}', r"'Q' is not a Rhubarb shape"),
    ('{"mouthCues": [{"start": 0.2, "end": 0.1, "value": "A"}]}', r"out of order"),
    ('{"mouthCues": [{"start": "x", "end": 0.1, "value": "A"}]}', r"'x' is not a finite"),
    ('{"mouthCues": 5}', r"not Rhubarb JSON"),
    ('{"mouthCues": [', r"r.json:1:\d+: not JSON"),
    ("[" * 100000, r"nested too deeply|not JSON"),
])
def test_bad_rhubarb_files(tmp_path, text, message):
    p = tmp_path / "r.json"
    p.write_text(text)
    with pytest.raises(DataError, match=message):
        read_rhubarb_json(p)


def test_viseme_export_from_speech_uses_talkinghead_names(tmp_path):
    pytest.importorskip("espeakng_loader")
    from mimika.speech.export import viseme_document, write_visemes
    from mimika.speech.tts import synthesize

    utt = synthesize("I hope you go to the zoo with me.", lang="en")
    doc = viseme_document(utt, format="talkinghead")
    assert doc["visemes"] and set(doc["visemes"]) <= set(TALKINGHEAD_VISEMES)
    assert {"I", "O", "U"} & set(doc["visemes"])  # the 27 % that used to do nothing
    write_visemes(tmp_path / "u.csv", utt, fps=50)
    w, length = read_viseme_weights(tmp_path / "u.csv")
    assert length == pytest.approx(utt.duration, abs=0.02) and w.shape[1] == 15
