"""Batch specs: a YAML file describing a stimulus set or a training set, validated strictly.

The schema is documented in ``docs/batch.md``. Every mistake raises :class:`SpecError` naming
the file, the line and the key (``spec.yaml:4: intensities[1]: 1.5 is outside [0, 1]``), with
"did you mean" for misspelt keys, AU codes, views and expressions.
"""

from __future__ import annotations

import difflib
import glob
import hashlib
import inspect
import json
import logging
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from mimika.errors import DataError, MimikaError, ParameterError
from mimika.face.heads import DEFAULT_HEAD
from mimika.facs.catalogue import SEED_AUS, parse_au, parse_intensity
from mimika.render.camera import FILL

log = logging.getLogger(__name__)

#: ``identity`` of an item: None (the head's own face), an ICT mode 0–9 or mode weights
Identity = int | tuple[float, ...] | None
Path_ = tuple[str | int, ...]

VIEWS: tuple[str, ...] = ("front", "three-quarter", "profile")  # == mimika.render.camera.VIEWS
CLIP_FORMATS = ("auto", "mp4", "gif", "strip")
AU_KEYWORDS = ("seed", "modelled")

TOP_KEYS = ("name", "aus", "expressions", "intensities", "neutral", "sample", "heads",
            "identities", "views", "size", "samples", "light", "face_height", "blend",
            "disabled_rules", "seed", "animation")
SAMPLE_KEYS = ("count", "pool", "min_aus", "max_aus", "range", "levels")
ANIMATION_KEYS = ("onset", "apex", "offset", "fps", "format", "ease", "speech", "audio", "lang")


class SpecError(DataError):
    """A batch spec is malformed; the message names file, line and key."""


@dataclass(frozen=True)
class SampleSpec:
    """Random AU combinations: ``count`` sets of ``min_aus``–``max_aus`` AUs from ``pool``.

    Intensities are uniform in ``range`` (rounded to 0.01), or drawn from ``levels``.
    ``pool=None`` means the seed face AUs every head models.
    """

    count: int
    pool: tuple[str, ...] | None = None
    min_aus: int = 1
    max_aus: int = 3
    range: tuple[float, float] = (0.2, 1.0)
    levels: tuple[float, ...] | None = None


@dataclass(frozen=True)
class AnimationSpec:
    """A short onset–apex–offset clip per item (seconds; ``fps`` frames per second)."""

    onset: float = 0.25
    apex: float = 0.5
    offset: float = 0.25
    fps: float = 25.0
    #: auto (mp4 where PyAV video output is available, else gif) | mp4 | gif | strip
    format: str = "auto"
    ease: str | None = None
    #: spoken clips: the text (lip-sync; the item's AUs rise over ``onset`` and fall over
    #: ``offset`` around it), a recording of it (absolute path; else espeak-ng) and its language
    speech: str | None = None
    audio: str | None = None
    lang: str = "en"

    @property
    def duration(self) -> float:
        return self.onset + self.apex + self.offset


