"""Behaviour layers of the newsreader: blinks, gaze, head motion, brows, smiles, idle."""

import numpy as np
import pytest

from mimika.behaviour import (
    LAYERS,
    SpeechCues,
    behaviour_layers,
    behaviour_params,
    merge_layers,
    sentence_kind,
)
from mimika.behaviour.blink import make_blinks
from mimika.behaviour.head import head_aus_to_angles
from mimika.errors import ParameterError

FPS = 25.0


def synthetic_cues(duration: float = 120.0, sentence: float = 3.2, gap: float = 0.5,
                   lang: str = "en", texts=None) -> SpeechCues:
    """Sentences of ``sentence`` s with ``gap`` s pauses, a word every 0.4 s, a stress per word."""
    sents, words, stresses, pauses = [], [], [], []
    t, i = 0.5, 0
    pauses.append((0.0, 0.5))
    while t + sentence < duration - 0.5:
        text = texts[i % len(texts)] if texts else "The council approved a longer budget."
        sents.append((t, t + sentence, text))
        for k in range(int(sentence / 0.4)):
            w0 = t + 0.4 * k
            words.append((w0, w0 + 0.38, "wonderful" if k % 3 == 0 else "the"))
            stresses.append(w0 + 0.1)
        pauses.append((t + sentence, t + sentence + gap))
        t += sentence + gap
        i += 1
    paras = tuple(s[0] for s in sents[::4])
    return SpeechCues(duration, tuple(sents), tuple(words), tuple(stresses), tuple(pauses),
                      paras, lang)


@pytest.fixture(scope="module")
def cues():
    return synthetic_cues()


@pytest.fixture(scope="module")
def layers(cues):
    return behaviour_layers(cues, fps=FPS, seed=7)


def test_every_layer_covers_the_duration_in_range(cues, layers):
    n = cues.n_frames(fps=FPS)
    assert set(layers) == set(LAYERS)
    for name, tr in layers.items():
        assert tr.n_frames == n and tr.fps == FPS, name
        if tr.channels:
            assert tr.values.min() >= 0 and tr.values.max() <= 1, name


def test_blink_count_falls_in_the_configured_range(cues):
    p = behaviour_params()["blink"]
    for seed in range(5):
        tr = behaviour_layers(cues, fps=FPS, seed=seed, layers=["blink"])["blink"]
        n = len(tr.meta["blinks"])
        lo = cues.duration / (p["rest_interval_s"] * 1.3)
        hi = cues.duration / (p["speaking_interval_s"] * 0.7)
        assert lo <= n <= hi, (seed, n, lo, hi)


def test_blinks_are_complete_short_and_close_faster_than_they_open(cues, layers):
    tr = layers["blink"]
    p = behaviour_params()["blink"]
    rng = np.random.default_rng(3)
    blinks = make_blinks(cues, fps=FPS, rng=rng, params=p)
    lo, hi = p["duration_range_s"]
    for b in blinks:
        assert lo - 1e-9 <= b.duration <= hi + 1e-9
        assert b.close < b.opening
    starts = [s for s, _ in tr.meta["blinks"]]
    au45 = tr["AU45"]
    for s, d in tr.meta["blinks"]:
        i0, i1 = int(np.floor(s * FPS)), int(np.ceil((s + d) * FPS))
        assert au45[i0:i1 + 1].max() == pytest.approx(1.0)  # the lids shut at some frame
    assert np.all(np.diff(starts) >= p["min_gap_s"] - 1e-9)
    durations = [d for _, d in tr.meta["blinks"]]
    assert 0.17 <= np.median(durations) <= 0.25  # ≈ 208 ms conversational blinks


def test_blinks_cluster_near_phrase_boundaries(cues):
    bounds = np.array(cues.boundaries)
    near = []
    for seed in range(4):
        tr = behaviour_layers(cues, fps=FPS, seed=seed, layers=["blink"])["blink"]
        for s, _ in tr.meta["blinks"]:
            near.append(np.min(np.abs(bounds - s)) <= 0.375)
    assert np.mean(near) >= 0.55  # Ford 2013: 71 % within ±375 ms


def test_gaze_stays_on_the_camera_with_small_saccades(cues, layers):
    sc = behaviour_params()["scales"]
    g = layers["gaze"]
    yaw = (g["AU61"] - g["AU62"]) * sc["eye_yaw_deg"]
    pitch = (g["AU64"] - g["AU63"]) * sc["eye_pitch_deg"]
    t = cues.times(fps=FPS)
    glance = np.zeros(len(t), bool)
    for g0, g1 in g.meta["glances"]:
        glance |= (t >= g0 - 0.15) & (t <= g1 + 0.15)
    assert np.abs(yaw).max() <= 3.0 and np.abs(pitch[~glance]).max() <= 3.0
    assert np.median(np.hypot(yaw, pitch)[~glance]) <= 1.5
    moves = np.flatnonzero(np.abs(np.diff(yaw)) + np.abs(np.diff(pitch)) > 0.05)
    assert len(moves) > cues.duration / 4  # saccades happen (every 0.5–2 s)
    assert g.meta["glances"], "no glance at the notes over 2 minutes"
    for g0, g1 in g.meta["glances"]:
        assert 0.3 <= g1 - g0 <= 0.9
        mid = (t >= g0 + 0.15) & (t <= g1 - 0.15)
        assert g["AU64"][mid].max() == pytest.approx(0.3, abs=0.05)


