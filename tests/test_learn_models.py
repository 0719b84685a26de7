"""Transition models (torch): tiny training, generation, the shipped model, the ``learned``
easing and the CLI. Tiny models only — the whole file runs in seconds."""

import subprocess
import sys

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from mimika.learn.data import MODEL_CHANNELS, SEED_FRAMES, Split, Take  # noqa: E402
from mimika.learn.gan_data import prototypes  # noqa: E402
from mimika.learn.segment import Segmenter  # noqa: E402
from mimika.learn.train import (  # noqa: E402
    Prepared,
    TrainConfig,
    evaluate_loss,
    generate,
    load_model,
    save_checkpoint,
    train,
)

K = len(MODEL_CHANNELS)


def _take(rng, name, n=600):
    """Smooth random AU motion: holds of random prototypes joined by cosine transitions (the
    labelling prototypes kept with the models, so library tuning leaves these takes alone)."""
    protos = list(prototypes(MODEL_CHANNELS)[1:])
    frames = [np.zeros(K)]
    while len(frames) < n:
        p = protos[rng.integers(len(protos))] * rng.uniform(0.5, 1.0)
        L = int(rng.integers(8, 20))
        u = 0.5 - 0.5 * np.cos(np.pi * np.arange(1, L + 1) / L)
        frames += [frames[-1] + (p - frames[-1]) * x for x in u] + [p] * int(rng.integers(10, 30))
    v = np.clip(np.array(frames[:n]), 0, 1).astype(np.float32)
    return Take(name, 30.0, {"linear": v}, np.ones(n, bool))


@pytest.fixture(scope="module")
def tiny_data():
    rng = np.random.default_rng(7)
    takes = {n: _take(rng, n) for n in ("a", "b", "c")}
    seg = Segmenter(rows=4, cols=4, n_groups=4).fit([takes["a"].values])
    from mimika.learn.segment import transitions_between

    holds = {n: seg.holds(t.values) for n, t in takes.items()}
    trans = {n: transitions_between(t.values, holds[n], take=n, max_length=24)[:12]
             for n, t in takes.items()}
    assert all(trans.values()), "every part needs transitions, or the losses compare zeros"
    return Prepared(takes, Split(("a",), ("b",), ("c",)), seg, holds, trans)


@pytest.mark.parametrize(("kind", "args"), [
    ("seed", {"enc_hidden": 16, "gen_hidden": 24}),
    ("rtn", {"embed": 16, "hidden": 24}),
])
def test_tiny_training_reduces_loss(tiny_data, kind, args, tmp_path):
    from mimika.learn.train import _build

    val = tiny_data.items("val")[:8]
    torch.manual_seed(0)
    before = evaluate_loss(_build(kind, K, args), val)
    cfg = TrainConfig(model=kind, epochs=3, lr=0.01, windows_per_epoch=32, batch_size=16,
                      window_lengths=(5, 12), val_window_lengths=(), threads=1,
                      model_args=args)
    ck = train(tiny_data, cfg)
    assert ck["best_val"] < ck["history"][0]["train"] or ck["best_val"] < before
    model = load_model(save_checkpoint(ck, tmp_path / f"{kind}.pt"))
    after = evaluate_loss(model, val)
    assert after < before
    assert model.checkpoint["channels"] == list(MODEL_CHANNELS)
    assert model.checkpoint["fps"] == 30.0


def test_rtn_lands_on_the_target(tiny_data):
    from mimika.learn.train import _build

    model = _build("rtn", K, {"embed": 8, "hidden": 8}).eval()
    rng = np.random.default_rng(0)
    w = rng.uniform(0, 1, (SEED_FRAMES, K)).astype(np.float32)
    g = rng.uniform(0, 1, K).astype(np.float32)
    out = generate(model, w, g, 17)
    assert out.shape == (17, K)
    np.testing.assert_allclose(out[-1], g, atol=1e-5)  # the sin(πu) offset vanishes at u = 1


def test_shipped_model_makes_a_transition():
    from mimika.knowledge.expressions import get_expression
    from mimika.learn import transition

    a, b = get_expression("happiness"), get_expression("surprise")
    tr = transition(a, b, duration=1.2, fps=30)
    assert tr.n_frames == 37 and tr.fps == 30
    assert set(a) | set(b) <= set(tr.channels)
    for c in tr.channels:
        assert tr[c][0] == pytest.approx(a.get(c, 0.0), abs=1e-5)
        assert tr[c][-1] == pytest.approx(b.get(c, 0.0), abs=1e-5)
    assert np.all(np.abs(np.diff(tr.values, axis=0)) < 0.25)  # no conspicuous jumps
    raw = load_model(__import__("mimika.learn.interp", fromlist=["x"]).default_model_path())
    assert raw.checkpoint["kind"] == "timing"
    val = raw.checkpoint["validation"]  # held-out evidence the learned easing decides on
    assert "leave-one-take-out" in val["source"] and len(val["bins"]) == 3
    assert all(b["n"] > 0 and b["use_model"] == (b["rel"] < 0) for b in val["bins"])


