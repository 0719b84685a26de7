"""The expression library: named AU sets with timing (seed 002 §5.3).

Built-in entries (``knowledge/data/expressions.json``):

* ``neutral`` and the basic emotions as EMFACS prototypes: ``happiness``, ``sadness``,
  ``surprise``, ``fear``, ``anger``, ``disgust`` (+ ``contempt``);
* the seed's 12 data-derived templates (Table 6.2) under ``template/…``: ``template/surprise``
  (1+2) is a different expression from ``surprise`` (1+2+5B+26).

A name without a prefix that is not itself an entry resolves to ``template/<name>``, so
``astonishment`` finds ``template/astonishment``. User entries live in a JSON file
(``$MIMIKA_DATA_DIR/expressions.json``, default ``~/.local/share/mimika/expressions.json``);
they may shadow a built-in only when created with ``force=True``.
"""

from __future__ import annotations

import difflib
import json
import logging
import math
import os
import re
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field
from functools import lru_cache
from importlib import resources
from pathlib import Path
from typing import Any

from mimika.errors import DataError, ParameterError
from mimika.facs.catalogue import parse_au_values
from mimika.io.atomic import atomic_write, sweep_stale
from mimika.limits import loads_json

log = logging.getLogger(__name__)

TEMPLATE_PREFIX = "template/"
_NAME_RE = re.compile(r"^[a-z0-9][a-z0-9_\-]*(/[a-z0-9][a-z0-9_\-]*)?$")
_VERSION = 1


@dataclass(frozen=True)
class Expression:
    """A named facial expression.

    ``aus`` maps canonical AU codes to intensities in [0, 1]; times are in seconds:
    ``onset`` (rise), ``offset`` (decay) and ``duration`` (whole expression, onset + apex +
    offset).
    """

    name: str
    aus: dict[str, float]
    onset: float = 0.25
    duration: float = 1.0
    offset: float = 0.25
    description: str = ""
    source: str = "user"
    builtin: bool = field(default=False, compare=False)

    @property
    def apex(self) -> float:
        """Seconds at full intensity: ``duration − onset − offset`` (≥ 0)."""
        return max(0.0, self.duration - self.onset - self.offset)

    @property
    def kind(self) -> str:
        """The name without a ``template/`` prefix (what the knowledge base reasons about)."""
        return self.name.removeprefix(TEMPLATE_PREFIX)

    def scaled(self, intensity: float = 1.0) -> dict[str, float]:
        """AU intensities times ``intensity`` (in [0, 1])."""
        k = _valid_intensity(intensity)
        return {c: round(v * k, 6) for c, v in self.aus.items()}

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d.pop("builtin")
        return d


def _valid_intensity(intensity: float) -> float:
    k = float(intensity)
    if not 0.0 <= k <= 1.0:
        raise ParameterError(f"intensity={intensity!r} must be within [0, 1]")
    return k


def _from_dict(d: Mapping[str, Any], *, where: str, builtin: bool) -> Expression:
    if not isinstance(d, Mapping):
        raise DataError(f"{where}: must be an object with name, aus, onset, duration, offset")
    name = d.get("name")
    if not isinstance(name, str) or not name:
        raise DataError(f"{where}.name: must be a name like 'my-smile', not {name!r:.40}")
    aus = d.get("aus", {})
    if not isinstance(aus, Mapping | list):
        raise DataError(f"{where}.aus: must be an object like {{\"AU12\": 0.8}}")
    try:
        parsed = parse_au_values(aus)
    except (TypeError, ValueError) as e:  # ParameterError is a ValueError
        raise DataError(f"{where}.aus: {e}") from None
    times = []
    for k, default in (("onset", 0.25), ("duration", 1.0), ("offset", 0.25)):
        v = d.get(k, default)
        if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v) \
                or abs(v) > 3600:
            raise DataError(f"{where}.{k}: must be a number of seconds (0…3600), not {v!r:.40}")
        times.append(float(v))
    onset, duration, offset = times
    for k in ("description", "source"):
        if not isinstance(d.get(k, ""), str):
            raise DataError(f"{where}.{k}: must be text")
    _check_timing(onset, duration, offset, what=f"{where}: {name}")
    return Expression(name, parsed, onset, duration, offset, str(d.get("description", "")),
                      str(d.get("source", "user")), builtin)


