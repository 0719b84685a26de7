"""Train the streaming recogniser's class model (``speech/data/mouth_classes.npz``).

Data: the GRID recordings of speaker s1 in ``$MIMIKA_SPEECH_DIR`` (GRID audiovisual sentence
corpus, Cooke, Barker, Cunningham & Shao 2006, CC BY 4.0). Utterances of the test split
(:func:`_grid.is_test`, a fifth by a hash of the name) are never trained on; of the rest a
tenth (``is_val``) chooses the decoder's switch cost and prior weight. Labels: the phoneme
class (``visemes.json``) sounding at each frame's centre in the transcript-aligned phones
(``mimika align`` with the transcript). Every training recording is used as is and in
``--copies`` altered copies: speed 0.85–1.18 (pitch and formants move with it, as another
voice's would), gain −20…+12 dB, a first-order tilt, white or brown noise at 10–40 dB SNR,
rate 8–48 kHz, and features taken with every band's frequency scaled by 0.85–1.15 (another
vocal tract length).

GRID is one speaker reading a 51-word grammar; a model of it alone hears another voice badly
(a Piper voice: 37 % viseme agreement against 59 % for pocketsphinx). So the training set
also holds ``--tts`` synthetic sentences of random words from the CMU dictionary (shipped with
pocketsphinx), spoken by the Piper voice en_US-joe-medium (CC0) and by espeak-ng variants
at 120–220 words per minute, labelled by the synthesiser's own phone timing, each also in
altered copies. None of them is in any evaluation (those use written sentences).

The model is an MLP (two hidden ReLU layers) over the features of the frames at ``offsets``
around each frame (:class:`mimika.speech.streaming.Model`), trained with cross-entropy
(Adam); weights are stored as float16.

    .venv/bin/python bench/train_mouth_classes.py [--epochs 16] [--hidden 192] [--right 4]
        [--copies 4] [--tts 360] [--warp 0.15] [--cache /tmp/grid-ref.pkl] [--out PATH]

The defaults made the shipped model (about 25 minutes on one loaded core).
"""

from __future__ import annotations

import argparse
import hashlib
import io
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import single_core

single_core()
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))
from _grid import grid_dir, ids, is_test, load, references
from mimika.speech import streaming
from mimika.speech.phonemes import segments

LEFT = (-15, -11, -8, -6, -4, -3, -2, -1)
OUT = Path(__file__).resolve().parents[1] / "src" / "mimika" / "speech" / streaming.MODEL


def is_val(uid: str) -> bool:
    return int(hashlib.md5(uid.encode()).hexdigest(), 16) % 10 == 0


def labels(u, n: int, speed: float = 1.0) -> list[str]:
    """The class at each frame centre (``speed`` > 1: the recording was sped up)."""
    t = (np.arange(n) + 0.5) / streaming.RATE * speed
    out = ["sil"] * n
    for s in segments(u):
        for k in np.nonzero((t >= s.start) & (t < s.end))[0]:
            out[k] = s.cls
    return out


def augment(a: np.ndarray, sr: int, rng: np.random.Generator, warp: float = 0.0
            ) -> tuple[np.ndarray, int, float, float]:
    """A randomly altered copy: (audio, its rate, speed, the features' frequency warp: a
    vocal tract up to ``warp`` shorter or longer)."""
    from mimika.speech.audio import resample

    speed = float(rng.uniform(0.85, 1.18))
    # speed: play the samples at sr * speed, i.e. resample them to sr / speed
    b = resample(a, orig_sr=round(sr * speed / 10) * 10, target_sr=sr)
    speed = len(a) / max(len(b), 1)
    tilt = float(rng.uniform(-0.6, 0.6))
    b = b + tilt * np.concatenate([[0.0], b[:-1]])
    b = b * 10 ** (rng.uniform(-20, 12) / 20)
    if rng.random() < 0.6:
        noise = rng.standard_normal(len(b))
        if rng.random() < 0.5:
            noise = np.cumsum(noise)
            noise -= np.convolve(noise, np.ones(400) / 400, mode="same")
        snr = rng.uniform(10, 40)
        p_sig = float(np.mean(b ** 2)) + 1e-12
        noise *= np.sqrt(p_sig / (np.mean(noise ** 2) + 1e-12) / 10 ** (snr / 10))
        b = b + noise
    b = np.clip(b, -1, 1).astype(np.float32)
    new_sr = int(rng.choice([8000, 16000, 16000, 22050, 24000, 44100, 48000]))
    if new_sr != sr:
        b = resample(b, orig_sr=sr, target_sr=new_sr)
    return b, new_sr, speed, float(rng.uniform(1 - warp, 1 + warp))


ESPEAK_VARIANTS = ("m1", "m2", "m3", "m4", "f1", "f2", "f3", "f4", "klatt")


