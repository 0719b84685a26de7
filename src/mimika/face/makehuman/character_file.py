"""Character files: who the character is (phenotype) and what they wear, in YAML or JSON.

```yaml
name: amara
description: news anchor, woman in her thirties
phenotype:
  gender: 0.0          # 0 female … 1 male
  age: 34              # years, 1–90
  muscle: 0.5          # 0–1 (0.5 average)
  weight: 0.45
  height: 0.55
  proportions: 0.6
  origin: {african: 0.9, caucasian: 0.1}   # mix, any scale (normalised)
modifiers:             # MakeHuman's face sliders, -1 … 1 (mimika characters --modifiers)
  eyebrows-trans-down-up: 0.2
skin: "#6e4633"        # albedo, sRGB (default: from origin)
eyes: "#3b2314"
hair: {style: bob02, color: "#17110d"}     # or hair: none
eyebrows: eyebrow010
eyelashes: eyelashes02
clothes: [female_elegantsuit01]
```

Presets ship in ``face/data/characters``; a file may ``extends: PRESET`` and change a few keys.
Every problem is one :class:`~mimika.errors.DataError` naming the file and the key.
"""

from __future__ import annotations

import functools
import hashlib
import itertools
import json
import re
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

from mimika.errors import DataError
from mimika.face.makehuman.build import ASSETS
from mimika.face.makehuman.targets import RACES, modifiers

#: age in years ↔ MakeHuman's age value (1 y → 0, 11 y → 0.1875, 25 y → 0.5, 90 y → 1)
_AGE_YEARS = ((1.0, 0.0), (11.0, 0.1875), (25.0, 0.5), (90.0, 1.0))
_KEYS = {"name", "description", "extends", "phenotype", "modifiers", "skin", "eyes", "hair",
         "eyebrows", "eyelashes", "clothes"}
_PHENO = {"gender", "age", "muscle", "weight", "height", "proportions", "origin"}
_HEX = re.compile(r"^#[0-9a-fA-F]{6}$")
#: default skin albedo (sRGB) per origin, blended by the origin mix
SKIN_BY_ORIGIN = {"african": "#6b4431", "asian": "#d6aa88", "caucasian": "#dfae94"}


def age_value(years: float) -> float:
    """MakeHuman's age parameter for an age in years (piecewise linear)."""
    for (y0, a0), (y1, a1) in itertools.pairwise(_AGE_YEARS):
        if years <= y1:
            return a0 + (a1 - a0) * (max(years, y0) - y0) / (y1 - y0)
    return 1.0


def _mix_hex(weights: dict[str, float], table: dict[str, str]) -> str:
    tot = sum(weights.values()) or 1.0
    rgb = [sum(w / tot * int(table[k][1 + 2 * c: 3 + 2 * c], 16) for k, w in weights.items())
           for c in range(3)]
    return "#" + "".join(f"{round(v):02x}" for v in rgb)


def assets(kind: str) -> list[str]:
    """Names of the shipped assets of ``kind`` (hair, eyebrows, eyelashes, clothes)."""
    d = ASSETS / kind
    return sorted(p.name for p in d.iterdir() if (p / f"{p.name}.mhclo").is_file())


@dataclass(frozen=True)
class Character:
    """A validated character description."""

    name: str
    description: str = ""
    phenotype: dict[str, Any] = field(default_factory=dict)
    #: face modifier values by name (:func:`mimika.face.makehuman.targets.modifiers`)
    modifiers: dict[str, float] = field(default_factory=dict)
    skin: str = "#dfae94"
    eyes: str = "#5b3a24"
    hair: str | None = "short02"
    hair_color: str = "#2a1d15"
    eyebrows: str | None = "eyebrow001"
    eyelashes: str | None = "eyelashes01"
    clothes: tuple[str, ...] = ("male_elegantsuit01",)
    source: str = ""

    def phenotype_values(self) -> dict[str, float]:
        """Values for :func:`mimika.face.makehuman.targets.macro_weights`."""
        p = dict(self.phenotype)
        out = {k: float(p[k]) for k in ("gender", "muscle", "weight", "height", "proportions")
               if k in p}
        if "age" in p:
            out["age"] = age_value(float(p["age"]))
        origin = p.get("origin") or {}
        if origin:
            for r in RACES:
                out[r] = float(origin.get(r, 0.0))
        return out

    def outfit_dict(self) -> dict[str, Any]:
        return {"hair": self.hair, "eyebrows": self.eyebrows, "eyelashes": self.eyelashes,
                "clothes": list(self.clothes)}

    def geometry_key(self) -> str:
        """A hash of everything that shapes the geometry (phenotype, modifiers and outfit)."""
        d: dict[str, Any] = {"p": sorted(self.phenotype_values().items()),
                             "o": self.outfit_dict()}
        if self.modifiers:
            d["m"] = sorted(self.modifiers.items())
        return hashlib.sha1(json.dumps(d, sort_keys=True).encode()).hexdigest()[:16]

    def key(self) -> str:
        """A hash of everything that shapes the character: geometry and paint (whose noise —
        pores, strands, iris fibres, fabric — is seeded by the name)."""
        d = [self.geometry_key(), self.name, self.skin, self.eyes, self.hair_color]
        return hashlib.sha1(json.dumps(d).encode()).hexdigest()[:16]


