"""Calibrate the AUs of mimika's own heads to the ICT Face Model's light-stage shapes.

For every face AU, peak and extent over the face front (``mimika.face.calibration``) are
measured on the head and on ICT (a real actor's scans), and the AU's calibration is chosen to
bring them together — the worst |log ratio| over the heads, a little in favour of leaving the
head's own motion as it is — then written into the head's data file. For the characters, of
the calibrations whose ratios all lie well inside the tolerance (``SAFE``), the one whose
landmarks move most like ICT's (:func:`~mimika.face.calibration.shape_error`, mean over the
presets) is taken::

    export MIMIKA_ICT_DIR=../shared/ict-facekit
    .venv/bin/python scripts/calibrate.py characters   # face/data/makehuman_aus.json
    .venv/bin/python scripts/calibrate.py builtin      # face/data/builtin_fields.json
    .venv/bin/python scripts/calibrate.py landmarks    # face/data/ict_landmark_motion.json

* **characters** (the four presets together): each AU is MakeHuman's faceunit recipe, mixed
  with the same AU in the ``ict`` style — ICT's recipe on shapes generated on the character by
  the per-shape fields fitted on ICT — and scaled: ``"calibration": {"ict": w, "gain": g}``,
  Δ = g·((1 − w)·Δ_faceunits + w·Δ_ict) (jaw and lid shapes stay the faceunits', × g).
* **builtin** (seed 002's hand-made fields): every Gaussian of the AU's field scaled,
  ``"calibration": {"gain": g, "spread": s}`` — η × g, σ × s.

Lid closure (AU41–46) is left as it is: a blink closes the eye, which is a contact, not a
distance to match.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable, Iterable, Mapping
from importlib import resources
from pathlib import Path

import numpy as np

PRESETS = ("amara", "daniel", "mei", "tomas")
KEEP = ("AU41", "AU42", "AU43", "AU44", "AU45", "AU46")
#: characters: ratios to ICT within which a calibration is chosen by the shape of its motion
SAFE = (0.75, 1.33)
#: characters: the lips' own AUs keep the faceunits' shapes, calibrated by peak and extent
#: alone: speech presses and rounds the lips with them and the faceunits keep them sealed
#: where ICT's funnel and pucker part them (a /b/ before /u/ opens), the ict-style shapes
#: fatten the red of the lips where FACS narrows it (23, 24), and the teeth are seated for
#: the faceunits' lip parting (25)
LIPS = ("AU18", "AU22", "AU23", "AU24", "AU25", "AU28")
#: builtin: the jaw's fields are not widened (they would reach the neck)
JAW = ("AU26", "AU27", "AU29", "AU30")
#: builtin: AUs around the eyes and nose whose fields may not spread further (wider, they pull
#: the lid skin off the eyeball and the nose field reaches the upper lip)
NARROW = {"AU01": 1.6, "AU02": 1.6, "AU04": 1.6, "AU05": 1.0, "AU06": 1.6, "AU07": 2.0,
          "AU09": 1.4}
GAINS = np.round(np.arange(0.5, 5.01, 0.05), 2)


def _dumps(doc: dict, one_line: Iterable[str]) -> str:
    """``doc`` as mimika's data files keep it: a line per key, a line per entry of the
    ``one_line`` keys' dictionaries."""
    def one(v) -> str:
        return json.dumps(v, ensure_ascii=False)

    lines = []
    for k, v in doc.items():
        if k in one_line:
            inner = ",\n".join(f"  {one(c)}: {one(e)}" for c, e in v.items())
            lines.append(f" {one(k)}: {{\n{inner}\n }}")
        else:
            lines.append(f" {one(k)}: {one(v)}")
    return "{\n" + ",\n".join(lines) + "\n}\n"


def _reference(codes: list[str]) -> dict[str, tuple[float, float]]:
    from mimika.face.calibration import face_front, motion
    from mimika.face.heads import load_head

    head, rig = load_head("ict")
    front, rest = face_front(head), head.rest["skin"]
    return {c: motion(np.asarray(rig.deform({c: 1.0})["skin"]) - rest, front) for c in codes}


