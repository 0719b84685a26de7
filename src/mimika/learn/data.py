"""Data pipeline for learned transitions: takes → AU frames → transition examples.

A *take* is any AU-bearing CSV :func:`mimika.io.tracks.read_track` reads (Live Link Face,
OpenFace or mimika AU CSV). Frames are folded onto :data:`MODEL_CHANNELS` — 20 bilateral face
AUs (one-sided residuals ``AUxxL/R`` add half to ``AUxx``); gaze, blinks, tongue and head AUs
are left out (they are separate behaviour channels, not part of an expression transition).

A :class:`Transition` is seed 000's training unit: a 20-frame seed window ending at the start
frame, then the frames up to and including the target frame. Splits are by take, never by
frame; gap-filling augmentation (linear / quadratic / cubic Lagrange, ×3 as in the seed) is
applied per take, so every variant of a take stays in that take's split.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mimika.errors import DataError, ParameterError
from mimika.tracks import AUTrack

log = logging.getLogger(__name__)

__all__ = ["FILLS", "MODEL_CHANNELS", "SEED_FRAMES", "Split", "Take", "Transition",
           "fold_channels", "list_takes", "load_take", "load_takes", "make_split",
           "random_windows", "stack_batch"]

#: the AU channels the transition models read and write (bilateral, face only)
MODEL_CHANNELS: tuple[str, ...] = (
    "AU01", "AU02", "AU04", "AU05", "AU06", "AU07", "AU09", "AU10", "AU11", "AU12",
    "AU14", "AU15", "AU16", "AU17", "AU18", "AU20", "AU22", "AU24", "AU27", "AU28",
)
#: frames in the seed window (seed 000: 20)
SEED_FRAMES = 20
#: gap-filling variants used for augmentation (seed 000: ×3)
FILLS = ("linear", "quadratic", "cubic")


def fold_channels(values: np.ndarray, channels: Sequence[str],
                  out_channels: Sequence[str] = MODEL_CHANNELS) -> np.ndarray:
    """Fold AU frames onto ``out_channels``.

    Parameters
    ----------
    values : ndarray, shape (T, K) — intensities over ``channels``
    channels : K canonical AU codes; ``AUxxL``/``AUxxR`` add half their value to ``AUxx``

    Returns
    -------
    ndarray, shape (T, len(out_channels)), float32, clipped to [0, 1]
    """
    v = np.asarray(values, np.float64).reshape(len(values), len(channels))
    out = np.zeros((len(v), len(out_channels)))
    idx = {c: j for j, c in enumerate(out_channels)}
    for k, c in enumerate(channels):
        if c in idx:
            out[:, idx[c]] += v[:, k]
        elif c[:4] in idx and c[4:] in ("L", "R"):
            out[:, idx[c[:4]]] += 0.5 * v[:, k]
    return np.clip(out, 0.0, 1.0).astype(np.float32)


@dataclass
class Take:
    """One recording folded onto the model channels.

    ``variants`` maps a gap-filling method to frames (T, K) float32 in [0, 1]; ``valid`` (T,)
    marks tracked frames (False: drop-out or missing row, filled).
    """

    name: str
    fps: float
    variants: dict[str, np.ndarray]
    valid: np.ndarray
    channels: tuple[str, ...] = MODEL_CHANNELS
    meta: dict = field(default_factory=dict)

    @property
    def values(self) -> np.ndarray:
        """The linear-filled frames, shape (T, K)."""
        return self.variants.get("linear", next(iter(self.variants.values())))

    @property
    def n_frames(self) -> int:
        return len(self.values)

    def track(self, fill: str = "linear") -> AUTrack:
        return AUTrack(self.variants[fill], self.channels, self.fps, {"take": self.name})


def list_takes(folder: str | os.PathLike) -> list[Path]:
    """Every ``*.csv`` in ``folder`` (sorted); raises :class:`DataError` if there are none."""
    d = Path(folder)
    if not d.is_dir():
        raise DataError(f"{d} is not a folder of takes (expected CSV files, e.g. Live Link Face)")
    files = sorted(p for p in d.glob("*.csv") if p.is_file())
    if not files:
        raise DataError(f"{d}: no *.csv takes found")
    return files


def load_take(path: str | os.PathLike, *, fills: Sequence[str] = ("linear",),
              fps: float | None = None) -> Take:
    """Read one take and fold it onto :data:`MODEL_CHANNELS`.

    Live Link Face and OpenFace takes are read once per gap-filling method in ``fills``
    (``linear``, ``quadratic``, ``cubic``); AU CSVs have no drop-outs (one variant).
    ``fps`` resamples the frames (default: the take's own rate).
    """
    from mimika.io.tracks import detect_format, read_track

    p = Path(path)
    for f in fills:
        if f not in FILLS:
            raise ParameterError(f"fill={f!r} must be one of {', '.join(FILLS)}")
    fmt = detect_format(p)
    variants: dict[str, np.ndarray] = {}
    meta: dict = {"source": str(p), "format": fmt}
    track = None
    for f in fills if fmt != "au" else ("linear",):
        track = read_track(p, fill=f) if fmt != "au" else read_track(p)
        if fps is not None:
            track = track.resample(fps=fps)
        variants[f] = fold_channels(track.values, track.channels)
        meta.update({k: v for k, v in track.meta.items() if k in ("dropouts", "missing_rows",
                                                                  "filled")})
    assert track is not None
    n = len(next(iter(variants.values())))
    filled = int(meta.get("filled", 0))
    if filled and len(variants) > 1:
        vs = list(variants.values())
        valid = np.all(np.stack([np.all(v == vs[0], axis=1) for v in vs[1:]]), axis=0)
    elif filled:  # the rows a hold-fill changes are the filled ones (unless flat there)
        held = read_track(p, fill="hold")
        if fps is not None:
            held = held.resample(fps=fps)
        h = fold_channels(held.values, held.channels)
        valid = np.all(h == next(iter(variants.values())), axis=1)
    else:
        valid = np.ones(n, bool)
    log.info("take %s: %d frames at %g fps, %d filled", p.stem, n, track.fps, filled)
    return Take(p.stem, float(track.fps), variants, valid, MODEL_CHANNELS, meta)


def load_takes(paths: Sequence[str | os.PathLike], *, fills: Sequence[str] = ("linear",)
               ) -> list[Take]:
    """:func:`load_take` for each path; every take must share one frame rate."""
    takes = [load_take(p, fills=fills) for p in paths]
    rates = {t.fps for t in takes}
    if len(rates) > 1:
        raise DataError(f"takes have different frame rates {sorted(rates)}; resample them first")
    return takes


@dataclass(frozen=True)
class Split:
    """Take names per split (by take, never by frame)."""

    train: tuple[str, ...]
    val: tuple[str, ...]
    test: tuple[str, ...]

    def of(self, name: str) -> str:
        for s in ("train", "val", "test"):
            if name in getattr(self, s):
                return s
        return "unused"


def make_split(names: Sequence[str], *, val: Sequence[str] | None = None,
               test: Sequence[str] | None = None) -> Split:
    """Split take names. Defaults: ``apfel`` (else the last name) is the test take, ``facial``
    (else the last remaining name) the validation take, the rest train. Needs ≥ 3 takes unless
    ``val``/``test`` are given explicitly (an empty list is allowed)."""
    names = list(dict.fromkeys(names))
    for group in (val or []), (test or []):
        for n in group:
            if n not in names:
                raise ParameterError(f"take {n!r} is not among {', '.join(names)}")
    if test is None:
        test = ["apfel"] if "apfel" in names else names[-1:]
    rest = [n for n in names if n not in test]
    if val is None:
        val = ["facial"] if "facial" in rest else rest[-1:]
    train = [n for n in rest if n not in val]
    if not train:
        raise ParameterError(f"no training takes left among {', '.join(names)} "
                             f"(validation {list(val)}, test {list(test)})")
    return Split(tuple(train), tuple(val), tuple(test))


@dataclass(frozen=True)
class Transition:
    """One transition example.

    ``window`` (SEED_FRAMES, K): the seed frames, the last one is the start frame;
    ``frames`` (L, K): the frames to generate, the last one is the target (L ≥ 1).
    ``start``: index of the start frame in the take; labels name the holds (or ``""``).
    """

    take: str
    start: int
    window: np.ndarray
    frames: np.ndarray
    source: str = ""
    target_label: str = ""
    fill: str = "linear"

    @property
    def length(self) -> int:
        return len(self.frames)

    @property
    def target(self) -> np.ndarray:
        return self.frames[-1]

    @property
    def start_frame(self) -> np.ndarray:
        return self.window[-1]


def window_at(values: np.ndarray, start: int, length: int, *, take: str = "",
              fill: str = "linear", source: str = "", target_label: str = "") -> Transition:
    """The transition starting at frame ``start`` with ``length`` generated frames."""
    if length < 1 or start < SEED_FRAMES - 1 or start + length > len(values) - 1:
        raise ParameterError(f"window start={start}, length={length} does not fit a take of "
                             f"{len(values)} frames with a {SEED_FRAMES}-frame seed")
    w = values[start - SEED_FRAMES + 1:start + 1]
    f = values[start + 1:start + length + 1]
    return Transition(take, start, np.array(w), np.array(f), source, target_label, fill)


def random_windows(take: Take, n: int, rng: np.random.Generator, *,
                   lengths: tuple[int, int] = (5, 45)) -> list[Transition]:
    """``n`` random in-betweening windows (any start, length in ``lengths``) from every
    gap-filling variant of ``take`` — the dense training signal besides segmented transitions."""
    out = []
    fills = list(take.variants)
    T = take.n_frames
    for _ in range(n):
        L = int(rng.integers(lengths[0], lengths[1] + 1))
        if T < SEED_FRAMES + L + 1:
            continue
        s = int(rng.integers(SEED_FRAMES - 1, T - L - 1))
        f = fills[int(rng.integers(len(fills)))]
        out.append(window_at(take.variants[f], s, L, take=take.name, fill=f))
    return out


def fixed_windows(take: Take, length: int, *, stride: int = 10) -> list[Transition]:
    """Every window of ``length`` generated frames, starts ``stride`` apart (for L2@N)."""
    v = take.values
    return [window_at(v, s, length, take=take.name)
            for s in range(SEED_FRAMES - 1, len(v) - length - 1, stride)]


def stack_batch(items: Sequence[Transition]) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                      np.ndarray]:
    """Pad a batch: windows (B, SEED_FRAMES, K), frames (B, Lmax, K) (padded with the target),
    mask (B, Lmax) (1 on real frames), lengths (B,)."""
    if not items:
        raise ParameterError("empty batch")
    K = items[0].window.shape[1]
    L = max(t.length for t in items)
    w = np.stack([t.window for t in items]).astype(np.float32)
    f = np.zeros((len(items), L, K), np.float32)
    m = np.zeros((len(items), L), np.float32)
    for i, t in enumerate(items):
        f[i, :t.length] = t.frames
        f[i, t.length:] = t.frames[-1]
        m[i, :t.length] = 1.0
    return w, f, m, np.array([t.length for t in items], np.int64)
