"""The timeline's ``learned`` interpolation mode and :func:`transition` (no torch at import).

:class:`LearnedInterpolator` is an :class:`~mimika.timeline.easing.Interpolator`: it loads its
model on first call, generates the transition at the model's frame rate over the model's
channels and samples it at the requested progress values. Channels the model does not know
follow the model's progress on an alias (AU26/AU25 → AU27, AU23 → AU24) where there is one,
else a cosine ease; the result is nudged linearly so it equals ``a`` at u = 0 and ``b`` at
u = 1 exactly, and clipped to [0, 1].

**It never does worse than interpolation on validation**: a checkpoint carries a validation
record (:func:`mimika.learn.protocol.validation_record`: per transition size, the model's MSE
on held-out transitions against the best interpolator's). For a transition whose size class
the model lost — or was never validated on — the easing falls back to that interpolator
(cubic Hermite at rest = ``smoothstep``; without any record, the timeline's default easing).
"""

from __future__ import annotations

import logging
import math
import os
import threading
from collections.abc import Mapping, Sequence
from importlib import resources
from pathlib import Path

import numpy as np

from mimika.errors import ParameterError
from mimika.learn.data import MODEL_CHANNELS, SEED_FRAMES

log = logging.getLogger(__name__)

__all__ = ["DEFAULT_MODEL", "LearnedInterpolator", "fallback_easing", "register_learned",
           "transition"]

ALIASES = {"AU26": "AU27", "AU25": "AU27", "AU23": "AU24"}
#: protocol baselines → timeline easings (the timeline's transitions start at rest, where cubic
#: Hermite is smoothstep)
EASING_OF = {"linear": "linear", "cosine": "cosine", "hermite": "smoothstep",
             "smoothstep": "smoothstep"}


#: shipped checkpoints by name: the default timing model and seed 000's LSTM (for comparison)
SHIPPED = {"builtin": "transitions.pt", "timing": "transitions.pt",
           "seed": "transitions_seed.pt"}


def default_model_path(name: str = "builtin") -> Path:
    """A shipped model (``mimika/learn/data/…``): ``builtin``/``timing`` or ``seed``."""
    return Path(str(resources.files("mimika.learn").joinpath("data", SHIPPED[name])))


DEFAULT_MODEL = "builtin"
_CACHE: dict[str, object] = {}
_LOCK = threading.Lock()


def _model(path: str | os.PathLike | None):
    from mimika.learn.train import load_model

    name = DEFAULT_MODEL if path is None else str(path)
    key = str(default_model_path(name) if name in SHIPPED else Path(path))
    with _LOCK:
        if key not in _CACHE:
            _CACHE[key] = load_model(key)
            log.info("loaded transition model %s", key)
        return _CACHE[key]


def _to_model(v: Mapping[str, float], channels: Sequence[str]) -> np.ndarray:
    """Input AUs → a vector over the model's ``channels``: one-sided ``AUxxL/R`` add half to
    ``AUxx`` (as :func:`~mimika.learn.data.fold_channels`), aliases (AU26 → AU27 …) take the
    maximum; clipped to [0, 1]."""
    out = np.zeros(len(channels))
    idx = {c: j for j, c in enumerate(channels)}
    for c, x in v.items():
        if c in idx:
            out[idx[c]] += float(x)
        elif c[:4] in idx and c[4:] in ("L", "R"):
            out[idx[c[:4]]] += 0.5 * float(x)
    for c, x in v.items():
        if c not in idx and c[:4] in ALIASES and ALIASES[c[:4]] in idx:
            j = idx[ALIASES[c[:4]]]
            out[j] = max(out[j], float(x))
    return np.clip(out, 0.0, 1.0).astype(np.float32)


def _curves(model, a: np.ndarray, b: np.ndarray, n: int) -> np.ndarray:
    """n + 1 frames (start … target) over the model's channels: the start is held for the
    seed window (as in seed 000's inference)."""
    from mimika.learn.train import generate

    window = np.repeat(a[None], SEED_FRAMES, axis=0)
    gen = generate(model, window, b, n)  # (n, K)
    return np.concatenate([a[None], gen], axis=0)


def transition(start: Mapping[str, float], target: Mapping[str, float], *, duration: float,
               fps: float = 30.0, model: str | os.PathLike | None = None,
               exact_ends: bool = True, fallback: bool = True):
    """A learned transition from ``start`` to ``target`` AUs (``{code: intensity}``).

    Returns an :class:`~mimika.tracks.AUTrack` of ``round(duration·fps) + 1`` frames (start
    and target included) over the union of the model's channels with those of the inputs;
    ``model`` and ``fallback`` as for :class:`LearnedInterpolator`.
    """
    from mimika.limits import check_timeline
    from mimika.tracks import AUTrack, valid_fps

    fps = valid_fps(fps)
    if not (math.isfinite(duration) and duration > 0):
        raise ParameterError(f"duration={duration!r} s must be > 0")
    check_timeline(duration, fps, "the transition")  # mimika.limits, before allocating
    n = max(1, round(duration * fps))
    codes = list(dict.fromkeys([*MODEL_CHANNELS, *start, *target]))
    a = np.array([float(start.get(c, 0.0)) for c in codes])
    b = np.array([float(target.get(c, 0.0)) for c in codes])
    u = np.arange(n + 1) / n
    vals = LearnedInterpolator(model, exact_ends=exact_ends, fallback=fallback)(
        a, b, u, channels=codes, duration=duration)
    return AUTrack(vals, tuple(codes), fps, {"source": "learned transition"})


