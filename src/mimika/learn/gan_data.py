"""Per-frame AU data for the WGAN controller (seed 001): takes → neutral-relative frames → labels.

Pipeline (the seed's IEMOCAP preprocessing, transposed to AU intensities):

1. every take (Live Link Face CSV) is read with drop-outs filled (linear) and folded onto the 20
   bilateral face AUs of :data:`mimika.learn.data.MODEL_CHANNELS` (gaze, blinks, tongue and
   head AUs are not part of an expression);
2. the take's *neutral frame* is subtracted — the per-channel median of the take, standing in
   for the seed's per-recording neutral pose (it removes resting offsets such as a constant
   ``EyeWide`` or squint) — and the result is clipped to [0, 1]: an AU frame relative to the
   performer's rest, which the rig adds to its own neutral face (AU = 0);
3. frames are split **by take**: ``apfel`` is the held-out test take, the rest train.

Emotion labels (the takes have none) come from documented nearest-prototype matching against
EMFACS prototypes kept with the models (``data/label_prototypes.json``: ``happiness`` 6+12+25,
``sadness`` 1+4+15+17+41, ``surprise`` 1+2+5+26, ``fear`` 1+2+4+5+7+20+26, ``anger``
4+5+7+10+22+23+25, ``disgust`` 9+15+16+25 — the expression library as it was when the shipped
models were trained, so tuning the library for rendering does not relabel the data):
over the prototype AUs only (AU26/AU25 → AU27 jaw open and AU23 → AU24 lip press, the closest
ARKit-derived channels), frame ``x`` gets the label ``e`` minimising
``min_s ‖x − s·p_e‖`` with the intensity scale ``s ∈ [0.25, 1]``, or ``neutral`` when ``‖x‖``
is smaller than every such distance. Labels are therefore derived, not annotated.
"""

from __future__ import annotations

import functools
import json
import logging
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np

from mimika.errors import DataError, ParameterError

log = logging.getLogger(__name__)

__all__ = ["ENV_DIR", "LABELS", "TEST_TAKES", "FrameSet", "expression_vector", "find_motion_dir",
           "load_frames",
           "nearest_neighbour", "neutral_relative", "nn_labels", "prototype_labels",
           "prototypes", "read_take_frames"]

#: environment variable naming the folder of Live Link Face takes
ENV_DIR = "MIMIKA_MOTION_DIR"
#: held-out test take(s) (by file stem)
TEST_TAKES: tuple[str, ...] = ("apfel",)
#: emotion labels: neutral + Ekman's six basic emotions (``data/label_prototypes.json``)
LABELS: tuple[str, ...] = ("neutral", "happiness", "sadness", "surprise", "fear", "anger",
                           "disgust")
#: prototype AUs the ARKit-derived channels lack → the closest channel present
PROTOTYPE_MAP = {"AU25": "AU27", "AU26": "AU27", "AU23": "AU24"}
#: smallest intensity scale of a prototype a labelled frame must reach
MIN_SCALE = 0.25


def find_motion_dir(path: str | os.PathLike | None = None) -> Path:
    """The folder of takes: ``path``, else ``$MIMIKA_MOTION_DIR``; raises :class:`DataError`."""
    if path is None:
        env = os.environ.get(ENV_DIR)
        if not env:
            raise DataError(f"no training data: give --data DIR or set ${ENV_DIR} to a folder of "
                            "Live Link Face CSV takes (e.g. shared/motion/livelinkface)")
        path = env
    d = Path(path).expanduser()
    if not d.is_dir():
        raise DataError(f"{d} is not a folder of takes (expected Live Link Face CSV files)")
    return d


@dataclass(frozen=True)
class FrameSet:
    """Frames of several takes.

    values : ndarray, shape (N, K), float32, neutral-relative AU intensities in [0, 1]
    channels : K AU codes; take : (N,) int index into ``takes``; labels : (N,) int into
    :data:`LABELS`.
    """

    values: np.ndarray
    channels: tuple[str, ...]
    take: np.ndarray
    takes: tuple[str, ...]
    labels: np.ndarray
    fps: float = 30.0
    meta: dict = field(default_factory=dict, compare=False)

    def __len__(self) -> int:
        return len(self.values)

    def subset(self, index: np.ndarray) -> FrameSet:
        """The frames at ``index`` (bool mask or integer indices)."""
        return FrameSet(self.values[index], self.channels, self.take[index], self.takes,
                        self.labels[index], self.fps, dict(self.meta))

    def of_takes(self, names: Sequence[str]) -> FrameSet:
        ids = [self.takes.index(n) for n in names if n in self.takes]
        return self.subset(np.isin(self.take, ids))

    def split(self, test: Sequence[str] = TEST_TAKES) -> tuple[FrameSet, FrameSet]:
        """``(train, test)`` by take: ``test`` names the held-out takes."""
        missing = [t for t in test if t not in self.takes]
        if missing:
            raise ParameterError(f"test take(s) {', '.join(missing)} not among "
                                 f"{', '.join(self.takes)}")
        is_test = np.isin(self.take, [self.takes.index(t) for t in test])
        if is_test.all():
            raise ParameterError("every take is a test take; nothing left to train on")
        return self.subset(~is_test), self.subset(is_test)

    def with_label(self, label: str) -> FrameSet:
        return self.subset(self.labels == LABELS.index(label))

    def balanced(self, labels: Sequence[str], rng: np.random.Generator) -> FrameSet:
        """Equal frames per label (random sampling down to the smallest class, as the seed)."""
        ids = [np.flatnonzero(self.labels == LABELS.index(lab)) for lab in labels]
        n = min(len(i) for i in ids)
        if n == 0:
            raise DataError(f"no frames labelled {labels[[len(i) for i in ids].index(0)]}")
        pick = np.concatenate([rng.choice(i, n, replace=False) for i in ids])
        return self.subset(np.sort(pick))

    def label_counts(self) -> dict[str, int]:
        c = np.bincount(self.labels, minlength=len(LABELS))
        return {lab: int(n) for lab, n in zip(LABELS, c, strict=True)}


