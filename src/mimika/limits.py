"""The limits on what mimika accepts: one documented set, checked at every entry point.

Every command, the Python API, the studio (HTTP and WebSocket) and batch jobs refuse work
they could not finish *before* they allocate for it: a timeline longer than
``max_duration``, more than ``max_frames`` frames, an fps over ``max_fps``, text over
``max_text`` characters, documents nested deeper than ``max_depth`` or with integers beyond
``max_int`` … Each refusal is one :class:`LimitError` line naming the limit and how to raise it.

The values come from :data:`DEFAULTS`, then ``MIMIKA_MAX_…`` environment variables
(``MIMIKA_MAX_DURATION=7200``), then :func:`override` (what the ``--max-duration``-style
command-line options use). ``docs/limits.md`` lists them all.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import re
from collections.abc import Iterator
from dataclasses import dataclass, fields, replace
from typing import Any

from mimika.errors import DataError, ParameterError

__all__ = ["DEFAULTS", "OPTIONS", "LimitError", "Limits", "check_count", "check_duration",
           "check_fps", "check_frames", "check_json_tree", "check_recording",
           "check_speech", "check_text",
           "check_timeline", "current", "fmt", "loads_json", "over", "override",
           "speech_seconds"]


@dataclass(frozen=True)
class Limits:
    """One set of limits (see ``docs/limits.md``); units are in the field names' docs."""

    #: longest timeline, speech or animation (seconds)
    max_duration: float = 3600.0
    #: largest frame rate (frames per second)
    max_fps: float = 1000.0
    #: most frames in one AU track, render or export
    max_frames: int = 250_000
    #: largest text: a script, article or text to speak (characters)
    max_text: int = 500_000
    #: deepest nesting of a JSON/YAML document or a script's elements
    max_depth: int = 64
    #: most values (scalars, lists, mappings) in one JSON/YAML document
    max_nodes: int = 200_000
    #: largest integer (absolute value) in a JSON/YAML document: 2**53, exact as a float
    max_int: int = 2**53
    #: most YAML aliases (``*name``) in one batch spec
    max_aliases: int = 50
    #: most items (images) in one batch
    max_items: int = 100_000
    #: most worker processes (batch, news)
    max_workers: int = 64
    #: largest studio request body or WebSocket message (bytes)
    max_body: int = 2 * 1024 * 1024
    #: longest wall-clock time of one studio export (seconds)
    max_export_seconds: float = 600.0
    #: studio exports running at once (more wait up to 10 s, then get 503)
    max_exports: int = 2
    #: studio speech cache (megabytes of audio)
    max_cache_mb: float = 128.0
    #: largest texture decoded from a glTF/VRM avatar (pixels, width × height)
    max_texture_pixels: int = 64 * 1024 * 1024
    #: longest recording read for alignment or a video's sound track (seconds)
    max_recording: float = 1800.0
    #: highest sample rate of a recording (Hz)
    max_sample_rate: int = 96_000
    #: most channels of a recording
    max_channels: int = 16


DEFAULTS = Limits()
#: command-line options that raise a limit (the others are set by environment variable)
OPTIONS = {"max_duration": "--max-duration", "max_frames": "--max-frames",
           "max_text": "--max-text", "max_items": "--max-items",
           "max_export_seconds": "--max-export-seconds", "max_body": "--max-body"}
_UNITS = {"max_duration": "s", "max_export_seconds": "s", "max_fps": "fps",
          "max_text": "characters", "max_body": "bytes", "max_cache_mb": "MB",
          "max_frames": "frames", "max_depth": "levels", "max_nodes": "values",
          "max_aliases": "aliases", "max_items": "items", "max_workers": "workers",
          "max_exports": "exports", "max_texture_pixels": "pixels",
          "max_recording": "s", "max_sample_rate": "Hz", "max_channels": "channels"}
_override: Limits | None = None


