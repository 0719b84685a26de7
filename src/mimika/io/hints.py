"""How to fix a JSON or YAML syntax error: a few words after the parser's own, so that one
line says what is wrong, where, and what to do (``file:line:col: invalid JSON: …; hint``)."""

from __future__ import annotations

import json
from typing import Any

_JSON = {
    "Expecting property name enclosed in double quotes": "put every key in double quotes",
    "Expecting ',' delimiter": "a ',' is missing between two items",
    "Expecting ':' delimiter": "write ':' between a key and its value",
    "Expecting value": ("a value is missing here: strings go in double quotes, true, false and "
                        "null in lower case"),
    "Extra data": "the document ends before this point; remove what follows",
    "Unterminated string starting at": "close the string with '\"'",
    "Invalid control character at": "write a line break or tab inside a string as \\n or \\t",
    "Invalid \\escape": "write a backslash inside a string as \\\\",
}


def json_hint(e: json.JSONDecodeError) -> str:
    """What to do about ``e`` (empty when there is nothing useful to say)."""
    before = e.doc[:e.pos].rstrip()
    if e.msg in ("Expecting property name enclosed in double quotes", "Expecting value") \
            and before.endswith(",") and e.doc[e.pos:e.pos + 1] in ("}", "]"):
        return "remove the ',' before it (JSON allows none after the last item)"
    if e.msg == "Expecting value" and not e.doc.strip():
        return "the file is empty"
    return _JSON.get(e.msg, "")


_YAML = {
    "mapping values are not allowed here": ("put quotes around a value that holds ': ', or "
                                            "check the line's indentation"),
    "could not find expected ':'": "write ': ' after the key, or quote the value",
    "found character '\\t' that cannot start any token": "indent with spaces, not tabs",
    "found undefined alias": "define the anchor (&name) before its alias (*name)",
}


def yaml_hint(e: Any) -> str:
    """What to do about PyYAML's error ``e`` (empty when there is nothing useful to say)."""
    problem = str(getattr(e, "problem", "") or "")
    context = str(getattr(e, "context", "") or "")
    mark = getattr(e, "context_mark", None)
    at = f" at {mark.line + 1}:{mark.column + 1}" if mark is not None else ""
    if problem.startswith("found undefined alias"):
        return _YAML["found undefined alias"]
    if problem in _YAML:
        return _YAML[problem]
    if "flow sequence" in context:
        return f"close the '['{at} with ']' (and separate its items with ',')"
    if "flow mapping" in context:
        return f"close the '{{'{at} with '}}' (and separate its items with ',')"
    if "quoted scalar" in context:
        return f"close the quote{at}"
    if problem.startswith("expected <block end>"):
        return "indent the line like the other keys or items of its block"
    return ""