def tts_corpus(n: int, rng: np.random.Generator):
    """``n`` synthetic utterances: (audio, sr, Utterance) — random dictionary words, the
    Piper voice for two thirds, espeak-ng variants for the rest."""
    import os
    import re

    import pocketsphinx

    from mimika.speech.tts import synthesize

    path = os.path.join(pocketsphinx.get_model_path(), "en-us", "cmudict-en-us.dict")
    with open(path, encoding="utf-8") as f:
        vocab = sorted({w for ln in f if re.fullmatch(r"[a-z]{2,9}", w := ln.split()[0])})
    for i in range(n):
        words = [str(w) for w in rng.choice(vocab, int(rng.integers(4, 10)))]
        if rng.random() < 0.5:
            words[int(rng.integers(1, len(words)))] += ","
        text = " ".join(words).capitalize() + "."
        rate = int(rng.integers(120, 221))
        if i % 3 < 2:
            u = synthesize(text, engine="piper", rate=rate)
        else:
            u = synthesize(text, engine="espeak", rate=rate,
                           voice=f"en-us+{ESPEAK_VARIANTS[i % len(ESPEAK_VARIANTS)]}",
                           pitch=int(rng.integers(30, 71)))
        yield u.audio, u.sr, u


def features(a: np.ndarray, sr: int, warp: float = 1.0) -> np.ndarray:
    return streaming.Features(sr, warp=warp).push(a, final=True)