@dataclass(frozen=True)
class BatchSpec:
    """A validated batch spec (see ``docs/batch.md``).

    ``aus`` holds AU sets as ``((code, weight), …)``; each set is rendered at every intensity
    (value = weight × intensity). ``aus_keyword`` (``modelled``) expands per head in the plan.
    """

    aus: tuple[tuple[tuple[str, float], ...], ...] = ()
    aus_keyword: str | None = None
    expressions: tuple[str, ...] = ()
    intensities: tuple[float, ...] = (1.0,)
    neutral: bool = False
    sample: SampleSpec | None = None
    heads: tuple[str, ...] = (DEFAULT_HEAD,)
    identities: tuple[Identity, ...] = (None,)
    views: tuple[str, ...] = ("front",)
    size: tuple[int, int] = (320, 240)
    samples: int = 4
    light: str = "studio"  #: a ``--light`` spec (mimika.render.lighting)
    face_height: float = FILL  #: share of the image height the face fills (render.camera)
    blend: bool = True
    disabled_rules: tuple[str, ...] = ()
    seed: int = 0
    animation: AnimationSpec | None = None
    name: str = ""
    source: str = field(default="<spec>", compare=False)
    #: line of every key path in the source file (for messages raised later, in the plan)
    lines: Mapping[Path_, int] = field(default_factory=dict, compare=False, repr=False)

    def to_dict(self) -> dict[str, Any]:
        """The normalised spec as plain JSON-able data (what :attr:`hash` covers)."""
        d = asdict(self)
        d.pop("source")
        d.pop("lines")
        return json.loads(json.dumps(d))

    def error(self, path: Path_, msg: str) -> SpecError:
        """A :class:`SpecError` located at key ``path`` of this spec's file."""
        return _Checker(self.source, self.lines).error(path, msg)

    @property
    def hash(self) -> str:
        """A short SHA-256 of the normalised spec (comments and key order do not matter)."""
        text = json.dumps(self.to_dict(), sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()[:16]


# -- YAML with line numbers -------------------------------------------------------------------
def _read_yaml(text: str, source: str) -> tuple[Any, dict[Path_, int]]:
    """Parse ``text`` into plain data plus the 1-based line of every key and list item
    (safely: :mod:`mimika.io.yamlsafe`)."""
    from mimika.io.yamlsafe import read_yaml

    return read_yaml(text, source, error=SpecError)


def _where(path: Path_) -> str:
    from mimika.io.yamlsafe import where

    return where(path) if path else "spec"


class _Checker:
    """Raises :class:`SpecError` with file:line and key path."""

    def __init__(self, source: str, lines: Mapping[Path_, int]):
        self.source = source
        self.lines = lines

    def error(self, path: Path_, msg: str) -> SpecError:
        p = tuple(path)
        while p and p not in self.lines:
            p = p[:-1]
        line = self.lines.get(p)
        loc = f"{self.source}:{line}" if line else self.source
        return SpecError(f"{loc}: {_where(path)}: {msg}")

    def keys(self, d: Any, allowed: Sequence[str], path: Path_) -> dict:
        if not isinstance(d, Mapping):
            raise self.error(path, f"must be a mapping of keys ({', '.join(allowed)}), "
                                   f"not {_show(d)}")
        for k in d:
            if k not in allowed:
                close = difflib.get_close_matches(str(k), allowed, n=1, cutoff=0.6)
                hint = f"; did you mean {close[0]!r}?" if close else ""
                raise self.error((*path, k), f"unknown key {k!r}{hint} "
                                             f"(valid keys: {', '.join(allowed)})")
        return dict(d)

    def seq(self, v: Any, path: Path_, *, scalar_ok: bool = True) -> list:
        if isinstance(v, list):
            return v
        if scalar_ok and v is not None and not isinstance(v, Mapping):
            return [v]
        raise self.error(path, f"must be a list, not {_show(v)}")

    def number(self, v: Any, path: Path_, *, lo: float | None = None, hi: float | None = None,
               integer: bool = False, lo_open: bool = False) -> float:
        ok = isinstance(v, int | float) and not isinstance(v, bool)
        if not ok or (integer and not float(v).is_integer()) or not math.isfinite(float(v)):
            raise self.error(path, f"{_show(v)} must be {'an integer' if integer else 'a number'}")
        f = float(v)
        if lo is not None and (f <= lo if lo_open else f < lo):
            raise self.error(path, f"{v!r} must be {'>' if lo_open else '≥'} {lo:g}")
        if hi is not None and f > hi:
            raise self.error(path, f"{v!r} must be ≤ {hi:g}")
        return int(f) if integer else f

    def intensity(self, v: Any, path: Path_) -> float:
        if isinstance(v, bool) or not isinstance(v, int | float | str):
            raise self.error(path, f"{_show(v)} must be an intensity in [0, 1] or a FACS letter "
                                   "A–E")
        if isinstance(v, int | float) and not 0.0 <= float(v) <= 1.0:
            raise self.error(path, f"intensity {v!r} is outside [0, 1] "
                                   "(use 0…1 or a FACS letter A–E)")
        try:
            return round(parse_intensity(v), 6)
        except MimikaError as e:
            raise self.error(path, str(e)) from None

    def au(self, v: Any, path: Path_) -> str:
        if isinstance(v, bool) or not isinstance(v, str | int):
            raise self.error(path, f"{_show(v)} is not an AU code (write e.g. AU12)")
        try:
            return parse_au(v)
        except MimikaError as e:
            raise self.error(path, str(e)) from None

    def flag(self, v: Any, path: Path_) -> bool:
        if not isinstance(v, bool):
            raise self.error(path, f"{_show(v)} must be true or false")
        return v


def _show(v: Any) -> str:
    if isinstance(v, Mapping):
        return "a mapping"
    if isinstance(v, list):
        return "a list"
    if v is None:
        return "empty"
    return repr(v)


# -- the fields -------------------------------------------------------------------------------
def _au_set(c: _Checker, v: Any, path: Path_) -> tuple[tuple[str, float], ...]:
    """One AU set: ``[AU01, AU02]``, ``"AU01+AU02"``, ``{AU06: 1, AU07: 0.8}``, ``AU07=0.8``."""
    pairs: list[tuple[str, float, Path_]] = []
    if isinstance(v, Mapping):
        for k, w in v.items():
            pairs.append((c.au(k, (*path, k)), c.intensity(w, (*path, k)), (*path, k)))
    else:
        items = v if isinstance(v, list) else [v]
        if isinstance(v, str):
            items = [s for s in v.split("+")]
        if not items:
            raise c.error(path, "an AU set must name at least one AU")
        for i, it in enumerate(items):
            p = (*path, i) if isinstance(v, list) else path
            if isinstance(it, str) and "=" in it:
                code, _, val = it.partition("=")
                pairs.append((c.au(code.strip(), p), c.intensity(val.strip(), p), p))
            else:
                pairs.append((c.au(it.strip() if isinstance(it, str) else it, p), 1.0, p))
    seen: set[str] = set()
    for code, _, p in pairs:
        if code in seen:
            raise c.error(p, f"{code} is given twice in this AU set")
        seen.add(code)
    return tuple((code, w) for code, w, _ in pairs)


#: file types a head may be (besides an ICT-FaceKit folder)
_HEAD_FILES = (".obj", ".glb", ".gltf", ".vrm", ".yaml", ".yml", ".json")


def _heads(c: _Checker, v: Any, base: Path | None) -> tuple[str, ...]:
    from mimika.face.makehuman.character_file import preset_names

    out = []
    for i, h in enumerate(c.seq(v, ("heads",))):
        p = ("heads", i)
        if not isinstance(h, str) or not h.strip():
            raise c.error(p, f"{_show(h)} is not a head (use a character, builtin, ict, an "
                             "ICT-FaceKit folder or an .obj file)")
        h = h.strip()
        if h == "builtin" or h in preset_names():
            out.append(h)
            continue
        if h == "ict":
            from mimika.face.heads.ict import find_ict_dir

            try:
                find_ict_dir()
            except MimikaError as e:
                raise c.error(p, f"head 'ict' is not available here: {e}") from None
            out.append(h)
            continue
        path = Path(os.path.expanduser(h))
        if not path.is_absolute() and base is not None:
            path = base / path
        if glob.has_magic(h):  # people/*.yaml: every head file that matches
            found = sorted(Path(f) for f in glob.glob(str(path))
                           if Path(f).suffix.lower() in _HEAD_FILES)
            if not found:
                raise c.error(p, f"no head file ({', '.join(_HEAD_FILES)}) matches "
                                 f"{str(path)!r}")
            out.extend(str(f.resolve()) for f in found)
            continue
        if path.is_dir() or path.suffix.lower() in _HEAD_FILES:
            if not path.exists():
                raise c.error(p, f"head file {str(path)!r} does not exist")
            out.append(str(path.resolve()))
            continue
        close = difflib.get_close_matches(h, ["builtin", "ict", *preset_names()], n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        raise c.error(p, f"unknown head {h!r}{hint} (use a character such as "
                         f"{preset_names()[0]} or a .yaml file, builtin, ict, an ICT-FaceKit "
                         "folder, a glTF/GLB/VRM avatar or an .obj file; run 'mimika heads')")
    if len(set(out)) != len(out):
        raise c.error(("heads",), "a head is listed twice")
    if not out:
        raise c.error(("heads",), "list at least one head")
    return tuple(out)


def is_ict(head: str) -> bool:
    """Whether ``head`` (as normalised in a spec) is an ICT head, i.e. takes identities."""
    return head == "ict" or Path(head).is_dir()


def _identities(c: _Checker, v: Any, heads: Sequence[str]) -> tuple[Identity, ...]:
    out: list[Identity] = []
    items = c.seq(v, ("identities",)) if v is not None else [None]
    for i, x in enumerate(items):
        p = ("identities", i)
        if x is None:
            out.append(None)
        elif isinstance(x, list):
            if not 1 <= len(x) <= 10:
                raise c.error(p, f"identity weights need 1 to 10 numbers, got {len(x)}")
            out.append(tuple(c.number(w, (*p, j)) for j, w in enumerate(x)))
        else:
            out.append(c.number(x, p, lo=0, hi=9, integer=True))
    if not out:
        raise c.error(("identities",), "list at least one identity (null: the head's own face)")
    if len(set(out)) != len(out):
        raise c.error(("identities",), "an identity is listed twice")
    if any(x is not None for x in out):
        if not any(is_ict(h) for h in heads):
            raise c.error(("identities",), "identities apply to ICT heads only, and no head in "
                                           "'heads' is one (add 'ict' or remove identities)")
        from mimika.face.heads import load_head

        if "identity" not in inspect.signature(load_head).parameters:
            raise c.error(("identities",), "this mimika cannot load ICT identities yet")
    return tuple(out)


def _sample(c: _Checker, v: Any) -> SampleSpec:
    if not isinstance(v, Mapping):
        n = c.number(v, ("sample",), lo=1, integer=True)
        return SampleSpec(count=n)
    d = c.keys(v, SAMPLE_KEYS, ("sample",))
    if "count" not in d:
        raise c.error(("sample",), "needs 'count': how many random AU combinations")
    count = c.number(d["count"], ("sample", "count"), lo=1, integer=True)
    pool = None
    if d.get("pool") is not None:
        pool = tuple(c.au(a, ("sample", "pool", i))
                     for i, a in enumerate(c.seq(d["pool"], ("sample", "pool"))))
        if len(set(pool)) != len(pool):
            raise c.error(("sample", "pool"), "an AU is listed twice")
    lo_n = c.number(d.get("min_aus", 1), ("sample", "min_aus"), lo=1, integer=True)
    hi_n = c.number(d.get("max_aus", max(3, lo_n)), ("sample", "max_aus"), lo=1, integer=True)
    if hi_n < lo_n:
        raise c.error(("sample", "max_aus"), f"{hi_n} is below min_aus={lo_n}")
    if pool is not None and hi_n > len(pool):
        raise c.error(("sample", "max_aus"), f"{hi_n} AUs cannot be drawn from a pool of "
                                             f"{len(pool)}")
    rng = (0.2, 1.0)
    if "range" in d:
        r = d["range"]
        if not isinstance(r, list) or len(r) != 2:
            raise c.error(("sample", "range"), "must be [low, high], e.g. [0.2, 1.0]")
        rng = (c.intensity(r[0], ("sample", "range", 0)), c.intensity(r[1], ("sample", "range", 1)))
        if rng[1] < rng[0]:
            raise c.error(("sample", "range"), f"high {rng[1]:g} is below low {rng[0]:g}")
    levels = None
    if d.get("levels") is not None:
        if "range" in d:
            raise c.error(("sample", "levels"), "give 'range' or 'levels', not both")
        levels = tuple(c.intensity(x, ("sample", "levels", i))
                       for i, x in enumerate(c.seq(d["levels"], ("sample", "levels"))))
        if not levels:
            raise c.error(("sample", "levels"), "list at least one intensity")
    return SampleSpec(count=count, pool=pool, min_aus=lo_n, max_aus=hi_n, range=rng,
                      levels=levels)


def _speech(c: _Checker, d: Mapping[str, Any], base: Path | None) -> dict[str, Any]:
    """``speech``/``audio``/``lang`` of a spoken clip (audio paths relative to the spec)."""
    a = ("animation",)
    kw: dict[str, Any] = {}
    if "speech" in d:
        if not isinstance(d["speech"], str) or not d["speech"].strip():
            raise c.error((*a, "speech"), "speech must be the text to speak")
        kw["speech"] = d["speech"]
    if "audio" in d:
        if "speech" not in kw:
            raise c.error((*a, "audio"), "audio needs speech: the text spoken in the recording")
        path = Path(str(d["audio"])).expanduser()
        if not path.is_absolute() and base is not None:
            path = base / path
        if not path.is_file():
            raise c.error((*a, "audio"), f"recording {str(path)!r} does not exist")
        kw["audio"] = str(path.resolve())
    if "lang" in d:
        from mimika.speech.espeak import check_lang

        try:
            kw["lang"] = check_lang(str(d["lang"]))
        except MimikaError as e:
            raise c.error((*a, "lang"), str(e)) from None
    return kw


def _animation(c: _Checker, v: Any, size: tuple[int, int], base: Path | None = None
               ) -> AnimationSpec | None:
    if v is None or v is False:
        return None
    if v is True:
        v = {}
    d = c.keys(v, ANIMATION_KEYS, ("animation",))
    a = ("animation",)
    kw: dict[str, Any] = {}
    for k in ("onset", "apex", "offset"):
        if k in d:
            kw[k] = c.number(d[k], (*a, k), lo=0, hi=10)
    if "fps" in d:
        kw["fps"] = c.number(d["fps"], (*a, "fps"), lo=0, hi=240, lo_open=True)
    fmt = d.get("format", "auto")
    if fmt not in CLIP_FORMATS:
        close = difflib.get_close_matches(str(fmt), CLIP_FORMATS, n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        raise c.error((*a, "format"), f"unknown clip format {fmt!r}{hint} "
                                      f"(use {', '.join(CLIP_FORMATS)})")
    if fmt == "mp4" and (size[0] % 2 or size[1] % 2):
        raise c.error((*a, "format"), f"mp4 needs an even image size, not {size[0]}x{size[1]}")
    kw["format"] = fmt
    if d.get("ease") is not None:
        from mimika.timeline.easing import check_easing

        try:
            kw["ease"] = check_easing(str(d["ease"]))
        except MimikaError as e:
            raise c.error((*a, "ease"), str(e)) from None
    kw.update(_speech(c, d, base))
    spec = AnimationSpec(**kw)
    if spec.duration <= 0:
        raise c.error(a, "onset + apex + offset must be > 0 seconds")
    return spec


def _size(c: _Checker, v: Any) -> tuple[int, int]:
    p = ("size",)
    if isinstance(v, str):
        try:
            w, h = (int(x) for x in v.lower().split("x"))
        except ValueError:
            raise c.error(p, f"{v!r} must look like 320x240 or [320, 240]") from None
    elif isinstance(v, list) and len(v) == 2:
        w, h = (c.number(x, (*p, i), integer=True) for i, x in enumerate(v))
    else:
        raise c.error(p, f"{_show(v)} must look like 320x240 or [320, 240]")
    if not (16 <= w <= 8192 and 16 <= h <= 8192):
        raise c.error(p, f"{w}x{h}: width and height must be 16…8192 pixels")
    return int(w), int(h)


def parse_spec(data: Any, *, source: str = "<spec>", base: str | os.PathLike | None = None,
               lines: Mapping[Path_, int] | None = None) -> BatchSpec:
    """Validate ``data`` (the YAML document as plain Python) into a :class:`BatchSpec`.

    ``base`` is the folder relative head paths are resolved against; ``lines`` maps key paths
    to line numbers for messages.
    """
    c = _Checker(source, lines or {})
    if data is None:
        raise c.error((), "the spec is empty; the smallest one is "
                          "'aus: [[AU12]]' (see docs/batch.md)")
    d = c.keys(data, TOP_KEYS, ())
    kw: dict[str, Any] = {}
    if "name" in d:
        kw["name"] = str(d["name"])
    heads = _heads(c, d.get("heads", [DEFAULT_HEAD]), Path(base) if base is not None else None)
    kw["heads"] = heads
    kw["identities"] = _identities(c, d.get("identities"), heads)

    if d.get("aus") is not None:
        v = d["aus"]
        if isinstance(v, str) and v in AU_KEYWORDS:
            if v == "seed":
                kw["aus"] = tuple(((a, 1.0),) for a in SEED_AUS)
            else:
                kw["aus_keyword"] = v
        elif isinstance(v, str) and v.strip().lower() in (*AU_KEYWORDS, "all", "every"):
            raise c.error(("aus",), f"{v!r}: did you mean 'modelled' (every AU the heads model) "
                                    "or 'seed' (the 32 seed AUs)?")
        else:
            sets = tuple(_au_set(c, s, ("aus", i))
                         for i, s in enumerate(c.seq(v, ("aus",), scalar_ok=False)))
            keyed = [tuple(sorted(s)) for s in sets]
            for i, k in enumerate(keyed):
                if k in keyed[:i]:
                    raise c.error(("aus", i), f"this AU set repeats aus[{keyed.index(k)}]")
            kw["aus"] = sets
    if d.get("expressions") is not None:
        from mimika.knowledge.expressions import ExpressionLibrary

        lib = ExpressionLibrary()
        names = []
        for i, n in enumerate(c.seq(d["expressions"], ("expressions",))):
            if not isinstance(n, str):
                raise c.error(("expressions", i), f"{_show(n)} is not an expression name")
            try:
                names.append(lib.get(n).name)
            except MimikaError as e:
                raise c.error(("expressions", i), str(e)) from None
        if len(set(names)) != len(names):
            raise c.error(("expressions",), "an expression is listed twice")
        kw["expressions"] = tuple(names)
    if "intensities" in d:
        its = tuple(c.intensity(x, ("intensities", i))
                    for i, x in enumerate(c.seq(d["intensities"], ("intensities",))))
        if not its:
            raise c.error(("intensities",), "list at least one intensity")
        if len(set(its)) != len(its):
            raise c.error(("intensities",), "an intensity is listed twice")
        kw["intensities"] = its
    if "neutral" in d:
        kw["neutral"] = c.flag(d["neutral"], ("neutral",))
    if d.get("sample") is not None:
        kw["sample"] = _sample(c, d["sample"])
    if "views" in d:
        views = []
        for i, v in enumerate(c.seq(d["views"], ("views",))):
            if v not in VIEWS:
                close = difflib.get_close_matches(str(v), VIEWS, n=1)
                hint = f"; did you mean {close[0]!r}?" if close else ""
                raise c.error(("views", i), f"unknown view {v!r}{hint} (use {', '.join(VIEWS)})")
            views.append(v)
        if not views:
            raise c.error(("views",), "list at least one view")
        if len(set(views)) != len(views):
            raise c.error(("views",), "a view is listed twice")
        kw["views"] = tuple(views)
    size = _size(c, d["size"]) if "size" in d else BatchSpec.size
    kw["size"] = size
    if "samples" in d:
        s = c.number(d["samples"], ("samples",), integer=True)
        if s not in (0, 2, 4, 8):
            raise c.error(("samples",), f"{s} anti-aliasing samples: use 0, 2, 4 or 8")
        kw["samples"] = s
    if "light" in d:
        from mimika.render.lighting import parse_light

        if not isinstance(d["light"], str):
            raise c.error(("light",), "give the lights as a --light spec, e.g. studio or "
                                      "news,shadows=off")
        try:
            parse_light(d["light"])
        except ParameterError as e:
            raise c.error(("light",), str(e).replace("--light ", "")) from None
        kw["light"] = d["light"]
    if "face_height" in d:
        kw["face_height"] = c.number(d["face_height"], ("face_height",), lo=0.05, hi=1.0)
    if "blend" in d:
        kw["blend"] = c.flag(d["blend"], ("blend",))
    if d.get("disabled_rules") is not None:
        from mimika.facs.blender import Blender

        rules = []
        for i, r in enumerate(c.seq(d["disabled_rules"], ("disabled_rules",))):
            try:
                rules.append(Blender.default().rule(str(r)).notation)
            except MimikaError as e:
                raise c.error(("disabled_rules", i), str(e)) from None
        kw["disabled_rules"] = tuple(rules)
    if "seed" in d:
        kw["seed"] = c.number(d["seed"], ("seed",), lo=0, integer=True)
    kw["animation"] = _animation(c, d.get("animation"), size,
                                 Path(base) if base is not None else None)
    spec = BatchSpec(source=source, lines=dict(lines or {}), **kw)
    if not (spec.aus or spec.aus_keyword or spec.expressions or spec.sample or spec.neutral):
        raise c.error((), "the spec renders nothing: give 'aus', 'expressions', 'sample' or "
                          "'neutral: true'")
    if "intensities" in d and not (spec.aus or spec.aus_keyword or spec.expressions):
        raise c.error(("intensities",), "intensities scale 'aus' and 'expressions'; the spec "
                                        "has neither")
    _check_items(c, spec)
    return spec


def item_count(spec: BatchSpec) -> int:
    """How many items (images) ``spec`` renders — an upper bound for ``aus: modelled``."""
    sets = 64 if spec.aus_keyword else len(spec.aus)
    contents = (int(spec.neutral) + (sets + len(spec.expressions)) * len(spec.intensities)
                + (spec.sample.count if spec.sample else 0))
    faces = sum(len(spec.identities) if is_ict(h) else 1 for h in spec.heads)
    return contents * faces * len(spec.views)


def _check_items(c: _Checker, spec: BatchSpec) -> None:
    from mimika import limits

    n = item_count(spec)
    if n > limits.current().max_items:
        raise c.error(("sample", "count") if spec.sample else (),
                      str(limits.over("max_items", f"the spec has {limits.fmt(n)} items")))


def load_spec(path: str | os.PathLike) -> BatchSpec:
    """Read and validate the YAML spec at ``path``; relative head paths are resolved against
    its folder. Raises :class:`SpecError` (file:line: key: problem)."""
    p = Path(path)
    try:
        text = p.read_text("utf-8")
    except OSError as e:
        raise SpecError(f"cannot read spec {str(p)!r}: {e.strerror or e}") from None
    except UnicodeDecodeError:
        raise SpecError(f"spec {str(p)!r} is not UTF-8 text") from None
    data, lines = _read_yaml(text, str(p))
    spec = parse_spec(data, source=str(p), base=p.parent, lines=lines)
    log.info("spec %s: hash %s", p, spec.hash)
    return spec