def neutral_relative(values: np.ndarray) -> np.ndarray:
    """Subtract a take's neutral frame (per-channel median) and clip: (T, K) → (T, K) in [0, 1]."""
    v = np.asarray(values, np.float32)
    return np.clip(v - np.median(v, axis=0, keepdims=True), 0.0, 1.0).astype(np.float32)


def read_take_frames(path: str | os.PathLike) -> tuple[np.ndarray, float]:
    """One take → neutral-relative frames (T, 20) over ``MODEL_CHANNELS`` and its fps."""
    from mimika.io.tracks import read_track
    from mimika.learn.data import MODEL_CHANNELS, fold_channels

    track = read_track(path)
    return neutral_relative(fold_channels(track.values, track.channels, MODEL_CHANNELS)), \
        float(track.fps)


def load_frames(folder: str | os.PathLike | None = None, *,
                takes: Sequence[str] | None = None) -> FrameSet:
    """Every ``*.csv`` take in ``folder`` (default ``$MIMIKA_MOTION_DIR``), preprocessed and
    labelled (see the module docstring). ``takes`` restricts to these file stems."""
    from mimika.learn.data import MODEL_CHANNELS, list_takes

    paths = list_takes(find_motion_dir(folder))
    if takes is not None:
        paths = [p for p in paths if p.stem in takes]
        if not paths:
            raise DataError(f"none of the takes {', '.join(takes)} found")
    vals, ids, rates = [], [], set()
    for i, p in enumerate(paths):
        v, fps = read_take_frames(p)
        vals.append(v)
        ids.append(np.full(len(v), i))
        rates.add(fps)
    if len(rates) > 1:
        raise DataError(f"takes have different frame rates {sorted(rates)}")
    values = np.concatenate(vals)
    labels = prototype_labels(values, MODEL_CHANNELS)
    fs = FrameSet(values, MODEL_CHANNELS, np.concatenate(ids), tuple(p.stem for p in paths),
                  labels, rates.pop(), {"folder": str(paths[0].parent)})
    log.info("loaded %d frames from %d takes; labels %s", len(fs), len(paths), fs.label_counts())
    return fs


def expression_vector(aus: Mapping[str, float], channels: Sequence[str]) -> np.ndarray:
    """An expression's AUs ``{code: value}`` over ``channels`` (K,) float64: sided codes count for
    their bilateral AU, codes the channels lack go to :data:`PROTOTYPE_MAP`'s closest one."""
    from mimika.facs.catalogue import base_code

    idx = {c: j for j, c in enumerate(channels)}
    row = np.zeros(len(channels))
    for code, v in aus.items():
        c = PROTOTYPE_MAP.get(base_code(code), base_code(code))
        if c in idx:
            row[idx[c]] = max(row[idx[c]], float(v))
    return row


def prototypes(channels: Sequence[str]) -> np.ndarray:
    """Labelling prototypes of :data:`LABELS` over ``channels``: (len(LABELS), K); row 0 is 0."""
    protos = _label_prototypes()
    return np.array([np.zeros(len(channels))] + [
        expression_vector(protos[lab], channels) for lab in LABELS[1:]], np.float32)


@functools.cache
def _label_prototypes() -> dict[str, dict[str, float]]:
    """``data/label_prototypes.json``'s prototypes (read once)."""
    text = resources.files("mimika.learn").joinpath("data/label_prototypes.json").read_text()
    return json.loads(text)["prototypes"]


def prototype_labels(values: np.ndarray, channels: Sequence[str], *,
                     min_scale: float = MIN_SCALE) -> np.ndarray:
    """Nearest-prototype emotion labels of neutral-relative frames.

    Parameters
    ----------
    values : ndarray, shape (N, K), in [0, 1]
    channels : the K AU codes

    Returns
    -------
    ndarray, shape (N,), int indices into :data:`LABELS`
    """
    P = prototypes(channels)
    on = P.any(axis=0)
    x = np.asarray(values, np.float32)[:, on]
    p = P[1:, on]
    s = np.clip(x @ p.T / (p * p).sum(1), min_scale, 1.0)  # (N, E) best intensity per prototype
    d = np.linalg.norm(x[:, None, :] - s[:, :, None] * p[None], axis=2)
    d = np.concatenate([np.linalg.norm(x, axis=1)[:, None], d], axis=1)
    return d.argmin(axis=1)


def nearest_neighbour(samples: np.ndarray, reference: np.ndarray, *,
                      chunk: int = 2048) -> np.ndarray:
    """Index of each sample's nearest reference frame (Euclidean over AU channels): (N,)."""
    s = np.asarray(samples, np.float32)
    r = np.asarray(reference, np.float32)
    rn = (r * r).sum(1)
    out = np.empty(len(s), np.int64)
    for i in range(0, len(s), chunk):
        b = s[i:i + chunk]
        d = rn[None, :] - 2.0 * b @ r.T
        out[i:i + chunk] = d.argmin(axis=1)
    return out


def nn_labels(samples: np.ndarray, reference: FrameSet) -> np.ndarray:
    """Labels of each sample's nearest neighbour in ``reference`` (the seed's NN-label test)."""
    return reference.labels[nearest_neighbour(samples, reference.values)]
