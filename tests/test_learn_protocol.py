"""The evaluation protocol on synthetic takes whose answer is known, the learned timing model
and the ``learned`` easing's fallback to interpolation."""

import json
import os
from pathlib import Path

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from mimika.learn.data import MODEL_CHANNELS, Take  # noqa: E402
from mimika.learn.gan_data import expression_vector  # noqa: E402
from mimika.learn.protocol import (  # noqa: E402
    Baseline,
    Learned,
    bootstrap,
    group_timing,
    leave_one_take_out,
    run_protocol,
    summarise,
)
from mimika.learn.train import RECIPES  # noqa: E402

K = len(MODEL_CHANNELS)
#: the expressions of the synthetic takes (over MODEL_CHANNELS): the library as these tests
#: were designed on, kept in a file (the library's prototypes change when it is tuned for
#: rendering), so they measure the methods. The snap test's margin depends on the takes: over
#: eight synthetic sets the timing model's median relative MSE ranged −75 % … +30 %
#: (docs/transitions.md)
PROTOS = [expression_vector(aus, MODEL_CHANNELS) for aus in json.loads(
    (Path(__file__).parent / "data" / "protocol_expressions.json").read_text()).values()]


def cosine(L):
    return 0.5 - 0.5 * np.cos(np.pi * np.arange(1, L + 1) / L)


def snap(L, onset=2.0, rise=4.0):
    """Wait ``onset`` frames, then a logistic snap over ``rise`` frames (10 → 90 %)."""
    t = np.arange(0, L + 1)
    s = 1 / (1 + np.exp(-2 * np.log(9) * (t - onset - rise / 2) / rise))
    return ((s - s[0]) / (s[-1] - s[0]))[1:]


def take(seed, profile, n=900, name=None):
    """Holds of random library expressions (25–40 frames) joined by transitions of 10–30
    frames shaped by ``profile(L)``; small tracking noise."""
    rng = np.random.default_rng(seed)
    protos = PROTOS
    cur = np.zeros(K)
    frames = []
    while len(frames) < n:
        frames += [cur] * int(rng.integers(25, 41))
        nxt = np.zeros(K) if rng.random() < 0.3 else \
            protos[rng.integers(len(protos))] * rng.uniform(0.6, 1.0)
        L = int(rng.integers(10, 31))
        frames += [cur + (nxt - cur) * p for p in profile(L)]
        cur = nxt
    x = np.clip(np.array(frames[:n]) + rng.normal(0, 0.003, (n, K)), 0, 1).astype(np.float32)
    return Take(name or f"t{seed}", 30.0, {"linear": x}, np.ones(n, bool))


def pool(profile, n_takes=3):
    return {f"t{i}": take(i, profile, name=f"t{i}") for i in range(n_takes)}


def test_folds_hold_out_every_take_once():
    folds = leave_one_take_out(["c", "a", "b", "d"])
    assert sorted(f.test[0] for f in folds) == ["a", "b", "c", "d"]
    for f in folds:
        assert not set(f.test) & set(f.train + f.val) and len(f.train + f.val) == 3


def test_known_answer_cosine_data_favours_cosine():
    """Transitions that are exactly cosine-eased: the cosine baseline is (near) perfect,
    linear is clearly worse — with an interval that excludes zero."""
    res = run_protocol(pool(cosine), leave_one_take_out(["t0", "t1", "t2"]),
                       [Baseline("linear"), Baseline("cosine")], l2_lengths=(5,))
    s = summarise(res, n_boot=300)
    assert s["n"] >= 30 and s["best_baseline"] == "cosine"
    cos, lin = s["methods"]["cosine"], s["methods"]["linear"]
    assert cos["mse"] < 0.4 * lin["mse"]  # segmented gaps are not exactly the eased spans
    assert lin["rel_ci"][0] > 0.8  # linear: > 80 % worse, whatever the resample
    assert cos["consp_n"] == 0
    assert set(res.take) == {"t0", "t1", "t2"}  # every take was tested


def test_protocol_does_not_depend_on_take_order():
    p = pool(cosine)
    methods = [Baseline("linear")]
    a = run_protocol(p, leave_one_take_out(list(p)), methods, l2_lengths=())
    b = run_protocol(dict(reversed(p.items())), leave_one_take_out(list(p)[::-1]), methods,
                     l2_lengths=())
    np.testing.assert_array_equal(a.se, b.se)
    np.testing.assert_array_equal(a.take, b.take)


def test_bootstrap_interval_covers_the_mean():
    x = np.random.default_rng(0).normal(1.0, 1.0, 400)
    lo, hi = bootstrap(lambda i: float(x[i].mean()), np.zeros(400), n=500)
    assert lo < 1.0 < hi and hi - lo < 0.3


def test_group_timing_of_a_known_curve():
    a, b = np.zeros(K), np.zeros(K)
    b[MODEL_CHANNELS.index("AU12")] = 0.8
    frames = a + (b - a) * snap(20, onset=3, rise=4)[:, None]
    groups = np.array([0 if c in ("AU01", "AU02", "AU04") else 3 if c == "AU12" else -1
                       for c in MODEL_CHANNELS])
    onset, peak = group_timing(a, frames, b, groups)
    assert onset[3] == 4  # the snap reaches 10 % one frame after its 3-frame wait
    assert 0.8 * 0.25 < peak[3] < 0.8 * 0.4  # a 4-frame snap moves ~30 % of the way per frame
    assert np.isnan(onset[0])  # the brows do not move


