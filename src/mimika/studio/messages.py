"""Request errors in plain words: pydantic's validation errors without regexes or type names."""

from __future__ import annotations

import re
from collections.abc import Iterable
from typing import Any

#: how a request field is named in messages
FIELDS = {"name": "the name", "text": "the text", "aus": "the Action Units",
          "fps": "the frame rate", "rate": "the speaking rate", "lang": "the language",
          "z": "the latent sliders", "label": "the label", "project": "the project",
          "description": "the description", "duration": "the duration", "onset": "the onset",
          "offset": "the offset", "format": "the format", "head": "the head",
          "view": "the view", "look": "the look", "width": "the width", "height": "the height",
          "names": "the expression names", "tile": "the tile size",
          "columns": "the number of columns", "disabled": "the switched-off rules"}
#: what a pattern-checked field may contain
PATTERNS = {"name": "letters, digits, '-' and '_' (starting with a letter or digit)",
            "lang": "a language code such as en, de or pl"}


#: hints meant for the command line: "(run 'mimika aus' for the full list)", "use --force …"
_CLI_HINTS = (re.compile(r"\s*\((?:run|see) '[^']*'[^)]*\)"),
              re.compile(r"[;,]?\s*(?:or )?use --[\w-]+[^;.]*"),
              re.compile(r"\s*\(e\.g\. --[^)]*\)"))


#: a server path in a message: only its file name is shown
_PATH = re.compile(r"(?<![\w.])(?:[A-Za-z]:)?[/\\](?:[^\s'\"“”/\\]+[/\\])+([^\s'\"“”/\\;,]+)")


def plain(message: str) -> str:
    """``message`` without the command-line hints the library adds for the CLI, and with
    server paths cut to their file names."""
    for rx in _CLI_HINTS:
        message = rx.sub("", message)
    return _PATH.sub(r"\1", message).strip()


def _field(loc: Iterable[Any]) -> tuple[str, str]:
    parts = [str(x) for x in loc if x not in ("body", "query", "path")]
    key = next((p for p in parts if p in FIELDS), parts[0] if parts else "")
    return key, FIELDS.get(key, f"“{'.'.join(parts)}”" if parts else "the request")


def one(err: dict[str, Any]) -> str:
    """One pydantic error (``ValidationError.errors()`` item) as a sentence."""
    key, what = _field(err.get("loc", ()))
    kind = str(err.get("type", ""))
    ctx = err.get("ctx") or {}
    if kind == "string_pattern_mismatch":
        return f"{what} may only contain {PATTERNS.get(key, 'letters, digits, - and _')}"
    if kind == "string_too_long":
        return f"{what} is too long: at most {ctx.get('max_length')} characters"
    if kind in ("string_too_short", "too_short") and ctx.get("min_length") in (0, 1):
        return f"{what} is empty"
    if kind == "too_long":
        return f"{what} has too many entries: at most {ctx.get('max_length')}"
    if kind in ("greater_than_equal", "greater_than"):
        return f"{what} must be at least {ctx.get('ge', ctx.get('gt'))}"
    if kind in ("less_than_equal", "less_than"):
        return f"{what} must be at most {ctx.get('le', ctx.get('lt'))}"
    if kind == "literal_error":
        return f"{what} must be one of {ctx.get('expected', '…')}"
    if kind == "missing":
        return f"{what} is missing"
    if kind == "extra_forbidden":
        return f"{what} is not something this request takes"
    if kind == "value_error":
        return plain(str(err.get("msg", "")).removeprefix("Value error, "))
    if kind.endswith("_type") or kind.endswith("_parsing"):
        return f"{what} has the wrong kind of value"
    return f"{what}: {err.get('msg', 'invalid')}"


def validation_message(errors: list[dict[str, Any]]) -> str:
    """Up to five errors, one sentence each, joined with '; '."""
    out = list(dict.fromkeys(one(e) for e in errors[:5]))
    msg = "; ".join(out) or "the request is invalid"
    return "The" + msg[3:] if msg.startswith("the ") else msg
