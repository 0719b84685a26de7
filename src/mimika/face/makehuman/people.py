"""Random people: character documents whose sex, age, build, origin mix, face (MakeHuman's
face modifiers), hair, eyes, brows and clothes vary, for stimulus sets with many identities.
How they vary is data (``data/people.json``); the same seed gives the same people."""

from __future__ import annotations

import functools
import json
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from mimika.errors import DataError
from mimika.face.makehuman.targets import RACES


@functools.cache
def _table() -> dict:
    text = resources.files("mimika.face.makehuman").joinpath("data", "people.json")
    return json.loads(text.read_text("utf-8"))


def _pick(rng: np.random.Generator, weights: dict[str, float]) -> str:
    names = list(weights)
    p = np.array([weights[n] for n in names], float)
    return names[rng.choice(len(names), p=p / p.sum())]


def random_person(rng: np.random.Generator, name: str) -> dict[str, Any]:
    """One character document (see :mod:`.character_file`) drawn from ``rng``."""
    from mimika.face.makehuman.character_file import assets

    t = _table()
    brows, lashes = assets("eyebrows"), assets("eyelashes")
    male = bool(rng.random() < 0.5)
    sex = "male" if male else "female"
    age = float(rng.uniform(*t["age"]))
    pheno: dict[str, Any] = {"gender": 1.0 if male else 0.0, "age": round(age)}
    for k, (mean, sd) in t["build"].items():
        pheno[k] = round(float(np.clip(rng.normal(mean, sd), 0.0, 1.0)), 2)
    main = RACES[rng.integers(len(RACES))]
    origin = {main: 1.0}
    if rng.random() < t["origin"]["mix_p"]:
        other = [r for r in RACES if r != main][rng.integers(len(RACES) - 1)]
        share = round(float(rng.uniform(0.1, t["origin"]["mix_max"])), 2)
        origin = {main: round(1.0 - share, 2), other: share}
    pheno["origin"] = origin
    clip = t["clip"]
    mods = {n: round(float(np.clip(rng.normal(0.0, sd), -clip, clip)), 2)
            for n, sd in t["modifiers"].items()}
    shape = t["head_shapes"][rng.integers(len(t["head_shapes"]))]
    mods[shape] = round(float(rng.uniform(0.0, t["head_shape_max"])), 2)
    hair = t["hair"]
    grey_p = np.clip((age - hair["grey_from"]) / (85.0 - hair["grey_from"]), 0.0, 1.0)
    colour = hair["grey"] if rng.random() < grey_p else _pick(rng, hair["colors"][main])
    # coily hair grows on people of African origin (the other styles on anyone)
    styles = [s for s in hair["styles"][sex] if s not in hair["coily"] or "african" in origin]
    return {
        "name": name,
        "description": f"random {'man' if male else 'woman'}, {round(age)}",
        "phenotype": pheno,
        "modifiers": {k: v for k, v in mods.items() if v},
        "eyes": _pick(rng, t["eyes"][main]),
        "hair": {"style": styles[rng.integers(len(styles))], "color": colour},
        "eyebrows": brows[rng.integers(len(brows))],
        "eyelashes": lashes[rng.integers(len(lashes))],
        "clothes": [t["clothes"][sex][rng.integers(len(t["clothes"][sex]))]],
    }


def random_people(n: int, seed: int = 0, prefix: str = "person") -> list[dict[str, Any]]:
    """``n`` character documents named ``{prefix}01`` …, the same for the same ``seed``."""
    if not 1 <= n <= 1000:
        raise DataError(f"--random {n}: ask for 1 to 1000 people")
    rng = np.random.default_rng(seed)
    width = max(2, len(str(n)))
    return [random_person(rng, f"{prefix}{k + 1:0{width}d}") for k in range(n)]


def write_people(docs: list[dict[str, Any]], folder: str | Path) -> list[Path]:
    """Write each document as ``folder/NAME.yaml`` (atomically); refuses to replace a file."""
    import yaml

    from mimika.io.atomic import atomic_write

    out = Path(folder)
    paths = [out / f"{d['name']}.yaml" for d in docs]
    taken = [p for p in paths if p.exists()]
    if taken:
        raise DataError(f"{taken[0]} exists; choose another folder (--out) or remove "
                        f"{'it' if len(taken) == 1 else f'the {len(taken)} files'} first")
    out.mkdir(parents=True, exist_ok=True)
    for d, p in zip(docs, paths, strict=True):
        atomic_write(p, "# a random person: mimika characters --random\n"
                     + yaml.safe_dump(d, sort_keys=False, allow_unicode=True))
    return paths