def test_timing_model_learns_a_snap_that_interpolators_miss():
    """Recordings that wait 2 frames then snap in 4: the learned timing model beats every
    interpolator on held-out takes (interval excluding zero) and moves as fast as they do."""
    res = run_protocol(pool(snap), leave_one_take_out(["t0", "t1", "t2"]),
                       [Baseline("linear"), Baseline("cosine"), Baseline("hermite"),
                        Learned("timing", RECIPES["timing"], inner_val=False)], l2_lengths=())
    s = summarise(res, n_boot=300)
    t = s["methods"]["timing"]
    assert t["rel_ci"][1] < -0.15  # ≥ 15 % below the best interpolator on every resample
    gt, model = (np.nanmedian(s["timing"]["peak"][k]) for k in ("ground truth", "timing"))
    lin = np.nanmedian(s["timing"]["peak"]["linear"])
    assert abs(model - gt) < 0.3 * gt < gt - lin


def _timing_checkpoint(validation):
    from mimika.learn.train import _build

    m = _build("timing", K, {})
    return {"kind": "timing", "config": {"n_channels": K}, "channels": list(MODEL_CHANNELS),
            "fps": 30.0, "state_dict": m.state_dict(), "validation": validation}


def _bins(use_model, baseline="linear"):
    from mimika.learn.protocol import SIZE_BINS

    return {"source": "test", "method": "model",
            "bins": [{"name": n, "lo": lo, "hi": hi, "n": 5, "use_model": use_model,
                      "baseline": baseline} for n, lo, hi in SIZE_BINS]}


@pytest.mark.parametrize(("validation", "expect"), [
    (_bins(False, "linear"), "linear"),
    (_bins(False, "hermite"), "smoothstep"),
    (None, "cosine"),  # no validation record: the timeline's default easing
    (_bins(True), None),
])
def test_learned_easing_falls_back_where_validation_says_worse(tmp_path, validation, expect):
    from mimika.learn.interp import LearnedInterpolator
    from mimika.learn.train import save_checkpoint
    from mimika.timeline import get_interpolator

    p = save_checkpoint(_timing_checkpoint(validation), tmp_path / "m.pt")
    a, b = np.zeros(3), np.array([0.9, 0.0, 0.4])
    u = np.linspace(0, 1, 31)
    ch = ("AU12", "AU01", "AU27")
    y = LearnedInterpolator(p)(a, b, u, channels=ch, duration=1.0)
    raw = LearnedInterpolator(p, fallback=False)(a, b, u, channels=ch, duration=1.0)
    if expect is None:
        np.testing.assert_allclose(y, raw)
    else:
        np.testing.assert_allclose(y, get_interpolator(expect)(a, b, u, channels=ch,
                                                                duration=1.0), atol=1e-6)
        assert np.abs(raw - y).max() > 0.05  # the model itself moves differently


def test_a_model_worse_on_validation_falls_back_end_to_end(tmp_path):
    """Train a timing model on cosine-eased takes, validate it on takes that snap: it loses
    to an interpolator there, so ease='learned' gives that interpolator's curve."""
    from mimika.learn.data import Split
    from mimika.learn.interp import LearnedInterpolator
    from mimika.learn.train import load_state, save_checkpoint, segment_split, train, validate
    from mimika.timeline import get_interpolator

    takes = {"a": take(0, cosine, name="a"), "b": take(1, cosine, name="b"),
             "v": take(2, lambda L: np.arange(1, L + 1) / L, name="v")}  # validation: linear
    data = segment_split(takes, Split(("a", "b"), ("v",), ()))
    ck = train(data, RECIPES["timing"])
    ck["validation"] = validate(load_state(ck), data)
    bins = {b["name"]: b for b in ck["validation"]["bins"]}
    assert not bins["medium"]["use_model"] and bins["medium"]["baseline"] == "linear"
    p = save_checkpoint(ck, tmp_path / "m.pt")
    a, b = np.zeros(2), np.array([0.4, 0.3])  # a medium transition
    u = np.linspace(0, 1, 16)
    y = LearnedInterpolator(p)(a, b, u, channels=("AU12", "AU06"), duration=0.5)
    np.testing.assert_allclose(y, get_interpolator("linear")(a, b, u), atol=1e-6)


FACEGOOD = os.environ.get("MIMIKA_FACEGOOD_DIR")


@pytest.mark.skipif(not FACEGOOD, reason="needs MIMIKA_FACEGOOD_DIR (shared/motion/facegood)")
def test_facegood_takes_map_onto_the_mouth_channels():
    from mimika.learn.facegood import covered_channels, load_facegood

    ch = covered_channels(FACEGOOD)
    assert {"AU12", "AU27", "AU16", "AU24"} <= set(ch)
    assert not {"AU01", "AU04", "AU05", "AU06"} & set(ch)  # brows, lids, cheeks: invalid
    takes = load_facegood(FACEGOOD)
    assert len(takes) == 7 and sum(t.n_frames for t in takes) == 19673
    off = ~np.isin(MODEL_CHANNELS, ch)
    for t in takes:
        assert t.fps == 30.0 and np.all(t.values[:, off] == 0)
        assert t.values[:, MODEL_CHANNELS.index("AU27")].max() > 0.2  # she talks


def test_facegood_column_shift_is_found_from_symmetric_pairs():
    from mimika.errors import DataError
    from mimika.learn.facegood import column_names

    names = ["jaw_c", "lip_l", "lip_r", "brow_l", "brow_r", "nose_c"]
    w = np.random.default_rng(0).uniform(0, 1, (50, 6))
    w[:, 2] = w[:, 1]  # a symmetric shape: its left and right columns are equal
    w[:, 4] = w[:, 3]
    assert column_names(names, w) == names
    shifted = np.roll(w, 1, axis=1)  # the export's layout: column i holds name i − 1
    assert column_names(names, shifted) == [names[-1], *names[:-1]]
    with pytest.raises(DataError, match="cannot tell"):
        column_names(names, np.random.default_rng(1).uniform(0, 1, (50, 6)))