def _choose(code: str, candidates: dict, ref: tuple[float, float],
            prior: Callable[[tuple], float], shape: Mapping[tuple, float] | None = None
            ) -> tuple:
    """The candidate key whose (peak, extent) per head ({key: [(p, e) per head]}) is closest
    to ``ref`` in the worst |log ratio|, plus ``prior(key)``; with that worst and the ratios.
    With ``shape`` ({key: landmark shape error}), of the candidates whose ratios all lie
    within :data:`SAFE` the one with the least shape error (plus the prior) wins."""
    from mimika.face.calibration import EXCEPTIONS

    skip = EXCEPTIONS.get(code, ((), ""))[0]
    lo, hi = np.log(SAFE)
    best = None
    for key, per_head in candidates.items():
        rs = [(p / ref[0], e / ref[1]) for p, e in per_head]
        logs = [np.log(x) for a, b in rs for what, x in (("peak", a), ("extent", b))
                if what not in skip]
        worst = max((abs(x) for x in logs), default=0.0)
        score = worst + prior(key)
        if shape is not None:  # feasible candidates first, by the shape of their motion
            ok = all(lo <= x <= hi for x in logs)
            score = (shape[key] + prior(key)) if ok else 10.0 + score
        if best is None or score < best[0]:
            best = (score, key, worst, rs)
    return best[1:]


def _report(code: str, key: tuple, worst: float, rs: list, shape: float | None = None) -> None:
    cells = "  ".join(f"{a:.2f}/{b:.2f}" for a, b in rs)
    err = "" if shape is None else f"  shape error {shape:.2f}"
    print(f"{code:5s} {key[0]:5.2f} {key[1]:5.2f}  {worst:5.3f}  {cells}{err}", flush=True)


def characters() -> Path:
    from mimika.face.calibration import (
        EXTRA_AUS,
        SEED_AUS,
        face_front,
        landmark_motion,
        motion,
        shape_error,
    )
    from mimika.face.heads import character, load_head

    path = Path(str(resources.files("mimika.face").joinpath("data/makehuman_aus.json")))
    table = json.loads(path.read_text("utf-8"))
    codes = [c for c in (*SEED_AUS, *EXTRA_AUS)
             if c not in KEEP and "shapes" in table["aus"].get(c, {})]
    ref = _reference(codes)
    ict_head, ict_rig = load_head("ict")
    ict_rest = ict_head.rest["skin"]
    ref_lm = {c: landmark_motion(np.asarray(ict_rig.deform({c: 1.0})["skin"]) - ict_rest,
                                 ict_head) for c in codes}
    #: per AU and head: (front, faceunits Δ, ict-style Δ, their landmark motions, head)
    disp: dict[str, list] = {c: [] for c in codes}
    for name in PRESETS:
        rigs = [character.character_rig(name, {c: {"ict": w, "gain": 1.0} for c in codes})
                for w in (0.0, 1.0)]
        head = rigs[0].head
        front = face_front(head)
        rest = head.rest["skin"].astype(np.float64)
        for c in codes:
            dm, di = (np.asarray(r.deform({c: 1.0})["skin"], np.float64) - rest for r in rigs)
            disp[c].append((front, dm, di, landmark_motion(dm, head), landmark_motion(di, head)))
    print(f"{'AU':5s} {'ict':>5s} {'gain':>5s}  worst  ratio to ICT (peak/extent): "
          + "  ".join(PRESETS))
    gains = GAINS[(GAINS >= 0.6) & (GAINS <= 1.6)]
    for c in codes:
        keys = [(w, float(g)) for w in ((0.0,) if c in LIPS else (0.0, 0.25, 0.5, 0.75, 1.0))
                for g in gains]
        cand = {(w, g): [motion(g * ((1 - w) * dm + w * di), front)
                         for front, dm, di, _, _ in disp[c]] for w, g in keys}
        shape = {(w, g): float(np.mean([shape_error(g * ((1 - w) * lm + w * li), ref_lm[c])
                                        for _, _, _, lm, li in disp[c]])) for w, g in keys}
        key, worst, rs = _choose(c, cand, ref[c],
                                 lambda k: 0.02 * k[0] + 0.05 * abs(np.log(k[1])),
                                 None if c in LIPS else shape)
        _report(c, key, worst, rs, shape[key])
        table["aus"][c]["calibration"] = {"ict": key[0], "gain": key[1]}
    return _write(path, table, ("aus", "body"))


