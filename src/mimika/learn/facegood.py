"""FACEGOOD takes (a second person) as transition data, on the channels that map.

``shared/motion/facegood`` holds FACEGOOD-Audio2Face's training animation: ``bs_value/*.npy``
float [T, 116] weights of FACEGOOD's own rig at 30 fps (names in ``doc/bsname.txt``) and the
upstream mapping to ARKit-52 (``doc/facegood116_to_arkit52.csv``: ``arkit, facegood_expr,
status``; an expression is one rig channel or ``max(a, b, …)``). Only rows marked ``valid`` are
used (27 mouth and jaw shapes; see :func:`column_names` for which column is which channel);
the ARKit frames then take the same path as a Live Link take
(:func:`mimika.io.arkit.arkit_to_aus`, folded onto :data:`~mimika.learn.data.MODEL_CHANNELS`).
:func:`covered_channels` names the model channels fed only by valid shapes (13 of 20: no
brows, lids or cheeks) — evaluations on this person use those channels only.
"""

from __future__ import annotations

import csv
import os
import re
import warnings
from functools import lru_cache
from pathlib import Path

import numpy as np

from mimika.errors import DataError
from mimika.learn.data import MODEL_CHANNELS, Take, fold_channels

__all__ = ["column_names", "covered_channels", "load_facegood", "read_mapping"]

FPS = 30.0


def _arkit_name(name: str) -> str:
    """``browDownleft`` → ``BrowDownLeft`` (the csv's spelling → :data:`ARKIT_52`'s)."""
    from mimika.io.arkit import ARKIT_52

    low = {n.lower(): n for n in ARKIT_52}
    if name.lower() not in low:
        raise DataError(f"FACEGOOD mapping names an unknown ARKit shape {name!r}")
    return low[name.lower()]


def read_mapping(folder: str | os.PathLike) -> tuple[list[str], dict[str, list[str]],
                                                     set[str]]:
    """(rig channel names (116), valid ARKit shape → rig channels (max of), invalid shapes)."""
    doc = Path(folder) / "doc"
    try:
        lines = (doc / "bsname.txt").read_text().split()
        rows = list(csv.DictReader((doc / "facegood116_to_arkit52.csv").open()))
    except OSError as e:
        raise DataError(f"{folder} is not a FACEGOOD folder (doc/bsname.txt and "
                        f"doc/facegood116_to_arkit52.csv): {e}") from None
    names = lines[1:] if lines and lines[0].isdigit() else lines
    valid, invalid = {}, set()
    for r in rows:
        shape = _arkit_name(r["arkit"])
        status = r["status"] or r["facegood_expr"]  # "tongueOut,Invalid" has two fields
        if status.strip().lower() != "valid":
            invalid.add(shape)
            continue
        valid[shape] = re.findall(r"[A-Za-z0-9_]+", r["facegood_expr"].replace("max(", "("))
        for n in valid[shape]:
            if n not in names:
                raise DataError(f"FACEGOOD mapping: {n!r} is not a rig channel")
    return names, valid, invalid


@lru_cache(maxsize=4)
def covered_channels(folder: str) -> tuple[str, ...]:
    """Model channels that only valid FACEGOOD shapes feed (probe each ARKit shape)."""
    from mimika.io.arkit import ARKIT_52, arkit_to_aus

    _, valid, _ = read_mapping(folder)
    probe = np.eye(len(ARKIT_52), dtype=np.float32)
    vals, chans = arkit_to_aus(probe)
    folded = fold_channels(vals, chans)  # (52 shapes, 20 channels)
    ok = [ARKIT_52.index(s) for s in valid]
    bad = [j for j in range(len(ARKIT_52)) if ARKIT_52[j] not in valid]
    return tuple(c for k, c in enumerate(MODEL_CHANNELS)
                 if folded[ok, k].max() > 0 and folded[bad, k].max() == 0)


def _pair(a: str, b: str) -> bool:
    """``x_l``/``x_r`` (or ``_dl``/``_dr``, ``_ul``/``_ur``): one shape's two halves."""
    return a[:-1] == b[:-1] and a[-2:-1] in ("_", "d", "u") and (a[-1], b[-1]) == ("l", "r")


def column_names(names: list[str], weights: np.ndarray) -> list[str]:
    """The rig channel of each weight column. In the FACEGOOD export the columns are
    ``doc/bsname.txt`` shifted by one (column i holds name i − 1): the animation is symmetric,
    so a shape's left and right columns are identical, and only with that shift do the 11
    identical neighbouring columns line up as ``_l``/``_r`` pairs. The shift (0 or 1) is
    chosen by that test; a tie raises :class:`DataError`."""
    w = np.asarray(weights)
    same = [i for i in range(w.shape[1] - 1)
            if w[:, i].max() > 1e-3 and np.allclose(w[:, i], w[:, i + 1], atol=1e-6)]
    score = {}
    for shift in (0, 1):
        cand = names[-shift:] + names[:-shift] if shift else list(names)
        score[shift] = sum(_pair(cand[i], cand[i + 1]) for i in same)
    best = max(score, key=score.__getitem__)
    if score[best] == score[1 - best]:
        raise DataError(f"cannot tell which rig channel each FACEGOOD column is ({score})")
    return names[-best:] + names[:-best] if best else list(names)


def load_facegood(folder: str | os.PathLike) -> list[Take]:
    """Every ``bs_value/*.npy`` take as a :class:`~mimika.learn.data.Take` over
    :data:`MODEL_CHANNELS` (channels outside :func:`covered_channels` are 0), sorted by name."""
    from mimika.io.arkit import ARKIT_52, arkit_to_aus

    folder = Path(folder)
    names, valid, _ = read_mapping(folder)
    files = sorted((folder / "bs_value").glob("*.npy"))
    if not files:
        raise DataError(f"{folder}/bs_value: no *.npy takes")
    keep = np.isin(MODEL_CHANNELS, covered_channels(str(folder)))
    weights = []
    for f in files:
        with warnings.catch_warnings():  # the files carry a Python-2 header; numpy warns
            warnings.simplefilter("ignore", UserWarning)
            w = np.asarray(np.load(f), np.float64)
        if w.ndim != 2 or w.shape[1] != len(names):
            raise DataError(f"{f}: expected [T, {len(names)}] rig weights, got {w.shape}")
        weights.append(w)
    col = {n: i for i, n in enumerate(column_names(names, np.concatenate(weights)))}
    takes = []
    for f, w in zip(files, weights, strict=True):
        shapes = np.zeros((len(w), len(ARKIT_52)))
        for s, src in valid.items():
            shapes[:, ARKIT_52.index(s)] = w[:, [col[n] for n in src]].max(1)
        vals, chans = arkit_to_aus(shapes)
        v = fold_channels(vals, chans) * keep
        takes.append(Take(f.stem.removeprefix("bs_value_"), FPS, {"linear": v},
                          np.ones(len(v), bool), MODEL_CHANNELS,
                          {"source": str(f), "format": "facegood"}))
    return takes