class LearnedInterpolator:
    """A transition model as a timeline easing (see the module docstring).

    Parameters
    ----------
    model : checkpoint path, or a shipped model's name (None / ``"builtin"``: the default;
        ``"seed"``: seed 000's LSTM), loaded lazily
    fps : rate the model generates at (default: the checkpoint's)
    exact_ends : nudge the curves so they start at ``a`` and end at ``b`` exactly
    fallback : use the best interpolator where validation says the model is worse (False:
        always the model — for comparisons)
    """

    def __init__(self, model: str | os.PathLike | None = None, *, fps: float | None = None,
                 exact_ends: bool = True, fallback: bool = True):
        self.model_path = model
        self.fps = fps
        self.exact_ends = exact_ends
        self.fallback = fallback

    def __repr__(self) -> str:
        return f"<learned transition {self.model_path or DEFAULT_MODEL}>"

    def __call__(self, a: np.ndarray, b: np.ndarray, u: np.ndarray, *,
                 channels: Sequence[str] = (), duration: float = 1.0) -> np.ndarray:
        a = np.asarray(a, np.float64).reshape(-1)
        b = np.asarray(b, np.float64).reshape(-1)
        u = np.clip(np.asarray(u, np.float64).reshape(-1), 0.0, 1.0)
        chans = list(channels) or [f"c{j}" for j in range(len(a))]
        if len(chans) != len(a) or len(b) != len(a):
            raise ParameterError(f"a, b and channels must have one length, got {len(a)}, "
                                 f"{len(b)}, {len(chans)}")
        model = _model(self.model_path)
        mch = list(model.checkpoint["channels"])
        fps = float(self.fps or model.checkpoint.get("fps", 30.0))
        n = int(np.clip(round(float(duration) * fps), 1, 600))
        am = _to_model(dict(zip(chans, a, strict=True)), mch)
        bm = _to_model(dict(zip(chans, b, strict=True)), mch)
        fallback = (fallback_easing(model.checkpoint, float(np.max(np.abs(bm - am), initial=0)))
                    if self.fallback else None)
        if fallback is not None:
            from mimika.timeline.easing import get_interpolator

            return get_interpolator(fallback)(a, b, u, channels=chans, duration=duration)
        curves = _curves(model, am, bm, n)  # (n + 1, K) start … target
        grid = np.arange(n + 1) / n
        idx = {c: j for j, c in enumerate(mch)}

        def at(uu: np.ndarray) -> np.ndarray:  # (T,) progress → (T, len(chans))
            out = a + (b - a) * (0.5 - 0.5 * np.cos(np.pi * uu))[:, None]  # fallback: cosine
            for k, c in enumerate(chans):
                src = c if c in idx else (c[:4] if c[:4] in idx else ALIASES.get(c[:4]))
                if src is None:
                    continue
                y = np.interp(uu, grid, curves[:, idx[src]])
                if src == c:
                    out[:, k] = y
                    continue
                span = bm[idx[src]] - am[idx[src]]  # follow the source channel's progress
                if abs(span) > 0.05:
                    p = np.clip((y - am[idx[src]]) / span, -0.25, 1.25)
                    out[:, k] = a[k] + (b[k] - a[k]) * p
            return out

        out = at(u)
        if self.exact_ends:  # remove the model's residual offsets at both ends linearly
            f0, f1 = at(np.zeros(1))[0], at(np.ones(1))[0]
            out = out + (a - f0)[None] * (1 - u)[:, None] + (b - f1)[None] * u[:, None]
        return np.clip(out, 0.0, 1.0).astype(np.float32)


def fallback_easing(checkpoint: Mapping, size: float) -> str | None:
    """The easing to use instead of the model for a transition of ``size`` (largest AU change
    over the model's channels), or None to use the model (see the module docstring)."""
    from mimika.timeline.easing import DEFAULT_EASING

    val = checkpoint.get("validation")
    if not val:
        _warn_once(f"model {checkpoint.get('kind')!r} has no validation record; the learned "
                   f"easing falls back to {DEFAULT_EASING!r}")
        return DEFAULT_EASING
    for b in val["bins"]:
        if b["lo"] <= size < b["hi"]:
            if b["use_model"]:
                return None
            return EASING_OF.get(b.get("baseline") or "", DEFAULT_EASING)
    return DEFAULT_EASING


_WARNED: set[str] = set()


def _warn_once(msg: str) -> None:
    if msg not in _WARNED:
        _WARNED.add(msg)
        log.warning(msg)


def register_learned(model: str | os.PathLike | None = None, *, name: str = "learned",
                     replace: bool = True) -> LearnedInterpolator:
    """Register a :class:`LearnedInterpolator` as the timeline easing ``name`` (no torch is
    loaded until the easing is first used)."""
    from mimika.timeline.easing import register_interpolator

    interp = LearnedInterpolator(model)
    register_interpolator(name, interp, replace=replace)
    return interp