def builtin() -> Path:
    from mimika.face.calibration import EXTRA_AUS, SEED_AUS, face_front, motion
    from mimika.face.heads.builtin import build_builtin_head
    from mimika.face.rigs.field import FieldRig, parse_fields

    path = Path(str(resources.files("mimika.face").joinpath("data/builtin_fields.json")))
    doc = json.loads(path.read_text("utf-8"))
    codes = [c for c in (*SEED_AUS, *EXTRA_AUS)
             if c not in KEEP and doc["aus"].get(c, {}).get("kind", "linear") == "linear"
             and c in doc["aus"]]
    ref = _reference(codes)
    head = build_builtin_head(1)
    front = face_front(head)
    rest = head.rest["skin"].astype(np.float64)
    print(f"{'AU':5s} {'gain':>5s} {'sprd':>5s}  worst  ratio to ICT (peak/extent)")
    for c in codes:
        cand = {}
        for s in (x for x in (0.8, 1.0, 1.2, 1.4, 1.6, 1.8, 2.0, 2.3, 2.6)
                  if x <= (1.0 if c in JAW else NARROW.get(c, 9.0))):
            trial = {**doc, "aus": {c: {**doc["aus"][c], "calibration": {"spread": s}}}}
            rig = FieldRig(head, parse_fields(trial, source="calibration"))
            d = np.asarray(rig.deform({c: 1.0})["skin"], np.float64) - rest
            p, e = motion(d, front)
            for g in GAINS:  # displacements are linear in the gain
                cand[float(g), s] = [(g * p, g * e)]
        key, worst, rs = _choose(c, cand, ref[c],
                                 lambda k: 0.02 * abs(np.log(k[0])) + 0.05 * abs(np.log(k[1])))
        _report(c, key, worst, rs)
        doc["aus"][c]["calibration"] = {"gain": key[0], "spread": key[1]}
    return _write(path, doc, ("splits", "aus"))


def _write(path: Path, doc: dict, one_line: tuple[str, ...]) -> Path:
    from mimika.io.atomic import atomic_write

    atomic_write(path, _dumps(doc, one_line))
    print(f"wrote {path}")
    return path


def landmarks() -> Path:
    """ICT's landmark motion per face AU (68 × 3, inter-ocular distances) for the AUs the
    characters match (``face/landmark_match.py``)."""
    from mimika.face.calibration import EXTRA_AUS, SEED_AUS, landmark_motion
    from mimika.face.heads import load_head

    head, rig = load_head("ict")
    o = head.landmark_object
    rest = rig.deform({})[o]
    aus = {c: np.round(landmark_motion(rig.deform({c: 1.0})[o] - rest, head), 5).tolist()
           for c in (*SEED_AUS, *EXTRA_AUS)}
    doc = {"_doc": "The ICT Face Model's (MIT; light-stage scans of an actor) 68-point "
                   "landmark displacements per AU at intensity 1, in inter-ocular distances "
                   "(x toward the subject's left, y up, z forward), from the landmarks' "
                   "vertices of its generic neutral: what face/landmark_match.py matches. "
                   "Written by scripts/calibrate.py landmarks.",
           "aus": aus}
    path = Path(str(resources.files("mimika.face").joinpath("data/ict_landmark_motion.json")))
    return _write(path, doc, ("aus",))


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("what", choices=("characters", "builtin", "landmarks"))
    a = p.parse_args(argv)
    {"characters": characters, "builtin": builtin, "landmarks": landmarks}[a.what]()
    return 0


if __name__ == "__main__":
    sys.exit(main())