def test_shipped_seed_lstm_for_comparison():
    """Seed 000's LSTM ships as ``model="seed"``: it makes a transition that starts and ends
    where asked, and falls back wherever its validation record has it lose or has no data."""
    from mimika.learn import transition
    from mimika.learn.interp import default_model_path, fallback_easing

    raw = load_model(default_model_path("seed"))
    assert raw.checkpoint["kind"] == "seed"
    assert default_model_path("seed").stat().st_size < 5_000_000
    bins = raw.checkpoint["validation"]["bins"]
    for b in bins:
        size = min(b["lo"] + 0.1, 0.9)
        uses_model = fallback_easing(raw.checkpoint, size) is None
        assert uses_model == (b["n"] > 0 and b["use_model"])
    a, b = {"AU12": 0.8, "AU06": 0.6}, {"AU01": 0.7, "AU02": 0.7}
    tr = transition(a, b, duration=0.5, fps=30, model="seed")
    assert tr.n_frames == 16
    assert tr["AU12"][0] == pytest.approx(0.8, abs=1e-5)
    assert tr["AU01"][-1] == pytest.approx(0.7, abs=1e-5)


def test_learned_easing_in_a_timeline():
    import mimika.learn  # noqa: F401  (registers "learned")
    from mimika.timeline import Event, get_interpolator, sample, timeline_from_events

    interp = get_interpolator("learned")
    a, b = np.array([0.0, 0.8, 0.3]), np.array([0.8, 0.0, 0.3])
    u = np.linspace(0, 1, 25)
    y = interp(a, b, u, channels=("AU12", "AU01", "weight"), duration=0.8)
    assert y.shape == (25, 3)
    np.testing.assert_allclose(y[0], a, atol=1e-5)
    np.testing.assert_allclose(y[-1], b, atol=1e-5)
    np.testing.assert_allclose(y[:, 2], 0.3, atol=1e-6)
    ev = [Event(kind="expression", name="happiness", start=0.0, duration=1.0, ease="learned"),
          Event(kind="expression", name="surprise", start=1.0, duration=1.0, ease="learned")]
    track = sample(timeline_from_events(ev), fps=30)
    assert track.n_frames >= 60 and "AU12" in track.channels
    assert np.all((track.values >= 0) & (track.values <= 1))


def test_import_mimika_and_learn_do_not_load_torch():
    code = ("import sys, mimika, mimika.learn, mimika.timeline; "
            "print('torch' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "False"


def _transition_cli(*argv: str) -> int:
    """``mimika transition …`` through the command module's parser."""
    import argparse

    from mimika.commands import learn

    parser = argparse.ArgumentParser()
    sub = parser.add_subparsers(dest="command", required=True)
    learn.register(sub)
    args = parser.parse_args(["transition", *argv])
    return args.func(args)


def test_cli_transition_csv(tmp_path):
    from mimika.io.tracks import read_au_csv

    p = tmp_path / "t.csv"
    assert _transition_cli("--from", "happiness", "--to", "surprise", "--duration", "0.5",
                           "-o", str(p), "-q") == 0
    tr = read_au_csv(p)
    assert tr.n_frames == 16


@pytest.mark.render
def test_cli_transition_mp4_moves_from_one_face_to_the_other(tmp_path):
    import av

    from mimika.errors import ParameterError

    p = tmp_path / "t.mp4"
    assert _transition_cli("--from", "neutral", "--to", "surprise", "--duration", "0.5",
                           "-o", str(p), "-q") == 0
    with av.open(str(p)) as c:
        frames = [f.to_ndarray(format="rgb24").astype(int) for f in c.decode(video=0)]
    assert len(frames) == 16 and frames[0].shape == (480, 640, 3)
    # the brows rise: the upper face changes between the first and the last frame
    assert np.abs(frames[-1][120:240] - frames[0][120:240]).mean() > 1.0
    with pytest.raises(ParameterError, match=r"\.csv, \.png or \.mp4"):
        _transition_cli("--from", "neutral", "--to", "surprise", "-o", str(tmp_path / "t.gif"))