def preset_names() -> list[str]:
    """Names of the shipped presets."""
    d = resources.files("mimika.face").joinpath("data", "characters")
    return sorted(p.name.removesuffix(".yaml") for p in d.iterdir() if p.name.endswith(".yaml"))


def _preset_text(name: str) -> str:
    return resources.files("mimika.face").joinpath("data", "characters",
                                                   f"{name}.yaml").read_text("utf-8")


def _parse(text: str, where: str) -> dict:
    """The file's mapping, read safely (:mod:`mimika.io.yamlsafe`: budgets on size, nesting,
    aliases and integers; text keys only; every problem one line with its place)."""
    from mimika.io.yamlsafe import read_yaml

    doc, _ = read_yaml(text, where, text_keys=True)
    if not isinstance(doc, dict):
        raise DataError(f"{where}: a character file is a mapping of keys "
                        f"({', '.join(sorted(_KEYS))})")
    return doc


def _num(where: str, key: str, v: Any, lo: float, hi: float) -> float:
    if isinstance(v, bool) or not isinstance(v, int | float):
        raise DataError(f"{where}: {key} must be a number in [{lo:g}, {hi:g}], got {v!r}")
    if not lo <= float(v) <= hi:
        raise DataError(f"{where}: {key}={v!r} is out of range [{lo:g}, {hi:g}]")
    return float(v)


def _asset(where: str, key: str, kind: str, v: Any) -> str | None:
    if v is None or (isinstance(v, str) and v.lower() == "none"):
        return None
    have = assets(kind)
    if not isinstance(v, str) or v not in have:
        raise DataError(f"{where}: unknown {key} {v!r}; available: {', '.join(have)}, none")
    return v


def _color(where: str, key: str, v: Any) -> str:
    if not isinstance(v, str) or not _HEX.match(v):
        raise DataError(f"{where}: {key} must be a colour '#rrggbb', got {v!r}")
    return v.lower()


def _modifiers(where: str, v: Any) -> dict[str, float]:
    if v is None:
        return {}
    if not isinstance(v, dict):
        raise DataError(f"{where}: modifiers must map modifier names to values, e.g. "
                        "'eyebrows-trans-down-up: 0.2' (mimika characters --modifiers)")
    have = modifiers()
    out: dict[str, float] = {}
    for name, value in v.items():
        if name not in have:
            import difflib

            near = difflib.get_close_matches(str(name), list(have), n=1)
            hint = f"did you mean {near[0]}? " if near else ""
            raise DataError(f"{where}: unknown modifier {name!r}; {hint}(mimika characters "
                            "--modifiers lists them)")
        out[name] = _num(where, f"modifiers.{name}", value, have[name].low, 1.0)
    return {k: x for k, x in sorted(out.items()) if x}