class LimitError(ParameterError):
    """A request is over one of the :class:`Limits`; ``limit`` names it."""

    def __init__(self, message: str, limit: str):
        self.limit = limit
        super().__init__(message)


def env_name(limit: str) -> str:
    return "MIMIKA_" + limit.upper()


def how_to_raise(limit: str) -> str:
    opt = OPTIONS.get(limit)
    env = env_name(limit)
    return f"raise it with {opt} or {env}" if opt else f"raise it with {env}"


def _from_env() -> Limits:
    kw: dict[str, Any] = {}
    for f in fields(Limits):
        raw = os.environ.get(env_name(f.name))
        if raw is None or not raw.strip():
            continue
        kind = int if isinstance(getattr(DEFAULTS, f.name), int) else float
        try:
            v = kind(float(raw)) if kind is int else kind(raw)
        except (ValueError, OverflowError):
            v = None
        if v is None or not (math.isfinite(v) and v > 0):
            raise ParameterError(f"{env_name(f.name)}={raw!r} must be a positive number")
        kw[f.name] = v
    return replace(DEFAULTS, **kw) if kw else DEFAULTS


def current() -> Limits:
    """The limits in force: :func:`override`, else the environment, else :data:`DEFAULTS`."""
    return _override if _override is not None else _from_env()


@contextlib.contextmanager
def override(**values: float | None) -> Iterator[Limits]:
    """Raise or lower limits for the ``with`` block (process-wide); None values are ignored.

    >>> with override(max_duration=7200):
    ...     current().max_duration
    7200.0
    """
    global _override
    kw = {k: v for k, v in values.items() if v is not None}
    for k, v in kw.items():
        if k not in {f.name for f in fields(Limits)}:
            raise ParameterError(f"unknown limit {k!r}")
        if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
            raise ParameterError(f"{OPTIONS.get(k, k)}={v!r} must be a positive number")
    base = current()
    kw = {k: type(getattr(DEFAULTS, k))(v) for k, v in kw.items()}
    old, _override_new = _override, replace(base, **kw)
    _override = _override_new
    try:
        yield _override_new
    finally:
        _override = old


def fmt(v: float) -> str:
    """A number for messages: ``36 000``, ``12 801``, ``0.04``, ``1e+09``."""
    v = float(v)
    if abs(v) >= 1e9:
        return f"{v:.3g}"
    if abs(v) >= 100 or v.is_integer():
        return f"{v:,.0f}".replace(",", " ")
    return f"{v:.4g}"


def over(limit: str, text: str, lim: Limits | None = None) -> LimitError:
    """A :class:`LimitError` ``"{text}, over the limit of N unit (limit); raise it with …"``."""
    top = getattr(lim or current(), limit)
    unit = _UNITS.get(limit, "")
    return LimitError(f"{text}, over the limit of {fmt(top)} {unit} ({limit}); "
                      f"{how_to_raise(limit)}", limit)


# -- checks --------------------------------------------------------------------------------------
def check_fps(fps: float, what: str = "fps") -> float:
    """``fps`` as float; refuses non-positive, non-finite and over ``max_fps``."""
    try:
        f = float(fps)
    except (TypeError, ValueError):
        raise ParameterError(f"{what}={fps!r} must be a number of frames per second") from None
    if not (math.isfinite(f) and f > 0):
        raise ParameterError(f"{what}={fps!r} must be > 0")
    if f > current().max_fps:
        raise over("max_fps", f"{what}={fmt(f)}")
    return f


def check_frames(n: float, what: str = "the track") -> int:
    """Refuse more than ``max_frames`` frames (call before allocating them)."""
    if not n <= current().max_frames:
        raise over("max_frames", f"{what} needs {fmt(n)} frames")
    return int(n)


def check_duration(seconds: float, what: str = "the timeline") -> float:
    """Refuse a length over ``max_duration`` seconds (and NaN)."""
    s = float(seconds)
    if not s <= current().max_duration:
        raise over("max_duration", f"{what} is {fmt(s)} s long")
    return s


