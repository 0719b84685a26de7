"""Expand a :class:`~mimika.batch.spec.BatchSpec` into items: one image (and clip) each.

Items come in a fixed order — head → identity → content (neutral, AU sets × intensities,
expressions × intensities, random samples) → view — with readable, stable ids such as
``builtin_front_AU01+AU02_i050``. Every item carries its requested AUs and the exact values
after the AU Blender (what is rendered and what ``labels.csv`` reports), so the plan is all the
labelling there is; workers only render.
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
import logging
import re
from collections.abc import Iterator
from dataclasses import dataclass, field, replace
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from mimika.batch.spec import BatchSpec, Identity, SpecError, is_ict
from mimika.facs.catalogue import AU_CATALOGUE, SEED_AUS, base_code

log = logging.getLogger(__name__)

IMAGES_DIR = "images"
CLIPS_DIR = "clips"
CLIP_EXT = {"mp4": ".mp4", "gif": ".gif", "strip": ".png"}


@dataclass(frozen=True)
class Item:
    """One planned image (and optional clip).

    ``requested`` are the AU intensities the spec asks for, ``aus`` the values after the AU
    Blender (both canonical code → [0, 1]); ``rules`` the Blender rules that changed something.
    ``file``/``clip`` are paths relative to the output folder; ``key`` hashes everything that
    determines the pixels (a finished item is reused only while its key is unchanged).
    """

    id: str
    head: str
    identity: Identity
    view: str
    kind: str  #: neutral | aus | expression | sample
    content: str  #: AU set (``AU01+AU02``), expression name, ``s0007`` or ``neutral``
    intensity: float | None
    requested: dict[str, float]
    aus: dict[str, float]
    rules: tuple[str, ...]
    file: str
    clip: str | None
    key: str = field(default="", compare=False)

    def payload(self) -> dict[str, Any]:
        """What a worker needs to render this item (plain data, cheap to ship)."""
        return {"id": self.id, "head": self.head, "identity": self.identity, "view": self.view,
                "requested": self.requested, "aus": self.aus, "clip": self.clip is not None}


@dataclass(frozen=True)
class Plan:
    """All items of a spec, the AU label columns and the resolved clip format."""

    spec: BatchSpec
    items: tuple[Item, ...]
    au_columns: tuple[str, ...]
    clip_format: str | None

    def __len__(self) -> int:
        return len(self.items)

    def __iter__(self) -> Iterator[Item]:
        return iter(self.items)

    def settings(self) -> dict[str, Any]:
        """Render settings shared by every item (sent once per task)."""
        s = self.spec
        return {"size": list(s.size), "samples": s.samples, "light": s.light,
                "face_height": s.face_height,
                "blend": s.blend,
                "disabled_rules": list(s.disabled_rules), "clip_format": self.clip_format,
                "animation": None if s.animation is None else {
                    "onset": s.animation.onset, "apex": s.animation.apex,
                    "offset": s.animation.offset, "fps": s.animation.fps,
                    "ease": s.animation.ease, "speech": s.animation.speech,
                    "audio": s.animation.audio, "lang": s.animation.lang}}


@lru_cache(maxsize=8)
def head_supported(head: str) -> tuple[str, ...]:
    """AU codes the rig of ``head`` models (loads the head once per process)."""
    from mimika.face.heads import load_head

    return tuple(load_head(head)[1].supported)


def au_sort_key(code: str) -> tuple[int, int]:
    """Catalogue order, bilateral before L before R."""
    return AU_CATALOGUE[base_code(code)].number, " LR".index(code[4:] or " ")


def clip_format(spec: BatchSpec) -> str | None:
    """The clip format ``auto`` resolves to here: mp4 where mimika can write video (PyAV and
    :mod:`mimika.render.video`) and the size is even, else an animated GIF."""
    if spec.animation is None:
        return None
    fmt = spec.animation.format
    if fmt != "auto":
        return fmt
    w, h = spec.size
    video = (importlib.util.find_spec("av") is not None
             and importlib.util.find_spec("mimika.render.video") is not None)
    if video and w % 2 == 0 and h % 2 == 0:
        return "mp4"
    log.info("animations are written as GIF (%s)",
             "odd image size" if video else "no video writer available")
    return "gif"


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9+.\-]+", "-", text).strip("-") or "x"


def _head_tags(heads: tuple[str, ...]) -> dict[str, str]:
    tags: dict[str, str] = {}
    for h in heads:
        tag = h if h in ("builtin", "ict") else _slug(Path(h).stem if Path(h).suffix
                                                        else Path(h).name)
        base, n = tag, 2
        while tag in tags.values():
            tag, n = f"{base}{n}", n + 1
        tags[h] = tag
    return tags


def _identity_tag(identity: Identity) -> str:
    if identity is None:
        return ""
    if isinstance(identity, int):
        return f"id{identity}"
    digest = hashlib.sha1(json.dumps(list(identity)).encode()).hexdigest()[:6]
    return f"idw{digest}"


def _num(v: float) -> str:
    return f"{v:.4f}".rstrip("0").rstrip(".")


def _intensity_tag(k: float) -> str:
    v = round(k * 100, 4)
    return f"i{int(v):03d}" if float(v).is_integer() else "i" + f"{v:07.3f}".replace(".", "p")


def _set_name(pairs: tuple[tuple[str, float], ...]) -> str:
    return "+".join(c if w == 1.0 else f"{c}x{_num(w)}" for c, w in pairs)


def _contents(spec: BatchSpec, heads_sup: dict[str, tuple[str, ...]]
              ) -> list[tuple[str, str, float | None, dict[str, float]]]:
    """(kind, content name, intensity, requested AUs) — the same for every head/view."""
    out: list[tuple[str, str, float | None, dict[str, float]]] = []
    if spec.neutral:
        out.append(("neutral", "neutral", None, {}))
    sets = list(spec.aus)
    if spec.aus_keyword == "modelled":
        common = set.intersection(*(set(s) for s in heads_sup.values()))
        codes = sorted((c for c in common if len(c) == 4), key=au_sort_key)
        sets = [((c, 1.0),) for c in codes]
    for pairs in sets:
        for k in spec.intensities:
            req = {c: round(w * k, 6) for c, w in pairs}
            out.append(("aus", _set_name(pairs), k, req))
    if spec.expressions:
        from mimika.knowledge.expressions import get_expression

        for name in spec.expressions:
            for k in spec.intensities:
                out.append(("expression", name, k, get_expression(name, k)))
    if spec.sample is not None:
        out += _samples(spec, heads_sup)
    return out


def _samples(spec: BatchSpec, heads_sup: dict[str, tuple[str, ...]]
             ) -> list[tuple[str, str, float | None, dict[str, float]]]:
    s = spec.sample
    assert s is not None
    common = set.intersection(*(set(v) for v in heads_sup.values()))
    if s.pool is None:
        pool = [a for a in SEED_AUS
                if AU_CATALOGUE[a].group not in ("head", "eyes") and a in common]
        if len(pool) < s.max_aus:
            raise spec.error(("sample", "max_aus"), f"{s.max_aus} AUs cannot be drawn from the "
                                                    f"{len(pool)} AUs every head models")
    else:
        pool = list(s.pool)
    rng = np.random.default_rng(spec.seed)
    width = max(4, len(str(s.count - 1)))
    out = []
    for i in range(s.count):
        k = int(rng.integers(s.min_aus, s.max_aus + 1))
        idx = sorted(rng.choice(len(pool), size=k, replace=False).tolist())
        if s.levels is not None:
            vals = [float(s.levels[j]) for j in rng.integers(0, len(s.levels), size=k)]
        else:
            vals = [round(float(v), 2) for v in rng.uniform(s.range[0], s.range[1], size=k)]
        req = dict(sorted(((pool[j], v) for j, v in zip(idx, vals, strict=True)),
                          key=lambda cv: au_sort_key(cv[0])))
        out.append(("sample", f"s{i:0{width}d}", None, req))
    return out


def _check_supported(spec: BatchSpec, heads_sup: dict[str, tuple[str, ...]]) -> None:
    for h, sup in heads_sup.items():
        ok = set(sup)
        for i, pairs in enumerate(spec.aus):
            for c, _ in pairs:
                if c not in ok:
                    models = ", ".join(x for x in sup if len(x) == 4)
                    raise spec.error(("aus", i), f"{c} ({AU_CATALOGUE[base_code(c)].name}) is "
                                                 f"not modelled by head {h!r}; it models: "
                                                 f"{models}")
        if spec.sample is not None and spec.sample.pool is not None:
            for i, c in enumerate(spec.sample.pool):
                if c not in ok:
                    raise spec.error(("sample", "pool", i), f"{c} is not modelled by head {h!r}")


def _key(item: dict[str, Any], settings: dict[str, Any]) -> str:
    text = json.dumps({"item": item, "settings": settings}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def make_plan(spec: BatchSpec) -> Plan:
    """Every item of ``spec`` in a fixed order, with AU values after the Blender.

    Raises :class:`SpecError` when an AU is not modelled by a head or two items would share a
    file name.
    """
    from mimika.facs.blender import blend

    heads_sup = {h: head_supported(h) for h in spec.heads}
    _check_supported(spec, heads_sup)
    contents = _contents(spec, heads_sup)
    fmt = clip_format(spec)
    tags = _head_tags(spec.heads)
    blended: list[tuple[dict[str, float], tuple[str, ...]]] = []
    for _, _, _, req in contents:
        if spec.blend and req:
            r = blend(req, disabled=spec.disabled_rules)
            blended.append((dict(r.aus), tuple(dict.fromkeys(t.rule for t in r.trace))))
        else:
            blended.append((dict(req), ()))
    plan_settings = Plan(spec, (), (), fmt).settings()
    items: list[Item] = []
    for h in spec.heads:
        identities = spec.identities if is_ict(h) else (None,)
        sup = set(heads_sup[h])
        for ident in identities:
            for (kind, name, k, req), (aus, rules) in zip(contents, blended, strict=True):
                bad = [c for c in aus if c not in sup]
                if bad:
                    raise SpecError(f"{spec.source}: {name}: {', '.join(bad)} not modelled by "
                                    f"head {h!r}")
                for view in spec.views:
                    parts = [tags[h], _identity_tag(ident), view, _slug(name),
                             _intensity_tag(k) if k is not None else ""]
                    iid = "_".join(p for p in parts if p)
                    clip = (f"{CLIPS_DIR}/{iid}{CLIP_EXT[fmt]}"
                            if fmt is not None and kind != "neutral" else None)
                    item = Item(id=iid, head=h, identity=ident, view=view, kind=kind,
                                content=name, intensity=k, requested=req, aus=aus, rules=rules,
                                file=f"{IMAGES_DIR}/{iid}.png", clip=clip)
                    key = _key({**item.payload(), "clip": clip}, plan_settings)
                    items.append(replace(item, key=key))
    ids = [it.id for it in items]
    if len(set(ids)) != len(ids):
        dup = next(i for i in ids if ids.count(i) > 1)
        raise SpecError(f"{spec.source}: two items would both be named {dup!r}; "
                        "remove the repeated entry")
    columns = sorted({c for it in items for c in (*it.aus, *it.requested)}, key=au_sort_key)
    log.info("planned %d items (%d AU columns)", len(items), len(columns))
    return Plan(spec, tuple(items), tuple(columns), fmt)
