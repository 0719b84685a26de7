"""Visemes and coarticulation in AU space: closure rules, timing, jaw/envelope, exports."""

from __future__ import annotations

import json
import logging
import math
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("espeakng_loader")

import itertools

from mimika.speech import (
    bilabial_apex_times,
    closure_ok,
    combine,
    labiodental_apex_times,
    mouth_track,
    synthesize,
)
from mimika.speech.audio import rms_envelope
from mimika.speech.export import (
    rhubarb_json,
    seed004_keyframes,
    viseme_cues,
    viseme_document,
)
from mimika.speech.phonemes import classify, espeak_inventory, phoneme_table
from mimika.tracks import AUTrack

BILABIAL = {
    "en": "Bob, Pam and Mum bought a bumper box of bubble gum. Maybe a big map, please.",
    "de": "Mama mag bunte Ballons, aber Papa baut am Montag Bambusboote.",
    "pl": "Mama ma bardzo pyszne pomidory, a babcia piecze bułki pod Poznaniem.",
}
PARAGRAPH = ("Good evening. Here are the news. The city council met on Monday to discuss the "
             "new budget for public transport. Buses will run more often, and a new tram line "
             "is planned for the northern districts.")


@pytest.fixture(scope="module")
def utts():
    return {lang: synthesize(t, lang=lang) for lang, t in BILABIAL.items()}


def _apex_frames(t: float, fps: float, n: int) -> list[int]:
    return sorted({min(max(i, 0), n - 1) for i in (math.floor(t * fps), math.ceil(t * fps))})


@pytest.mark.parametrize("fps", [25, 30, 60])
@pytest.mark.parametrize("lang", list(BILABIAL))
def test_bilabials_close_at_every_apex(utts, lang, fps):
    u = utts[lang]
    tr = mouth_track(u, fps=fps)
    apex = bilabial_apex_times(u)
    assert len(apex) >= 8
    bad = [t for t in apex for i in _apex_frames(t, fps, tr.n_frames)
           if not closure_ok(tr.frame(i))]
    assert bad == []


@pytest.mark.parametrize("lang", list(BILABIAL))
def test_bilabials_close_while_smiling(utts, lang):
    u = utts[lang]
    tr = mouth_track(u, fps=25)
    smile = AUTrack.constant({"AU12": 1.0, "AU25": 0.6, "AU06": 0.8}, n_frames=5, fps=30)
    mixed = combine(tr, smile)
    for t in bilabial_apex_times(u):
        for i in _apex_frames(t, 25, mixed.n_frames):
            f = mixed.frame(i)
            assert closure_ok(f), (t, f)
            assert f["AU24"] >= 0.4 + 0.3 * f["AU12"] - 1e-6
    # emotion keeps the rest of the face; the smile survives where the lips are not rounded
    assert np.allclose(mixed["AU06"], 0.8)
    assert np.median(mixed["AU12"]) > 0.5


def test_combine_without_meta_still_closes(utts):
    u = utts["en"]
    tr = mouth_track(u, fps=25)
    bare = AUTrack(tr.values, tr.channels, tr.fps)  # e.g. read back from CSV
    mixed = combine(bare, AUTrack.constant({"AU12": 1.0, "AU25": 0.8}, fps=25))
    for t in bilabial_apex_times(u):
        i = round(t * 25)
        if bare.frame(i)["AU25"] == 0 and bare.frame(i)["AU24"] >= 0.4:
            assert closure_ok(mixed.frame(i))


def test_emotion_mouth_shows_in_long_pauses():
    u2 = synthesize('<speak>Hello. <break time="1500ms"/> Goodbye.</speak>', ssml=True)
    tr = mouth_track(u2, fps=25)
    mixed = combine(tr, AUTrack.constant({"AU25": 0.5}, fps=25))
    pause = max((p for p in u2.phonemes if p.is_pause), key=lambda p: p.duration)
    mid = round((pause.start + pause.end) / 2 * 25)
    assert mixed.frame(mid)["AU25"] == pytest.approx(0.5, abs=0.05)


def test_labiodentals_tuck_the_lower_lip(utts):
    u = synthesize("Five vivid fish fly over the valley of fifty vines.")
    tr = mouth_track(u, fps=30)
    apex = labiodental_apex_times(u)
    assert len(apex) >= 8
    for t in apex:
        for i in _apex_frames(t, 30, tr.n_frames):
            f = tr.frame(i)
            assert f["AU28"] >= 0.3 - 1e-6 and f["AU10"] >= 0.15 - 1e-6
            assert f["AU26"] <= 0.08 + 1e-6 and f["AU16"] <= 1e-6 and f["AU24"] <= 1e-6


def test_rounding_spreads_to_preceding_consonants():
    u = synthesize("The school stool.")
    tr = mouth_track(u, fps=100)
    segs = [p for p in u.phonemes]
    k = next(i for i, p in enumerate(segs) if p.symbol == "k")
    mid_k = round((segs[k].start + segs[k].end) / 2 * 100)
    assert tr.frame(mid_k)["AU18"] > 0.2  # /k/ before /u:/ is already rounded
    base = synthesize("The skill still.")
    tb = mouth_track(base, fps=100)
    kb = next(p for p in base.phonemes if p.symbol == "k")
    assert tb.frame(round((kb.start + kb.end) / 2 * 100))["AU18"] < 0.1