def test_head_motion_is_small_smooth_and_follows_speech(cues, layers):
    sc = behaviour_params()["scales"]
    ang = head_aus_to_angles(layers["head"].with_channels(
        ["AU51", "AU52", "AU53", "AU54", "AU55", "AU56"]).values, sc)
    assert np.abs(ang).max() <= 4.0  # a few degrees at most (survey: reduce it)
    assert np.abs(ang).max() >= 0.5  # but it is there
    step = np.abs(np.diff(ang, axis=0)).max()
    assert step <= 0.5  # degrees per frame: no popping


def test_idle_never_freezes(cues, layers):
    v = layers["idle"].values
    moving = np.abs(np.diff(v, axis=0)).sum(1) > 0
    # never still for longer than a few frames, in pauses as well as in speech
    runs = np.diff(np.flatnonzero(np.r_[True, moving, True]))
    assert runs.max() <= 3


def test_brows_rise_on_accented_words_and_questions():
    cues = synthetic_cues(40.0, texts=["Is this the budget?", "The council approved it."])
    tr = behaviour_layers(cues, fps=FPS, seed=2, layers=["brows"])["brows"]
    assert tr.meta["raises"]
    assert 0.1 <= tr["AU01"].max() <= 0.35
    t = cues.times(fps=FPS)
    _s0, s1, _ = cues.sentences[0]
    tail = (t > s1 - 0.5) & (t < s1 - 0.2)
    assert tr["AU01"][tail].min() >= 0.2  # the question's end


@pytest.mark.parametrize(("text", "lang", "kind"), [
    ("Good evening, and welcome.", "en", "greeting"),
    ("Guten Abend, meine Damen und Herren.", "de", "greeting"),
    ("Dobry wieczór państwu.", "pl", "greeting"),
    ("Goodbye.", "en", "farewell"),
    ("Auf Wiedersehen!", "de", "farewell"),
    ("Do widzenia.", "pl", "farewell"),
    ("Thank you for watching, and goodbye.", "en", "farewell"),
    ("The evening was good.", "en", None),
    ("Good evidence was found.", "en", None),
])
def test_greetings_and_farewells_are_found_in_three_languages(text, lang, kind):
    assert sentence_kind(text, lang) == kind


def test_smile_during_greeting_and_farewell_only():
    texts = ["Good evening.", "The budget grew.", "Goodbye."]
    cues = synthetic_cues(12.0, texts=texts)
    tr = behaviour_layers(cues, fps=FPS, seed=1, layers=["smile"])["smile"]
    t = cues.times(fps=FPS)
    (g0, g1, _), (m0, m1, _) = cues.sentences[0], cues.sentences[1]
    mid = (t > g0 + 0.5) & (t < g1 - 0.2)
    k = behaviour_params()["smile"]["intensity"]  # each smile within ±10 % of it
    assert 0.3 <= k <= 1.0  # a smile that shows, short of a full one
    assert tr["AU12"][mid].min() == pytest.approx(k, rel=0.12)
    assert tr["AU06"][mid].min() == pytest.approx(k, rel=0.12)
    assert tr["AU12"][(t > m0 + 1.2) & (t < m1 - 0.5)].max() == 0.0


def test_switching_a_layer_off_leaves_the_others_unchanged(cues, layers):
    for off in LAYERS:
        rest = behaviour_layers(cues, fps=FPS, seed=7, layers=[x for x in LAYERS if x != off])
        assert off not in rest
        for name, tr in rest.items():
            np.testing.assert_array_equal(tr.values, layers[name].values, err_msg=name)


def test_merge_sums_rotations_and_keeps_eyes_on_the_camera(cues, layers):
    sc = behaviour_params()["scales"]
    m = merge_layers(layers)
    head = head_aus_to_angles(m.with_channels(
        ["AU51", "AU52", "AU53", "AU54", "AU55", "AU56"]).values, sc)
    h1 = head_aus_to_angles(layers["head"].values, sc)
    h2 = head_aus_to_angles(layers["idle"].values, sc)
    np.testing.assert_allclose(head, h1 + h2, atol=1e-4)
    eye_yaw = (m["AU61"] - m["AU62"]) * sc["eye_yaw_deg"]
    g = layers["gaze"]
    gaze_yaw = (g["AU61"] - g["AU62"]) * sc["eye_yaw_deg"]
    # eye + head = gaze direction in the world: the camera plus the saccades
    np.testing.assert_allclose(eye_yaw + head[:, 0], gaze_yaw, atol=1e-3)
    no_gaze = merge_layers({k: v for k, v in layers.items() if k != "gaze"})
    assert "AU61" not in no_gaze.channels
    no_blink = merge_layers({k: v for k, v in layers.items() if k != "blink"})
    assert "AU45" not in no_blink.channels


def test_seeded_and_reproducible(cues, layers):
    again = behaviour_layers(cues, fps=FPS, seed=7)
    for k in layers:
        np.testing.assert_array_equal(again[k].values, layers[k].values)
    other = behaviour_layers(cues, fps=FPS, seed=8, layers=["blink"])["blink"]
    assert not np.array_equal(other.values, layers["blink"].values)


def test_bad_parameters_name_the_problem(cues):
    with pytest.raises(ParameterError, match="unknown behaviour layer 'blinks'"):
        behaviour_layers(cues, fps=FPS, layers=["blinks"])
    with pytest.raises(ParameterError, match=r"blink\.interval"):
        behaviour_params({"blink": {"interval": 3}})
    with pytest.raises(ParameterError, match="duration"):
        SpeechCues(0.0)
    p = behaviour_params({"blink": {"rest_interval_s": 9.0}})
    assert p["blink"]["rest_interval_s"] == 9.0
    assert behaviour_params()["blink"]["rest_interval_s"] != 9.0  # a copy
