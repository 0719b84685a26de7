"""Alignment on real recorded speech (GRID corpus in MIMIKA_SPEECH_DIR), determinism of
alignment, and lip-sync without a transcript. Figures live in bench/bench_align_real.py."""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mimika.speech.alignment import align, recognise
from mimika.speech.audio import read_wav
from mimika.speech.coarticulation import bilabial_apex_times, closure_ok, mouth_track

SRC = str(Path(__file__).resolve().parents[1] / "src")
IDS = ("bbaf5a", "bbbf8p", "brbm8p", "lgaz8p", "pbwx5s", "swwp2s")


def speech_dir() -> Path | None:
    d = os.environ.get("MIMIKA_SPEECH_DIR")
    return Path(d) if d and (Path(d) / "wav").is_dir() else None


needs_grid = pytest.mark.skipif(speech_dir() is None,
                                reason="MIMIKA_SPEECH_DIR not set: no GRID recordings")


def grid(i: str):
    d = speech_dir()
    a, sr = read_wav(d / "wav" / f"{i}.wav")
    truth = []
    for line in (d / "align" / f"{i}.align").read_text().splitlines():
        s, e, w = line.split()
        if w not in ("sil", "sp"):
            truth.append((w, int(s) / 25000, int(e) / 25000))
    return a, sr, truth


def grid_ids():
    d = speech_dir()
    have = {p.stem for p in (d / "wav").glob("*.wav")}
    ids = [i for i in IDS if i in have] or sorted(have)[:6]
    return ids


@needs_grid
def test_edge_silence_shifts_no_word_boundary_by_more_than_20ms():
    rng = np.random.default_rng(5)
    for i in grid_ids()[:3]:
        a, sr, truth = grid(i)
        text = " ".join(w for w, _, _ in truth)
        base = align(a, sr=sr, transcript=text)
        for pre, post in ((0.0, 2.0), (2.0, 0.0), (0.7, 1.3)):
            b = np.concatenate([np.zeros(round(pre * sr)), a, np.zeros(round(post * sr))])
            b = (b + rng.normal(0, 1e-4, len(b))).astype(np.float32)
            u = align(b, sr=sr, transcript=text)
            assert [w.text for w in u.words] == [w.text for w in base.words]
            for w0, w1 in zip(base.words, u.words, strict=True):
                assert abs(w1.start - pre - w0.start) <= 0.02, (i, pre, w0, w1)
                assert abs(w1.end - pre - w0.end) <= 0.02, (i, pre, w0, w1)
            assert u.duration == pytest.approx(len(b) / sr)


@needs_grid
def test_bilabials_in_real_speech_close_the_lips_inside_their_word():
    n = inside = 0
    for i in grid_ids():
        a, sr, truth = grid(i)
        u = align(a, sr=sr, transcript=" ".join(w for w, _, _ in truth))
        track = mouth_track(u, fps=25)
        for t in bilabial_apex_times(u):
            k = next(j for j, w in enumerate(u.words) if w.start - 1e-6 <= t <= w.end + 1e-6)
            word = truth[k]
            n += 1
            inside += word[1] <= t <= word[2]
            f = round(t * 25)
            assert closure_ok(dict(zip(track.channels, track.values[f], strict=True))) or \
                closure_ok(dict(zip(track.channels, track.values[min(f + 1, track.n_frames - 1)],
                                    strict=True)))
    assert n >= 6
    assert inside / n >= 0.7  # GRID word times are themselves a forced alignment (HTK)


@needs_grid
def test_audio_only_lipsync_closes_the_lips_for_most_bilabials():
    n = hit = 0
    for i in grid_ids():
        a, sr, truth = grid(i)
        ref = align(a, sr=sr, transcript=" ".join(w for w, _, _ in truth))
        rec = recognise(a, sr=sr)
        assert rec.words == [] and rec.phonemes[-1].end == pytest.approx(len(a) / sr)
        tr = mouth_track(rec, fps=25)
        for t in bilabial_apex_times(ref):
            n += 1
            k = round(t * 25)
            hit += any(closure_ok(dict(zip(tr.channels, tr.values[j], strict=True)))
                       for j in range(max(0, k - 1), min(tr.n_frames, k + 2)))
    assert n >= 6
    assert hit / n > 0.5


_PROG = """
import json, sys
sys.path.insert(0, {src!r})
from mimika.speech.alignment import align
from mimika.speech.tts import synthesize
jobs = json.loads(sys.argv[1])
out = []
for text, engine in jobs:
    rec = synthesize(text, voice="f3", rate=150)
    u = align(rec.audio, sr=rec.sr, transcript=text, engine=engine)
    out.append([text, engine, u.timing_dict()["phonemes"], u.timing_dict()["words"]])
print(json.dumps(out))
"""


def _run(jobs):
    r = subprocess.run([sys.executable, "-c", _PROG.format(src=SRC), json.dumps(jobs)],
                       capture_output=True, text=True, check=True)
    return json.loads(r.stdout)


@pytest.mark.parametrize("engine", ["dtw", "sphinx"])
def test_two_alignments_in_one_process_equal_two_in_fresh_processes(engine):
    a = "Good evening. Bob bought a big map for 12 dollars."
    b = "Here is the news: prices rose by 3.5 percent."
    together = _run([[b, engine], [a, engine], [b, engine]])
    fresh_a = _run([[a, engine]])[0]
    fresh_b = _run([[b, engine]])[0]
    assert together[1] == fresh_a
    assert together[0] == fresh_b
    assert together[2] == fresh_b


@needs_grid
def test_pocketsphinx_result_does_not_depend_on_what_it_aligned_before():
    """Real recordings aligned one after another in one process equal each aligned by a
    freshly built decoder (all pocketsphinx state lives in the decoder)."""
    from mimika.speech import sphinx

    ids = sorted(p.stem for p in (speech_dir() / "wav").glob("*.wav"))[50:62]
    jobs = []
    for i in ids:
        a, sr, truth = grid(i)
        jobs.append((a, sr, " ".join(w for w, _, _ in truth)))
    warm = [align(a, sr=sr, transcript=t, engine="sphinx").timing_dict()["words"]
            for a, sr, t in jobs]
    for (a, sr, t), w in zip(jobs, warm, strict=True):
        sphinx._decoder.cache_clear()
        assert align(a, sr=sr, transcript=t, engine="sphinx").timing_dict()["words"] == w


def test_pocketsphinx_aligns_clean_synthetic_speech_without_falling_back():
    from mimika.speech.tts import synthesize

    for text in ("Good evening, and welcome to the news.",
                 "Will the trains run on time this winter?",
                 "They call it a small but welcome surprise."):
        rec = synthesize(text, engine="espeak")
        u = align(rec.audio, sr=rec.sr, transcript=text, engine="auto")
        assert u.meta["engine"] == "sphinx", text