def _merge(base: dict, over: dict) -> dict:
    out = dict(base)
    for k, v in over.items():
        out[k] = _merge(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else v
    return out


def character_from_dict(doc: dict, where: str, default_name: str = "character") -> Character:
    """Validate a parsed character document."""
    unknown = sorted(set(doc) - _KEYS)
    if unknown:
        raise DataError(f"{where}: unknown key {unknown[0]!r}; keys: {', '.join(sorted(_KEYS))}")
    ext = doc.get("extends")
    if ext is not None:
        if ext not in preset_names():
            raise DataError(f"{where}: extends {ext!r}: no such preset; presets: "
                            f"{', '.join(preset_names())}")
        base = _parse(_preset_text(ext), f"preset {ext}")
        doc = _merge(base, {k: v for k, v in doc.items() if k != "extends"})
    ph = doc.get("phenotype") or {}
    if not isinstance(ph, dict):
        raise DataError(f"{where}: phenotype must be a mapping ({', '.join(sorted(_PHENO))})")
    bad = sorted(set(ph) - _PHENO)
    if bad:
        raise DataError(f"{where}: unknown phenotype key {bad[0]!r}; keys: "
                        f"{', '.join(sorted(_PHENO))}")
    pheno: dict[str, Any] = {}
    for k in ("gender", "muscle", "weight", "height", "proportions"):
        if k in ph:
            pheno[k] = _num(where, f"phenotype.{k}", ph[k], 0.0, 1.0)
    if "age" in ph:
        pheno["age"] = _num(where, "phenotype.age", ph["age"], 1.0, 90.0)
    origin = ph.get("origin")
    if origin is not None:
        if not isinstance(origin, dict) or not origin or set(origin) - set(RACES):
            raise DataError(f"{where}: phenotype.origin must map some of "
                            f"{', '.join(RACES)} to weights, got {origin!r}")
        pheno["origin"] = {r: _num(where, f"phenotype.origin.{r}", w, 0.0, 1e6)
                           for r, w in origin.items()}
        if sum(pheno["origin"].values()) <= 0:
            raise DataError(f"{where}: phenotype.origin weights must not all be 0")
    hair = doc.get("hair", "short02")
    hair_color = "#2a1d15"
    if isinstance(hair, dict):
        extra = sorted(set(hair) - {"style", "color"})
        if extra:
            raise DataError(f"{where}: unknown hair key {extra[0]!r} (style, color)")
        hair_color = _color(where, "hair.color", hair.get("color", hair_color))
        hair = hair.get("style")
    clothes = doc.get("clothes", ["male_elegantsuit01"])
    if clothes is None:
        clothes = []
    if isinstance(clothes, str):
        clothes = [clothes]
    if not isinstance(clothes, list):
        raise DataError(f"{where}: clothes must be a list of names")
    mix = pheno.get("origin") or dict.fromkeys(RACES, 1.0)
    # a name taken from the file name is made valid, never held against the user
    name = doc.get("name", re.sub(r"[^\w.-]+", "_", default_name).strip("_")[:64] or "character")
    if not isinstance(name, str) or not re.fullmatch(r"[\w.-]{1,64}", name):
        raise DataError(f"{where}: name must be 1–64 letters, digits, '.', '_' or '-'")
    desc = doc.get("description", "")
    return Character(
        name=name, description=str(desc), phenotype=pheno,
        modifiers=_modifiers(where, doc.get("modifiers")),
        skin=_color(where, "skin", doc.get("skin", _mix_hex(mix, SKIN_BY_ORIGIN))),
        eyes=_color(where, "eyes", doc.get("eyes", "#5b3a24")),
        hair=_asset(where, "hair", "hair", hair), hair_color=hair_color,
        eyebrows=_asset(where, "eyebrows", "eyebrows", doc.get("eyebrows", "eyebrow001")),
        eyelashes=_asset(where, "eyelashes", "eyelashes", doc.get("eyelashes", "eyelashes01")),
        clothes=tuple(_asset(where, "clothes", "clothes", c) for c in clothes),
        source=where,
    )


@functools.lru_cache(maxsize=32)
def _preset(name: str) -> Character:
    return character_from_dict(_parse(_preset_text(name), f"preset {name}"), f"preset {name}",
                               name)


def is_character_spec(spec: str) -> bool:
    """True for a preset name or a ``.yaml``/``.yml``/``.json`` character file path."""
    return spec in preset_names() or Path(spec).suffix.lower() in (".yaml", ".yml", ".json")


def load_character_spec(spec: str) -> Character:
    """A preset by name, or a character file (YAML/JSON) by path."""
    if spec in preset_names():
        return _preset(spec)
    p = Path(spec)
    if not p.is_file():
        raise DataError(f"no character {spec!r}: not a preset ({', '.join(preset_names())}) "
                        "and no such file")
    try:
        text = p.read_text("utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise DataError(f"cannot read character file {p}: {e}") from None
    return character_from_dict(_parse(text, str(p)), str(p), p.stem)
