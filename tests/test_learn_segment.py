"""Segmentation (PCA + SOM, seed 002 Ch. 7 run rules) and transition examples."""

import itertools
import os
from pathlib import Path

import numpy as np
import pytest

from mimika.learn.data import MODEL_CHANNELS, SEED_FRAMES, make_split, window_at
from mimika.learn.segment import NONE, Segmenter, clean_runs, label_prototype, library_prototypes
from mimika.learn.segment import transitions_between as between

K = len(MODEL_CHANNELS)


def synthetic_take(rng, n_cycles=3):
    """neutral → happiness → neutral → surprise … : holds of 40 frames, 12-frame cosine
    transitions, tracking noise; returns frames (T, K) and the true hold intervals."""
    protos = library_prototypes()
    seq = [np.zeros(K), protos["happiness"], np.zeros(K), protos["surprise"],
           protos["anger"]] * n_cycles
    frames, holds, t = [], [], 0
    for i, p in enumerate(seq):
        if i:
            u = 0.5 - 0.5 * np.cos(np.pi * np.arange(1, 13) / 13)
            frames += [seq[i - 1] + (p - seq[i - 1]) * x for x in u]
            t += 12
        frames += [p] * 40
        holds.append((t, t + 40))
        t += 40
    x = np.array(frames) + rng.normal(0, 0.004, (len(frames), K))
    return np.clip(x, 0, 1).astype(np.float32), holds


def test_finds_the_holds_of_a_synthetic_take(rng):
    x, truth = synthetic_take(rng)
    seg = Segmenter(rows=6, cols=6, n_groups=4, seed=1).fit([x])
    holds = seg.holds(x)
    assert len(holds) >= 0.8 * len(truth)
    covered = 0
    for a, b in truth:  # each true hold is mostly covered by one found hold
        best = max((min(b, h.end) - max(a, h.start) for h in holds), default=0)
        covered += best >= 0.6 * (b - a)
    assert covered >= 0.8 * len(truth)
    assert all(h.length >= 5 for h in holds)
    labels = {h.label for h in holds}
    assert "neutral" in labels and "happiness" in labels
    trans = between(x, holds)
    assert trans and all(t.window.shape == (SEED_FRAMES, K) for t in trans)
    for t in trans:  # the window ends at the start frame, frames end at the target
        np.testing.assert_array_equal(t.window[-1], x[t.start])
        np.testing.assert_array_equal(t.frames[-1], x[t.start + t.length])


def test_run_rules():
    N = NONE
    lab = np.array([1, 1, 1, 2, 1, 1, 1] + [N] * 10 + [1] * 6 + [N] * 20 + [3, 3, 3] + [4] * 8)
    out = clean_runs(lab, min_length=5, max_gap=12)
    assert np.all(out[:23] == 1)  # 1-frame gap filled, runs 10 apart merged
    assert np.all(out[43:46] == N)  # 3-frame run dropped
    assert np.all(out[46:] == 4)


def test_label_threshold():
    p = library_prototypes()
    assert label_prototype(p["happiness"])[0] == "happiness"
    assert label_prototype(np.full(K, 0.9))[0] == "unlabelled"


def test_window_and_split_rules():
    v = np.arange(100 * K, dtype=np.float32).reshape(100, K)
    t = window_at(v, 30, 10)
    assert t.window.shape == (20, K) and t.length == 10 and t.start == 30
    s = make_split(["alex_rom_3", "S07-001", "S88-001", "apfel", "facial"])
    assert s.test == ("apfel",) and s.val == ("facial",)
    assert set(s.train) == {"alex_rom_3", "S07-001", "S88-001"}
    s2 = make_split(["a", "b", "c"])
    assert s2 == type(s2)(("a",), ("b",), ("c",))


MOTION = os.environ.get("MIMIKA_MOTION_DIR")


@pytest.mark.skipif(not (MOTION and Path(MOTION, "alex_rom_3.csv").exists()),
                    reason="MIMIKA_MOTION_DIR not set: no Live Link takes")
def test_real_slice_has_holds_and_transitions():
    from mimika.learn.data import load_take

    take = load_take(Path(MOTION, "alex_rom_3.csv"))
    x = take.values[:1500]
    seg = Segmenter(seed=0).fit([x])
    holds = seg.holds(x)
    assert len(holds) >= 8
    assert all(h.length >= 5 for h in holds)
    assert all(b.start > a.end for a, b in itertools.pairwise(holds))
    assert len(between(x, holds)) >= 4


def test_segmentation_does_not_depend_on_file_order(rng):
    """The segmenter fitted on the same takes in any order gives the same holds."""
    takes = [synthetic_take(np.random.default_rng(s), n_cycles=2)[0] for s in range(3)]
    ref = None
    for perm in itertools.permutations(range(3)):
        seg = Segmenter(rows=5, cols=5, n_groups=4, seed=0).fit([takes[i] for i in perm])
        holds = [[(h.start, h.end, h.label) for h in seg.holds(x)] for x in takes]
        assert ref is None or holds == ref, perm
        ref = holds


@pytest.mark.skipif(not os.environ.get("MIMIKA_MOTION_DIR"), reason="needs MIMIKA_MOTION_DIR "
                    "(real Live Link Face takes, e.g. shared/motion/livelinkface)")
def test_real_segmentation_does_not_depend_on_file_order():
    from mimika.learn.data import list_takes
    from mimika.learn.train import prepare

    paths = list_takes(os.environ["MIMIKA_MOTION_DIR"])
    a = prepare(paths, augment=False)
    b = prepare(paths[::-1], augment=False, val=list(a.split.val), test=list(a.split.test))
    for n in a.takes:
        assert [(h.start, h.end, h.label) for h in a.holds[n]] == \
            [(h.start, h.end, h.label) for h in b.holds[n]], n