def _check_timing(onset: float, duration: float, offset: float, *, what: str) -> None:
    if not duration > 0:
        raise ParameterError(f"{what}: duration={duration:g} s must be > 0")
    if onset < 0 or offset < 0 or onset + offset > duration + 1e-9:
        raise ParameterError(f"{what}: onset={onset:g} s and offset={offset:g} s must be ≥ 0 "
                             f"and fit into duration={duration:g} s")


@lru_cache(maxsize=1)
def _builtins() -> dict[str, Expression]:
    text = resources.files("mimika.knowledge").joinpath("data/expressions.json").read_text("utf-8")
    data = json.loads(text)
    return {e["name"]: _from_dict(e, where="expressions.json", builtin=True)
            for e in data["expressions"]}


def builtin_expressions() -> dict[str, Expression]:
    """Every built-in expression by name (basic emotions, then ``template/…``)."""
    return dict(_builtins())


def default_library_path() -> Path:
    """``$MIMIKA_DATA_DIR/expressions.json``, else ``$XDG_DATA_HOME/mimika/…``, else
    ``~/.local/share/mimika/expressions.json``."""
    d = os.environ.get("MIMIKA_DATA_DIR")
    if d:
        return Path(d) / "expressions.json"
    xdg = os.environ.get("XDG_DATA_HOME")
    base = Path(xdg) if xdg else Path.home() / ".local" / "share"
    return base / "mimika" / "expressions.json"