def windows(f: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """Rows of stacked context (edges repeated as the recogniser does), shape (n, k, d)."""
    lo, hi = -offsets.min(), offsets.max()
    g = np.concatenate([np.repeat(f[:1], lo, 0), f, np.repeat(f[-1:], hi, 0)])
    return g[np.arange(len(f))[:, None] + (offsets + lo)[None, :]]


def train(x: np.ndarray, y: np.ndarray, n_cls: int, hidden: int, epochs: int,
          seed: int) -> list[tuple[np.ndarray, np.ndarray]]:
    import torch

    torch.manual_seed(seed)
    torch.set_num_threads(1)
    d = x.shape[1]
    net = torch.nn.Sequential(
        torch.nn.Linear(d, hidden), torch.nn.ReLU(), torch.nn.Dropout(0.2),
        torch.nn.Linear(hidden, hidden), torch.nn.ReLU(), torch.nn.Dropout(0.2),
        torch.nn.Linear(hidden, n_cls))
    opt = torch.optim.AdamW(net.parameters(), lr=2e-3, weight_decay=1e-4)
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, max_lr=2e-3, total_steps=epochs *
                                                ((len(x) + 511) // 512))
    xt, yt = torch.from_numpy(x), torch.from_numpy(y)
    g = torch.Generator().manual_seed(seed)
    for ep in range(epochs):
        net.train()
        perm = torch.randperm(len(x), generator=g)
        tot = 0.0
        for k in range(0, len(x), 512):
            i = perm[k:k + 512]
            loss = torch.nn.functional.cross_entropy(net(xt[i]), yt[i], label_smoothing=0.05)
            opt.zero_grad()
            loss.backward()
            opt.step()
            sched.step()
            tot += float(loss) * len(i)
        print(f"  epoch {ep + 1}/{epochs}: loss {tot / len(x):.3f}", flush=True)
    lin = [m for m in net if isinstance(m, torch.nn.Linear)]
    return [(m.weight.detach().numpy().T.copy(), m.bias.detach().numpy().copy()) for m in lin]


def frame_agreement(model: streaming.Model, data, dec: dict) -> float:
    """Share of frames whose decoded class has the reference's Oculus viseme."""
    from mimika.speech.phonemes import viseme_table

    ocu = {c: v["oculus"] for c, v in viseme_table()["classes"].items()}
    streaming.model.cache_clear()
    hit = n = 0
    for f, lab in data:
        d = streaming.Decoder(len(model.classes), lag=dec["lag"], switch=dec["switch"],
                              prior_weight=dec["prior_weight"], log_prior=model.log_prior,
                              start=model.classes.index("sil"))
        g = np.concatenate([np.repeat(f[:1], model.left, 0), f,
                            np.repeat(f[-1:], model.right, 0)])
        got = [model.classes[c] for c in d.push(model.scores(g), final=True)]
        hit += sum(ocu[a] == ocu[b] for a, b in zip(got, lab, strict=True))
        n += len(lab)
    return hit / n


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--epochs", type=int, default=16)
    ap.add_argument("--hidden", type=int, default=192)
    ap.add_argument("--right", type=int, default=4, help="future frames the model sees")
    ap.add_argument("--lag", type=int, default=2, help="decoder lag (frames)")
    ap.add_argument("--copies", type=int, default=4, help="altered copies per recording")
    ap.add_argument("--tts", type=int, default=360, help="synthetic utterances")
    ap.add_argument("--tts-copies", type=int, default=2, help="altered copies of each")
    ap.add_argument("--cache", type=Path, help="pickle of the aligned references")
    ap.add_argument("--out", type=Path, default=OUT)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--warp", type=float, default=0.15,
                    help="altered copies' features: frequencies scaled by 1 ± up to this "
                         "(another vocal tract length)")
    args = ap.parse_args()
    d = grid_dir()
    uids = ids(d)
    train_ids = [u for u in uids if not is_test(u)]
    fit_ids = [u for u in train_ids if not is_val(u)]
    val_ids = [u for u in train_ids if is_val(u)]
    print(f"{len(uids)} utterances: {len(fit_ids)} fit, {len(val_ids)} validation, "
          f"{len(uids) - len(train_ids)} test (not used)", flush=True)
    refs = references(d, train_ids, args.cache)
    rng = np.random.default_rng(args.seed)
    offsets = np.array(LEFT + tuple(range(0, args.right + 1)))
    xs, ys, val = [], [], []
    t0 = time.perf_counter()
    for uid in train_ids:
        a, sr = load(d, uid)
        f = features(a, sr)
        lab = labels(refs[uid], len(f))
        if is_val(uid):
            val.append((f, lab))
            continue
        xs.append(windows(f, offsets))
        ys += lab
        for _ in range(args.copies):
            b, sr2, speed, warp = augment(a, sr, rng, args.warp)
            f = features(b, sr2, warp)
            xs.append(windows(f, offsets))
            ys += labels(refs[uid], len(f), speed)
    for i, (a, sr, u) in enumerate(tts_corpus(args.tts, rng)):
        for k in range(args.tts_copies + 1):
            b, sr2, speed, warp = (a, sr, 1.0, 1.0) if k == 0 else \
                augment(a, sr, rng, args.warp)
            f = features(b, sr2, warp)
            lab = labels(u, len(f), speed)
            if i % 10 == 9:  # a tenth chooses the decoder's parameters too
                if k == 0:
                    val.append((f, lab))
                continue
            xs.append(windows(f, offsets))
            ys += lab
    print(f"features: {sum(len(x) for x in xs)} frames in {time.perf_counter() - t0:.0f} s",
          flush=True)
    classes = sorted(set(ys), key=list(streaming.SYMBOL).index)
    y = np.array([classes.index(c) for c in ys], np.int64)
    x = np.concatenate(xs)
    mean = x.reshape(-1, x.shape[2]).mean(axis=0)
    std = x.reshape(-1, x.shape[2]).std(axis=0) + 1e-3
    x = ((x - mean) / std).reshape(len(x), -1).astype(np.float32)
    layers = train(x, y, len(classes), args.hidden, args.epochs, args.seed)
    prior = np.bincount(y, minlength=len(classes)) / len(y)
    meta = {"about": "mimika.speech.streaming class model: log-posteriors of phoneme classes "
                     "from log-mel frames",
            "data": "GRID audiovisual sentence corpus (Cooke, Barker, Cunningham & Shao 2006), "
                    "speaker s1, CC BY 4.0, labels: mimika align with the transcript; "
                    "synthetic sentences of CMU-dictionary words by the Piper voice "
                    "en_US-joe-medium (CC0) and espeak-ng variants, labels: their phone "
                    "timing",
            "trained_by": "bench/train_mouth_classes.py " + " ".join(
                f"--{k.replace('_', '-')} {v}" for k, v in sorted(vars(args).items())
                if k not in ("cache", "out")),
            "train": fit_ids, "validation": val_ids}
    arrays = {"classes": np.array(classes), "offsets": offsets,
              "mean": mean.astype(np.float32), "std": std.astype(np.float32),
              "n_layers": np.array(len(layers)),
              "log_prior": np.log(prior + 1e-6).astype(np.float32)}
    for i, (w, b) in enumerate(layers):
        arrays[f"w{i}"], arrays[f"b{i}"] = w.astype(np.float16), b.astype(np.float16)
    best = None
    for switch in (2.0, 4.0, 6.0, 9.0, 12.0):
        for pw in (0.0, 0.3, 0.6):
            dec = {"lag": args.lag, "switch": switch, "prior_weight": pw}
            model = streaming.Model({**arrays, "meta": json.dumps({**meta, "decoder": dec})})
            acc = frame_agreement(model, val, dec)
            print(f"  decoder switch {switch:4.1f} prior {pw:.1f}: validation viseme "
                  f"agreement {100 * acc:.1f}%", flush=True)
            if best is None or acc > best[0]:
                best = (acc, dec)
    assert best is not None
    meta["decoder"] = best[1]
    buf = io.BytesIO()
    np.savez_compressed(buf, meta=np.array(json.dumps(meta)), **arrays)
    args.out.write_bytes(buf.getvalue())
    print(f"wrote {args.out} ({len(buf.getvalue()) / 1024:.0f} KiB): decoder {best[1]}, "
          f"validation viseme agreement {100 * best[0]:.1f}%")


if __name__ == "__main__":
    main()
