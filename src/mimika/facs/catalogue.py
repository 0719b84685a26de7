"""The FACS Action Unit catalogue and AU code parsing.

Canonical names: ``AU01`` … ``AU66`` for bilateral AUs, ``AU12L`` / ``AU12R`` for one side
(the subject's left/right). Input accepts ``1``, ``AU1``, ``au12``, ``12L``, ``AU12r``.

Besides the AUs, a few *body channels* (``body.breath``, ``body.shrug_l`` …, listed in
``facs/data/body.csv``) name whole-body motion FACS does not code; they travel in the same
tracks, the AU Blender passes them through and only heads with a skinned body move them.
"""

from __future__ import annotations

import csv
import difflib
import functools
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from importlib import resources

from mimika.errors import ParameterError

_CODE_RE = re.compile(r"^\s*(?:au)?\s*0*(\d{1,2})\s*([lr])?\s*$", re.IGNORECASE)


@dataclass(frozen=True)
class ActionUnit:
    """One FACS Action Unit as listed in ``facs/data/aus.csv``."""

    code: str  #: canonical code, e.g. ``AU12``
    number: int
    name: str
    group: str  #: FACS manual group: upper face, lower face linear/orbital, head, eyes, misc
    objects: tuple[str, ...]  #: objects it moves (seed 002 Table 4.2): face, eyes, teeth
    kind: str  #: linear | rotation | translation
    subobject: bool  #: split by the plane through the mouth corners (seed 002 §4.1.3)
    seed: bool  #: one of the 32 AUs modelled in seed 002 (Table 4.1)
    sided: bool  #: has unilateral L/R variants
    muscle: str

    @property
    def region(self) -> str:
        return {"head": "head", "eyes": "eyes", "upper face": "upper face"}.get(
            self.group, "lower face"
        )


def _load() -> dict[str, ActionUnit]:
    text = resources.files("mimika.facs").joinpath("data/aus.csv").read_text("utf-8")
    out: dict[str, ActionUnit] = {}
    for row in csv.DictReader(text.splitlines()):
        au = ActionUnit(
            code=row["code"],
            number=int(row["code"][2:]),
            name=row["name"],
            group=row["group"],
            objects=tuple(row["objects"].split(";")),
            kind=row["kind"],
            subobject=row["subobject"] == "1",
            seed=row["seed"] == "1",
            sided=row["sided"] == "1",
            muscle=row["muscle"],
        )
        out[au.code] = au
    return out


#: Every FACS AU (face 1–46, head 51–58, eyes 61–66), keyed by canonical code.
AU_CATALOGUE: dict[str, ActionUnit] = _load()


def _load_body() -> dict[str, str]:
    text = resources.files("mimika.facs").joinpath("data/body.csv").read_text("utf-8")
    return {r["code"]: r["name"] for r in csv.DictReader(text.splitlines())}


#: Body channels (code → name): whole-body motion in [0, 1] beyond FACS.
BODY_CHANNELS: dict[str, str] = _load_body()


def is_body(code: str) -> bool:
    """True for a body channel (``body.breath`` …), False for an AU code."""
    return code in BODY_CHANNELS
#: The 32 AUs seed 002 models (Table 4.1).
SEED_AUS: tuple[str, ...] = tuple(c for c, a in AU_CATALOGUE.items() if a.seed)


def _all_codes() -> list[str]:
    codes = list(AU_CATALOGUE)
    for c, a in AU_CATALOGUE.items():
        if a.sided:
            codes += [c + "L", c + "R"]
    return codes


@functools.lru_cache(maxsize=4096)
def parse_au(text: str | int) -> str:
    """Return the canonical code for ``text`` (``"12"``, ``"au12"``, ``"AU12L"`` …).

    Raises :class:`ParameterError` naming the closest valid codes when ``text`` is unknown.
    """
    raw = str(text)
    if raw.strip().lower() in BODY_CHANNELS:
        return raw.strip().lower()
    m = _CODE_RE.match(raw)
    if m:
        code = f"AU{int(m.group(1)):02d}"
        side = (m.group(2) or "").upper()
        au = AU_CATALOGUE.get(code)
        if au is not None:
            if side and not au.sided:
                raise ParameterError(
                    f"AU code {raw!r}: {code} ({au.name}) has no left/right variants; use {code}"
                )
            return code + side
    if m:  # a number FACS does not use: suggest the numerically closest codes
        n = int(m.group(1))
        guess = sorted(AU_CATALOGUE, key=lambda c: abs(AU_CATALOGUE[c].number - n))[:3]
    else:
        guess = difflib.get_close_matches(raw.strip().upper(), _all_codes(), n=3, cutoff=0.5)
    hint = f"; did you mean {', '.join(guess)}?" if guess else ""
    raise ParameterError(
        f"unknown Action Unit {raw!r}{hint} (run 'mimika aus' for the full list)"
    )


def base_code(code: str) -> str:
    """``AU12L`` → ``AU12``; ``AU12`` → ``AU12``; body channels are their own base."""
    return code if code in BODY_CHANNELS else code[:4]


def side_of(code: str) -> str | None:
    """``AU12L`` → ``"L"``, ``AU12R`` → ``"R"``, ``AU12`` → ``None`` (body channels too)."""
    return None if code in BODY_CHANNELS else code[4:] or None


def parse_intensity(value: str | float, *, what: str = "intensity") -> float:
    """Parse an AU intensity in [0, 1]; FACS letters A–E map to 0.2 … 1.0."""
    if isinstance(value, str):
        s = value.strip()
        if len(s) == 1 and s.upper() in "ABCDE":
            return 0.2 * ("ABCDE".index(s.upper()) + 1)
        try:
            value = float(s)
        except ValueError:
            raise ParameterError(
                f"{what} {s!r} is not a number; use a value in [0, 1] or a FACS letter A–E"
            ) from None
    v = float(value)
    if not 0.0 <= v <= 1.0:
        raise ParameterError(f"{what}={v:g} is outside [0, 1]")
    return v


def parse_au_values(items: Iterable[str] | Mapping[str, float | str]) -> dict[str, float]:
    """Parse ``["AU12=1", "6=0.7", "AU01"]`` or ``{"au12": 1}`` into ``{"AU12": 1.0, …}``.

    A bare code means full intensity. Repeated codes raise :class:`ParameterError`.
    """
    pairs: list[tuple[str, str | float]] = []
    if isinstance(items, Mapping):
        pairs = list(items.items())
    else:
        for item in items:
            code, sep, val = str(item).partition("=")
            pairs.append((code, val if sep else 1.0))
    out: dict[str, float] = {}
    for code, val in pairs:
        c = parse_au(code)
        if c in out:
            raise ParameterError(f"Action Unit {c} is given twice")
        out[c] = parse_intensity(val, what=c)
    return out
