"""Behaviour generators: blinks, gaze, head motion, brow raises, smiles, idle motion, whole-body
idle (``body.*`` channels) and the knowledge base's text defaults, each a toggleable layer → an
:class:`~mimika.tracks.AUTrack`.

Every layer is a function ``layer(cues, *, fps, rng, params) -> AUTrack`` over the duration of
a :class:`SpeechCues`; parameters live in ``behaviour/data/behaviour.json``. Each layer draws
from its own seeded random stream, so switching one layer off leaves the others unchanged.
:func:`merge_layers` sums the head/eye rotations of all layers (as signed angles), keeps the
eyes on the camera while the head moves, and takes the maximum for every other AU.
"""

from __future__ import annotations

import copy
import functools
import json
import logging
import zlib
from collections.abc import Callable, Iterable, Mapping
from importlib import resources
from typing import Any

import numpy as np

from mimika.behaviour.blink import blink_layer
from mimika.behaviour.body import body_layer
from mimika.behaviour.brows import brow_layer
from mimika.behaviour.cues import SpeechCues, cues_from_utterance
from mimika.behaviour.gaze import gaze_layer
from mimika.behaviour.head import head_layer
from mimika.behaviour.idle import idle_layer
from mimika.behaviour.knowledge import knowledge_layer
from mimika.behaviour.smile import sentence_kind, smile_layer
from mimika.errors import ParameterError
from mimika.tracks import AUTrack, valid_fps

log = logging.getLogger(__name__)

Layer = Callable[..., AUTrack]

#: the layers in merge order, by name
LAYERS: dict[str, Layer] = {
    "head": head_layer,
    "idle": idle_layer,
    "body": body_layer,
    "gaze": gaze_layer,
    "blink": blink_layer,
    "brows": brow_layer,
    "smile": smile_layer,
    "knowledge": knowledge_layer,
}

#: antagonist AU pairs merged as signed sums (positive, negative)
PAIRS = (("AU51", "AU52"), ("AU54", "AU53"), ("AU55", "AU56"),
         ("AU61", "AU62"), ("AU64", "AU63"))

__all__ = ["LAYERS", "PAIRS", "SpeechCues", "behaviour_layers", "behaviour_params",
           "cues_from_utterance", "merge_layers", "sentence_kind"]


@functools.cache
def _default_params() -> dict[str, Any]:
    text = resources.files("mimika.behaviour").joinpath("data/behaviour.json").read_text("utf-8")
    return json.loads(text)


def behaviour_params(overrides: Mapping[str, Mapping[str, Any]] | None = None) -> dict[str, Any]:
    """The parameters of ``data/behaviour.json`` (a deep copy) with ``overrides`` applied per
    section, e.g. ``{"blink": {"rest_interval_s": 6}}``; unknown keys raise ParameterError."""
    p = copy.deepcopy(_default_params())
    for sec, vals in (overrides or {}).items():
        if sec not in p or not isinstance(p[sec], dict):
            raise ParameterError(f"unknown behaviour section {sec!r}; sections: "
                                 f"{', '.join(k for k in p if not k.startswith('_'))}")
        for k, v in vals.items():
            if k not in p[sec]:
                raise ParameterError(f"unknown behaviour parameter {sec}.{k}; known: "
                                     f"{', '.join(x for x in p[sec] if not x.startswith('_'))}")
            p[sec][k] = v
    return p


def _rng(seed: int, name: str) -> np.random.Generator:
    return np.random.default_rng([int(seed) & 0xFFFFFFFF, zlib.crc32(name.encode())])


def behaviour_layers(cues: SpeechCues, *, fps: float, layers: Iterable[str] | None = None,
                     seed: int | None = None, params: dict[str, Any] | None = None
                     ) -> dict[str, AUTrack]:
    """Generate the behaviour layers named in ``layers`` (default: all of :data:`LAYERS`).

    Returns ``{name: AUTrack}`` with ``cues.n_frames(fps=fps)`` frames each. ``seed`` defaults
    to the params' seed; each layer has its own stream (named by the layer).
    """
    fps = valid_fps(fps)
    p = params if params is not None else behaviour_params()
    names = list(LAYERS) if layers is None else list(layers)
    for n in names:
        if n not in LAYERS:
            raise ParameterError(f"unknown behaviour layer {n!r}; layers: {', '.join(LAYERS)}")
    s = p["seed"] if seed is None else seed
    out = {}
    for n in LAYERS:
        if n in names:
            out[n] = LAYERS[n](cues, fps=fps, rng=_rng(s, n), params=p)
            log.debug("layer %s: %s", n, ", ".join(out[n].channels))
    return out


def merge_layers(tracks: Mapping[str, AUTrack], *, params: dict[str, Any] | None = None,
                 n_frames: int | None = None, fps: float | None = None) -> AUTrack:
    """One AU track from the layers: antagonist pairs (:data:`PAIRS`) as signed sums, other AUs
    as maximum; with a ``gaze`` layer (and ``gaze.vor``) the eyes counter-rotate against the
    merged head rotation, so they stay on the camera.

    Returns shape (n_frames, K); an empty mapping needs ``n_frames`` and ``fps``.
    """
    from mimika.behaviour.head import head_aus_to_angles

    p = params if params is not None else behaviour_params()
    trs = list(tracks.values())
    if trs:
        fps = trs[0].fps
        n_frames = trs[0].n_frames
    if fps is None or n_frames is None:
        raise ParameterError("merge_layers needs n_frames and fps when no layer is given")
    acc: dict[str, np.ndarray] = {}
    for tr in trs:
        if tr.n_frames != n_frames or tr.fps != fps:
            raise ParameterError("behaviour layers must share frame count and fps")
        for j, c in enumerate(tr.channels):
            col = tr.values[:, j].astype(np.float64)
            acc[c] = np.maximum(acc[c], col) if c in acc else col
    # signed sums for rotations (max above would drop the smaller of two layers)
    for pos, neg in PAIRS:
        s = np.zeros(n_frames)
        for tr in trs:
            if pos in tr.channels:
                s += tr[pos]
            if neg in tr.channels:
                s -= tr[neg]
        if pos in acc or neg in acc:
            acc[pos], acc[neg] = np.clip(s, 0, 1), np.clip(-s, 0, 1)
    if "gaze" in tracks and p["gaze"].get("vor", True):
        sc = p["scales"]
        head = np.stack([acc.get(c, np.zeros(n_frames))
                         for c in ("AU51", "AU52", "AU53", "AU54", "AU55", "AU56")], 1)
        ang = head_aus_to_angles(head, sc)
        yaw = (acc["AU61"] - acc["AU62"]) * sc["eye_yaw_deg"] - ang[:, 0]
        pitch = (acc["AU64"] - acc["AU63"]) * sc["eye_pitch_deg"] - ang[:, 1]
        acc["AU61"], acc["AU62"] = (np.clip(yaw / sc["eye_yaw_deg"], 0, 1),
                                    np.clip(-yaw / sc["eye_yaw_deg"], 0, 1))
        acc["AU64"], acc["AU63"] = (np.clip(pitch / sc["eye_pitch_deg"], 0, 1),
                                    np.clip(-pitch / sc["eye_pitch_deg"], 0, 1))
    from mimika.timeline.player import order_channels

    chans = order_channels(acc)
    v = np.stack([acc[c] for c in chans], 1) if chans else np.zeros((n_frames, 0))
    return AUTrack(np.clip(v, 0, 1).astype(np.float32), tuple(chans), fps,
                   {"source": "behaviour", "layers": list(tracks)})