def check_timeline(duration: float, fps: float, what: str = "the timeline") -> int:
    """Duration, fps and the frame count ``ceil(duration·fps) + 1`` against the limits;
    returns that frame count."""
    f = check_fps(fps)
    d = check_duration(duration, what)
    return check_frames(max(1, math.ceil(d * f - 1e-9) + 1), f"{what} at {fmt(f)} fps")


def check_text(text: str | int, what: str = "the text") -> None:
    """Refuse text (or a length) over ``max_text`` characters."""
    n = text if isinstance(text, int) else len(text)
    if n > current().max_text:
        raise over("max_text", f"{what} has {fmt(n)} characters")


def speech_seconds(text: str, wpm: float) -> float:
    """A generous lower estimate of how long ``text`` takes to say at ``wpm`` words per
    minute (plus any SSML ``<break time=…>``), for refusing before synthesis."""
    words = len(text.split())
    secs = 0.8 * words * 60.0 / max(float(wpm), 80.0)
    for m in _BREAK_RE.finditer(text):
        with contextlib.suppress(ValueError, OverflowError):
            v = float(m.group(1))
            secs += v / 1000.0 if m.group(2) == "ms" else v
    return secs


_BREAK_RE = re.compile(r"""time\s*=\s*["']\s*([0-9.eE+]+)\s*(ms|s)?""")


def check_speech(text: str, wpm: float, what: str = "the text") -> None:
    """Refuse text over ``max_text`` or whose speech would last over ``max_duration``."""
    check_text(text, what)
    est = speech_seconds(text, wpm)
    if est > current().max_duration:
        raise over("max_duration", f"{what} would take about {fmt(est / 60)} min to say at "
                                   f"{fmt(wpm)} words per minute")


#: lowest sample rate that can hold speech (Hz): below it a recording is refused as broken
MIN_SAMPLE_RATE = 4000


def check_recording(seconds: float, sr: float, channels: int, what: str) -> None:
    """Refuse a recording, from what its header declares, before it is decoded: longer than
    ``max_recording``, a rate outside 4 kHz … ``max_sample_rate``, over ``max_channels``."""
    lim = current()
    if not sr >= MIN_SAMPLE_RATE:
        raise DataError(f"{what}: a sample rate of {fmt(sr)} Hz cannot hold speech (at least "
                        f"{fmt(MIN_SAMPLE_RATE)} Hz); the header is broken or the file is not "
                        "a recording — re-export it, e.g. 'ffmpeg -i IN -ar 16000 OUT.wav'")
    if sr > lim.max_sample_rate:
        raise over("max_sample_rate", f"{what} declares {fmt(sr)} Hz")
    if channels > lim.max_channels:
        raise over("max_channels", f"{what} declares {fmt(channels)} channels")
    if not seconds <= lim.max_recording:
        raise over("max_recording", f"{what} is {fmt(seconds)} s long")


def check_count(limit: str, n: int, what: str) -> None:
    """Refuse ``n`` over the integer limit ``limit`` (max_items, max_workers …)."""
    if n > getattr(current(), limit):
        raise over(limit, f"{what}={fmt(n)}")


# -- documents -----------------------------------------------------------------------------------
def _path(parts: list) -> str:
    out = ""
    for p in parts:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else str(p))
    return out or "(top)"


