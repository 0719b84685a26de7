"""Long recordings align in bounded memory (issue 27): DTW holds O(N) cells at every level of
its pyramid, pocketsphinx sees one piece of at most ``pieces.PIECE`` seconds at a time, cut
in pauses outside words. Memory figures per duration: bench/bench_align_memory.py."""

from __future__ import annotations

from itertools import pairwise

import numpy as np
import pytest

from mimika.speech import dtw, pieces
from mimika.speech.utterance import Phone


def _signals(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A random feature sequence, a copy warped by a smooth random rate, and the true map."""
    rng = np.random.default_rng(seed)
    x = np.cumsum(rng.normal(size=(n, 6)), axis=0).astype(np.float32)
    x = (x - x.mean(0)) / x.std(0)
    rate = 1.0 + 0.3 * np.sin(np.linspace(0, 9, n * 13 // 10)) + rng.uniform(-0.1, 0.1)
    t = np.cumsum(rate)
    t = t[t < n - 1]
    y = np.stack([np.interp(t, np.arange(n), x[:, k]) for k in range(6)], axis=1)
    return x, y.astype(np.float32), t


def test_dtw_pyramid_keeps_every_level_linear(monkeypatch):
    x, y, t = _signals(6000)
    cells: list[tuple[int, int]] = []
    real = dtw.dtw_path

    def counting(a, b, lo, hi):
        cells.append((len(a), int(np.sum(np.asarray(hi) - np.asarray(lo)))))
        return real(a, b, lo, hi)

    monkeypatch.setattr(dtw, "dtw_path", counting)
    monkeypatch.setattr(dtw, "MAX_CELLS", 20_000)
    path = dtw.warp(x, y, hop=0.005)
    assert len(cells) >= 3  # went through coarser levels
    coarsest = cells[0]
    assert coarsest[1] <= 20_000
    for rows, n in cells[1:]:
        assert n <= 130 * rows  # a band of a few dozen frames per row, not a fraction of N
    # and the path still follows the true warp
    est = np.interp(np.arange(len(y)), path[:, 1], path[:, 0])
    assert np.median(np.abs(est - t)) < 3.0


def test_dtw_pyramid_agrees_with_the_direct_band(monkeypatch):
    x, y, _ = _signals(1200, seed=1)
    direct = dtw.warp(x, y, hop=0.005)
    monkeypatch.setattr(dtw, "MAX_CELLS", 5_000)
    layered = dtw.warp(x, y, hop=0.005)
    a = np.interp(np.arange(len(y)), direct[:, 1], direct[:, 0])
    b = np.interp(np.arange(len(y)), layered[:, 1], layered[:, 0])
    assert np.mean(np.abs(a - b) <= 2) > 0.95


def _act(pauses: list[tuple[float, float]], dur: float, hop: float = 0.01) -> np.ndarray:
    act = np.ones(round(dur / hop), bool)
    for s, e in pauses:
        act[round(s / hop):round(e / hop)] = False
    return act


def test_cuts_fall_in_pauses_outside_words_and_bound_every_piece():
    dur = 200.0
    # a word every 0.5 s, a 0.3 s pause after every 8th word; a 0.2 s closure inside some
    spans, pauses, t = [], [], 0.0
    for k in range(330):
        spans.append((t, t + 0.45))
        t += 0.5
        if k % 8 == 7:
            pauses.append((t - 0.05, t + 0.25))
            t += 0.3
        if k % 5 == 0:
            pauses.append((t - 0.35, t - 0.15))  # inside the word just placed
    spans_a = np.array(spans)
    cuts = pieces.cut_times(spans_a, _act(pauses, dur), dur)
    bounds = [0.0, *cuts, dur]
    assert all(pieces.MIN_PIECE - 1 <= b - a <= pieces.PIECE + 1e-9 for a, b in pairwise(bounds))
    for c in cuts:
        assert not any(s + pieces.SLACK < c < e - pieces.SLACK for s, e in spans)
        assert any(s <= c <= e for s, e in pauses)
    groups = pieces.assign(spans_a, cuts)
    assert [i for g in groups for i in g] == list(range(len(spans)))


def test_cuts_without_pauses_fall_between_words():
    spans = np.array([(k * 0.5, k * 0.5 + 0.5) for k in range(300)])  # 150 s, no pause
    cuts = pieces.cut_times(spans, np.ones(15000, bool), 150.0)
    assert cuts and all(abs(c / 0.5 - round(c / 0.5)) < 1e-9 for c in cuts)
    assert all(b - a <= pieces.PIECE for a, b in pairwise([0, *cuts, 150.0]))


def test_join_merges_pauses_at_cuts():
    a = ([Phone("_", 0, 1), Phone("a", 1, 2), Phone("_", 2, 3)], [-1, 0, -1])
    b = pieces.shift([Phone("_", 0, 0.5), Phone("b", 0.5, 1)], [-1, 0], 3.0, 1)
    phones, owner = pieces.join([a, b])
    assert [(p.symbol, p.start, p.end) for p in phones] == [
        ("_", 0, 1), ("a", 1, 2), ("_", 2, 3.5), ("b", 3.5, 4)]
    assert owner == [-1, 0, -1, 1]


@pytest.fixture()
def long_speech():
    """About 40 s of espeak-ng speech, sentences 0.3 s apart, with its true word times."""
    pytest.importorskip("espeakng_loader")
    from mimika.speech import synthesize

    text = " ".join(["The council met on Monday to discuss the budget.",
                     "Rain is expected tomorrow morning in the north.",
                     "Markets closed higher after a quiet day of trading.",
                     "The minister spoke to reporters outside the building."] * 3)
    return synthesize(text, lang="en", rate=150)


@pytest.mark.parametrize("engine", ["auto", "dtw"])
def test_a_long_recording_aligns_piece_by_piece(monkeypatch, long_speech, engine):
    from mimika.speech import align

    u = long_speech
    monkeypatch.setattr(pieces, "PIECE", 12.0)
    monkeypatch.setattr(pieces, "MIN_PIECE", 4.0)
    est = align(u.audio, sr=u.sr, transcript=u.text, lang="en", engine=engine)
    assert [w.text for w in est.words] == [w.text for w in u.words]
    err = np.abs(np.array([(w.start, w.end) for w in est.words]) -
                 np.array([(w.start, w.end) for w in u.words]))
    assert np.median(err) < 0.04 and np.mean(err < 0.1) > 0.9  # whole: 30 ms, 95 %
    assert est.phonemes[0].start == 0 and est.phonemes[-1].end == pytest.approx(est.duration)
    assert all(a.end == b.start for a, b in pairwise(est.phonemes))
    if engine == "auto" and est.meta["engine"] == "sphinx":
        assert est.meta["pieces"] >= u.duration / 12.0


def test_a_piece_pocketsphinx_cannot_align_keeps_its_dtw_phones(monkeypatch, long_speech):
    from mimika.errors import ParameterError
    from mimika.speech import align, alignment

    u = long_speech
    monkeypatch.setattr(pieces, "PIECE", 12.0)
    monkeypatch.setattr(pieces, "MIN_PIECE", 4.0)
    real, calls = alignment._sphinx_phones, []

    def flaky(a, sr, toks, lang, act):
        calls.append(len(toks))
        if len(calls) == 2:
            raise ParameterError("pocketsphinx cannot align the transcript to the audio")
        return real(a, sr, toks, lang, act)

    monkeypatch.setattr(alignment, "_sphinx_phones", flaky)
    est = align(u.audio, sr=u.sr, transcript=u.text, lang="en", engine="auto")
    assert est.meta["engine"] == "sphinx" and est.meta["dtw_pieces"] == 1
    assert [w.text for w in est.words] == [w.text for w in u.words]
    err = np.abs(np.array([(w.start, w.end) for w in est.words]) -
                 np.array([(w.start, w.end) for w in u.words]))
    assert np.median(err) < 0.04
    assert all(a.end == b.start for a, b in pairwise(est.phonemes))
    with pytest.raises(ParameterError):  # the sphinx engine asked for by name: no fallback
        calls.clear()
        align(u.audio, sr=u.sr, transcript=u.text, lang="en", engine="sphinx")