def test_jaw_follows_audio_envelope():
    u = synthesize(PARAGRAPH)
    tr = mouth_track(u, fps=25)
    env = rms_envelope(u.audio, sr=u.sr, fps=25, n_frames=tr.n_frames)
    r = np.corrcoef(tr["AU26"] + tr["AU27"], env)[0, 1]
    assert r > 0.3, r  # measured 0.36 (en), 0.42 (de), 0.50 (pl)


def test_not_flappy_and_smooth():
    u = synthesize(PARAGRAPH)
    tr = mouth_track(u, fps=60)
    jaw = tr["AU26"]
    # no full opening on every phone: consonants between vowels keep the jaw partly open
    assert np.percentile(jaw[jaw > 0.01], 50) < 0.5
    vowels_open = np.mean(jaw > 0.2)
    assert 0.25 < vowels_open < 0.9
    # per-frame steps at 60 fps stay small outside the closure snaps
    assert np.percentile(np.abs(np.diff(jaw)), 95) < 0.12


def test_any_fps_same_shape():
    u = synthesize("Bob met Pam.")
    a, b = mouth_track(u, fps=25), mouth_track(u, fps=50)
    assert a.n_frames == math.ceil(u.duration * 25) and b.n_frames == math.ceil(u.duration * 50)
    assert np.abs(a.values - b.values[::2][:a.n_frames]).mean() < 0.05
    assert a.values.min() >= 0 and a.values.max() <= 1


def test_cue_boundaries_are_phoneme_starts(utts):
    from mimika.speech.export import segment_starts

    for u in utts.values():
        starts = np.array(segment_starts(u))
        phone_starts = {p.start for p in u.phonemes}
        for fmt in ("oculus", "rhubarb", "mpeg4"):
            cues = viseme_cues(u, format=fmt)
            assert cues[0]["start"] == 0 and cues[-1]["end"] == pytest.approx(u.duration)
            for a, b in itertools.pairwise(cues):
                assert a["end"] == b["start"] and a["value"] != b["value"]
                assert np.min(np.abs(starts - b["start"])) < 1e-9
        # bilabials are cues of their own that start exactly at the phone start
        pp = [c for c in viseme_cues(u, format="oculus") if c["value"] == "PP"]
        assert pp and all(c["start"] in phone_starts for c in pp)


def test_rhubarb_json_structure(utts):
    doc = json.loads(json.dumps(rhubarb_json(utts["en"], sound_file="a.wav")))
    assert set(doc) == {"metadata", "mouthCues"}
    assert doc["metadata"]["soundFile"] == str(Path("a.wav").resolve())  # absolute, as Rhubarb
    cues = doc["mouthCues"]
    assert {c["value"] for c in cues} <= set("ABCDEFGHX")
    assert {"A", "X"} <= {c["value"] for c in cues}
    for c in cues:
        assert set(c) == {"start", "end", "value"}
        assert c["end"] > c["start"] and round(c["start"], 2) == c["start"]
    for a, b in itertools.pairwise(cues):
        assert a["end"] == b["start"]


def test_oculus_mpeg4_seed004_documents(utts):
    u = utts["de"]
    oc = viseme_document(u, format="oculus")
    assert oc["inventory"][0] == "sil" and len(oc["inventory"]) == 15
    assert {c["value"] for c in oc["cues"]} <= set(oc["inventory"])
    mp = viseme_document(u, format="mpeg4")
    assert all(0 <= c["value"] <= 14 and c["name"] for c in mp["cues"])
    th = viseme_document(u, format="talkinghead")
    assert len(th["visemes"]) == len(th["vtimes"]) == len(th["vdurations"])
    kf = seed004_keyframes(u)
    assert set(kf[0]) == {"time", "phoneme", "mouthWidth", "mouthHeight", "lipTension",
                          "upperTeethVisible", "lowerTeethVisible"}
    closed = [k for k in kf if k["phoneme"] in ("m", "b", "p")]
    assert all(k["mouthHeight"] < 0.05 for k in closed)


@pytest.mark.parametrize("lang", ["en", "en-us", "de", "pl"])
def test_every_espeak_phoneme_is_mapped(lang, caplog):
    table = phoneme_table()["phonemes"]
    over = phoneme_table()["languages"]
    inv = espeak_inventory(lang)
    assert len(inv) > 100
    for sym, (typ, _place) in inv.items():
        if typ in (0, 1, 9):  # pauses, stress marks, virtual phonemes
            continue
        assert sym in table or sym in over.get(lang.split("-")[0], {}), sym


def test_unknown_symbol_falls_back_with_warning(caplog):
    with caplog.at_level(logging.WARNING, logger="mimika.speech.phonemes"):
        assert classify("zq9", "en") == ("sibilant",)
    assert "not in phonemes.json" in caplog.text
    assert classify("'aI", "en") == ("vowel_open", "vowel_close_front")
    assert classify("y", "pl") == ("vowel_close_central",)
    assert classify("y", "de") == ("vowel_front_rounded",)