def atomic_write_text(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` atomically: a temp file in the same folder, then os.replace.

    On any failure the previous file is left untouched and the temp file is removed.
    """
    atomic_write(path, text)


class ExpressionLibrary:
    """Built-in expressions plus the user's own, stored in a JSON file.

    Parameters
    ----------
    path : the user library file (default :func:`default_library_path`); created on first save.
    """

    def __init__(self, path: str | Path | None = None):
        self.path = Path(path) if path is not None else default_library_path()
        self._user = self._load()

    def _load(self) -> dict[str, Expression]:
        sweep_stale(self.path)  # temp files of saves that were killed
        if not self.path.exists():
            return {}
        where = str(self.path)
        try:
            data = loads_json(self.path.read_bytes(), where)
        except (OSError, DataError) as e:
            raise DataError(f"cannot read expression library: {e}; fix or remove the "
                            "file") from None
        if not isinstance(data, dict) or not isinstance(data.get("expressions"), list):
            raise DataError(f"expression library {where!r} must be a JSON object with "
                            "an 'expressions' list")
        out: dict[str, Expression] = {}
        for i, e in enumerate(data["expressions"]):
            expr = _from_dict(e, where=f"{where}: expressions[{i}]", builtin=False)
            if not _NAME_RE.match(expr.name):
                raise DataError(f"{where}: expressions[{i}].name: {expr.name!r:.40} must be "
                                "lower-case letters, digits, '-' or '_'; fix or remove the entry")
            out[expr.name] = expr
        return out

    # -- queries ----------------------------------------------------------------------------
    def names(self) -> list[str]:
        """All names: built-ins (file order) then user entries (sorted); shadowed names once."""
        b = list(_builtins())
        return b + sorted(n for n in self._user if n not in b)

    def list(self) -> list[Expression]:
        """Every expression visible under its name (a forced user entry replaces a built-in)."""
        return [self.get(n) for n in self.names()]

    def user_names(self) -> list[str]:
        return sorted(self._user)

    def resolve(self, name: str) -> str:
        """The full name ``name`` refers to (``astonishment`` → ``template/astonishment``)."""
        key = name.strip().lower().replace(" ", "-")
        pool = {**_builtins(), **self._user}
        if key in pool:
            return key
        if TEMPLATE_PREFIX + key in pool:
            return TEMPLATE_PREFIX + key
        close = difflib.get_close_matches(key, [*pool, *(n.removeprefix(TEMPLATE_PREFIX)
                                                        for n in pool)], n=3, cutoff=0.6)
        hint = f"; did you mean {', '.join(dict.fromkeys(close))}?" if close else ""
        raise ParameterError(f"unknown expression {name!r}{hint} "
                             "(run 'mimika expressions list' for all names)")

    def get(self, name: str) -> Expression:
        """The expression called ``name`` (user entries first, then built-ins)."""
        full = self.resolve(name)
        return self._user.get(full) or _builtins()[full]

    def __contains__(self, name: str) -> bool:
        try:
            self.resolve(name)
        except ParameterError:
            return False
        return True

    # -- edits -------------------------------------------------------------------------------
    def create(
        self,
        name: str,
        aus: Mapping[str, float | str],
        *,
        onset: float = 0.25,
        duration: float = 1.0,
        offset: float = 0.25,
        description: str = "",
        force: bool = False,
        save: bool = True,
    ) -> Expression:
        """Add (or with ``force`` replace) a user expression and save the library atomically.

        Raises :class:`ParameterError` if the name is malformed, would shadow a built-in
        (``astonishment`` shadows ``template/astonishment``) or exists, unless ``force``.
        """
        key = name.strip().lower().replace(" ", "-")
        if not _NAME_RE.match(key) or key.startswith(TEMPLATE_PREFIX):
            raise ParameterError(f"expression name {name!r} must be lower-case letters, digits, "
                                 "'-' or '_' (optionally 'group/name'), not starting with "
                                 "'template/'")
        parsed = parse_au_values(aus)
        if not parsed:
            raise ParameterError(f"expression {key!r} needs at least one AU (e.g. --au AU12=0.8)")
        _check_timing(onset, duration, offset, what=f"expression {key!r}")
        builtin = _builtins()
        clash = key if key in builtin else (TEMPLATE_PREFIX + key
                                            if TEMPLATE_PREFIX + key in builtin else None)
        if not force:
            if clash:
                raise ParameterError(f"expression {key!r} would shadow the built-in {clash!r}; "
                                     "choose another name or use --force")
            if key in self._user:
                raise ParameterError(f"expression {key!r} already exists in {self.path}; use "
                                     "--force to replace it")
        if clash:
            log.warning("user expression %r shadows built-in %r", key, clash)
        expr = Expression(key, parsed, float(onset), float(duration), float(offset),
                          description, "user")
        self._user[key] = expr
        if save:
            self.save()
        return expr

    def delete(self, name: str) -> None:
        """Remove a user expression (built-ins cannot be deleted) and save."""
        key = name.strip().lower().replace(" ", "-")
        if key not in self._user:
            if key in self or key in _builtins():
                raise ParameterError(f"{self.resolve(key)!r} is a built-in expression and cannot "
                                     "be deleted")
            self.resolve(key)  # raises with suggestions
        del self._user[key]
        self.save()

    def save(self) -> None:
        """Write the user entries to :attr:`path` atomically (temp file + os.replace)."""
        data = {"version": _VERSION,
                "expressions": [self._user[n].to_dict() for n in sorted(self._user)]}
        atomic_write_text(self.path, json.dumps(data, indent=2, ensure_ascii=False) + "\n")
        log.info("saved %d user expression(s) to %s", len(self._user), self.path)


def get_expression(name: str, intensity: float = 1.0, *,
                   library: ExpressionLibrary | None = None) -> dict[str, float]:
    """AU intensities of expression ``name`` scaled by ``intensity`` ∈ [0, 1].

    Unknown names raise :class:`ParameterError` with the closest names.

    >>> get_expression("happiness", 0.5)
    {'AU06': 0.5, 'AU12': 0.5, 'AU25': 0.3}
    """
    lib = library if library is not None else _library_or_builtins()
    return lib.get(name).scaled(intensity)


def expression_aus(name: str, intensity: float = 1.0) -> dict[str, float]:
    """For ``mimika pose --expression NAME --intensity K``: the scaled AUs of ``name``."""
    return get_expression(name, intensity)


def _library_or_builtins() -> ExpressionLibrary:
    return ExpressionLibrary()