def check_json_tree(data: Any, *, lim: Limits | None = None) -> list[str]:
    """Problems (``"path: message"``) of parsed JSON/YAML-like ``data``: nesting over
    ``max_depth``, more than ``max_nodes`` values, integers beyond ``max_int``, NaN or
    infinite numbers. Iterative: safe on any depth. Returns at most 20 problems."""
    lim = lim or current()
    problems: list[str] = []
    stack: list[tuple[Any, list, int]] = [(data, [], 0)]
    nodes = 0
    while stack and len(problems) < 20:
        v, path, depth = stack.pop()
        nodes += 1
        if nodes > lim.max_nodes:
            problems.append(f"{_path(path)}: the document has over {fmt(lim.max_nodes)} values "
                            f"(max_nodes); {how_to_raise('max_nodes')}")
            break
        if isinstance(v, bool) or v is None or isinstance(v, str):
            continue
        if isinstance(v, _Bad):
            problems.append(f"{_path(path)}: {v.why}")
            continue
        if isinstance(v, int):
            if abs(v) > lim.max_int:
                digits = len(str(abs(v))) if v.bit_length() < 14000 else "thousands of"
                problems.append(f"{_path(path)}: a {digits}-digit integer is beyond the "
                                f"largest accepted, {lim.max_int} (max_int)")
            continue
        if isinstance(v, float):
            if not math.isfinite(v):
                problems.append(f"{_path(path)}: {v!r} is not a finite number")
            continue
        if isinstance(v, dict | list | tuple):
            if depth >= lim.max_depth:
                problems.append(f"{_path(path)}: nested deeper than {lim.max_depth} levels "
                                f"(max_depth); {how_to_raise('max_depth')}")
                continue
            items = v.items() if isinstance(v, dict) else enumerate(v)
            for k, x in reversed(list(items)):
                stack.append((x, [*path, k if isinstance(k, int | str) else repr(k)],
                              depth + 1))
    return problems


class _Bad:
    """A JSON value :func:`loads_json` refused (reported with its key path)."""

    def __init__(self, why: str):
        self.why = why


def loads_json(text: str | bytes, source: str = "<json>", *, check: bool = True) -> Any:
    """``json.loads`` that refuses what mimika cannot represent, as one :class:`DataError`
    naming ``source:line:col`` or the key path: NaN/Infinity, integers beyond ``max_int``
    (checked before conversion: no 4300-digit ``ValueError``), numbers that overflow to
    infinity, nesting over ``max_depth``, more than ``max_nodes`` values.

    ``check=False`` leaves the tree check to the caller (:func:`check_json_tree` reports
    every refused value with its key path)."""
    lim = current()
    digits = len(str(lim.max_int))

    def parse_int(s: str) -> int | _Bad:
        if len(s.lstrip("-")) > digits or abs(int(s)) > lim.max_int:
            n = len(s.lstrip("-"))
            return _Bad(f"a {n}-digit integer is beyond the largest accepted, {lim.max_int} "
                        "(max_int)")
        return int(s)

    def parse_float(s: str) -> float | _Bad:
        f = float(s)
        return f if math.isfinite(f) else _Bad(f"{s[:24]} is too large a number")

    def parse_constant(s: str) -> _Bad:
        return _Bad(f"{s} is not a number mimika accepts; write a finite number")

    if isinstance(text, bytes | bytearray):
        try:
            text = bytes(text).decode("utf-8-sig")
        except UnicodeDecodeError as e:
            raise DataError(f"{source}: not UTF-8 text (byte {e.start})") from None
    try:
        data = json.loads(text, parse_int=parse_int, parse_float=parse_float,
                          parse_constant=parse_constant)
    except json.JSONDecodeError as e:
        from mimika.io.hints import json_hint

        hint = json_hint(e)
        raise DataError(f"{source}:{e.lineno}:{e.colno}: invalid JSON: {e.msg}"
                        + (f"; {hint}" if hint else "")) from None
    except RecursionError:
        raise DataError(f"{source}: nested deeper than {lim.max_depth} levels (max_depth); "
                        f"{how_to_raise('max_depth')}") from None
    problems = check_json_tree(data, lim=lim) if check else []
    if problems:
        from mimika.io.jsonpos import where

        raise DataError(f"{where(text, source, problems[0])}: {problems[0]}")
    return data
