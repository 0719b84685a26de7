"""AU Blender: FACS co-occurrence rules as fuzzy logic (seed 002 §5.2, Appendix C).

The blender takes AU activations in [0, 1] and returns activations that respect the FACS
co-occurrence rules. Rules live in ``facs/data/rules.txt`` in the seed's own notation
(``7<6``, ``16<12+18``, ``10<12Z``, ``12@20``; opposition pairs under ``[opposition]``).

Fuzzy operators: ¬A = 1 − A, A ∧ B = min, A ∨ B = max. Semantics per rule kind:

==============  ===========  ==========================================
kind            notation     output
==============  ===========  ==========================================
domination      ``a<b``      [a] = min(1 − b, a)
combination     ``a<b+c``    [a] = min(1 − min(b, c), a)
strong          ``a<bZ``     [a] = min(1 − μ_z(b), a)
exclusion       ``a@b``      [b] = min(μ_x(a), b)
opposition      ``a@b``      [a] = max(0, a − b), [b] = max(0, b − a)
==============  ===========  ==========================================

Every rule reads the *input* activations (rules are not chained); several rules acting on one
AU combine with min. Rules are evaluated per side: ``AU12L`` and ``AU12R`` are blended
separately and a bilateral channel counts on both sides (sides are clipped sums, as in the rigs).

>>> from mimika.facs.blender import blend
>>> blend({"AU06": 1.0, "AU07": 0.8}).aus
{'AU06': 1.0, 'AU07': 0.0}
"""

from __future__ import annotations

import difflib
import logging
import re
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import lru_cache
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from mimika.errors import DataError, ParameterError
from mimika.facs.catalogue import AU_CATALOGUE, base_code, parse_au, parse_au_values, side_of

if TYPE_CHECKING:
    from mimika.tracks import AUTrack

log = logging.getLogger(__name__)

#: rule kinds, in the order Appendix C lists them
KINDS = ("domination", "combination", "strong", "exclusion", "opposition")
_EPS = 1e-6


# -- fuzzy sets -------------------------------------------------------------------------------
@dataclass(frozen=True)
class FuzzySet:
    """A trapezoidal fuzzy set over AU intensity.

    ``points = (a, b, c, d)``: membership rises linearly from 0 at ``a`` to 1 at ``b``, is 1 on
    [b, c] and falls to 0 at ``d``. ``a == b`` (or ``c == d``) makes a vertical edge that
    includes the end point, so ``(0, 0, 0.1, 0.4)`` has μ(0) = 1.
    """

    name: str  #: FACS intensity letter: x, y or z
    label: str  #: small, medium, high
    points: tuple[float, float, float, float]

    def __call__(self, v: np.ndarray | float) -> np.ndarray:
        """Membership of ``v`` (any shape, values in [0, 1]) → same shape, in [0, 1]."""
        a, b, c, d = self.points
        v = np.asarray(v, dtype=np.float64)
        with np.errstate(divide="ignore", invalid="ignore"):
            up = np.where(v >= b, 1.0, np.where(v <= a, 0.0, (v - a) / (b - a)))
            down = np.where(v <= c, 1.0, np.where(v >= d, 0.0, (d - v) / (d - c)))
        return np.minimum(up, down)


# -- rules ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Term:
    """One AU in a rule, optionally restricted to a fuzzy set (``12Z`` → ``AU12``, ``"z"``)."""

    au: str
    fuzzy: str | None = None

    def __str__(self) -> str:
        return f"{int(self.au[2:])}{(self.fuzzy or '').upper()}"


@dataclass(frozen=True)
class Rule:
    """A parsed co-occurrence rule.

    For domination kinds ``target`` is the suppressed AU and ``terms`` the dominators; for
    exclusion/opposition ``a@b`` the target is ``a`` and ``terms`` is ``(b,)``.
    """

    kind: str
    target: str
    terms: tuple[Term, ...]
    line: int = 0
    source: str = ""

    @property
    def notation(self) -> str:
        """Canonical text, e.g. ``16<12+18`` or ``51@52`` (how ``disabled`` names a rule)."""
        t = int(self.target[2:])
        if self.kind in ("exclusion", "opposition"):
            return f"{t}@{self.terms[0]}"
        return f"{t}<{'+'.join(str(x) for x in self.terms)}"

    def __str__(self) -> str:
        return self.notation

    @property
    def aus(self) -> tuple[str, ...]:
        """Every AU the rule reads (base codes)."""
        return (self.target, *(t.au for t in self.terms))

    @property
    def outputs(self) -> tuple[str, ...]:
        """The AUs the rule can lower."""
        if self.kind == "exclusion":
            return (self.terms[0].au,)
        if self.kind == "opposition":
            return (self.target, self.terms[0].au)
        return (self.target,)

    def apply(
        self, get: Callable[[str], np.ndarray], fuzzy: Mapping[str, FuzzySet]
    ) -> dict[str, np.ndarray]:
        """Proposed outputs ``{AU: activation}`` computed from the inputs ``get(AU)``."""
        def mu(t: Term) -> np.ndarray:
            return fuzzy[t.fuzzy](get(t.au)) if t.fuzzy else get(t.au)

        a = get(self.target)
        if self.kind == "exclusion":
            b = self.terms[0].au
            return {b: np.minimum(fuzzy["x"](a), get(b))}
        if self.kind == "opposition":
            b = get(self.terms[0].au)
            return {self.target: np.maximum(0.0, a - b), self.terms[0].au: np.maximum(0.0, b - a)}
        dom = mu(self.terms[0])
        for t in self.terms[1:]:
            dom = np.minimum(dom, mu(t))
        return {self.target: np.minimum(1.0 - dom, a)}


_TERM_RE = re.compile(r"^(?:AU)?0*(\d{1,2})([XYZ])?$", re.IGNORECASE)
_FUZZY_DEFAULT = (
    FuzzySet("x", "small", (0.0, 0.0, 0.1, 0.4)),
    FuzzySet("y", "medium", (0.1, 0.4, 0.6, 0.9)),
    FuzzySet("z", "high", (0.6, 0.9, 1.0, 1.0)),
)


def _term(text: str, where: str) -> Term:
    m = _TERM_RE.match(text)
    if not m:
        raise DataError(f"{where}: {text!r} is not an AU number (expected e.g. 12 or 12Z)")
    try:
        code = parse_au(m.group(1))
    except ParameterError as e:
        raise DataError(f"{where}: {e}") from None
    return Term(code, m.group(2).lower() if m.group(2) else None)


def parse_rule(text: str, *, section: str | None = None, where: str = "rule") -> Rule:
    """Parse one rule (``"7<6"``, ``"16<12+18"``, ``"10<12Z"``, ``"12@20"``).

    ``section`` (a :data:`KINDS` name or None) says which list the rule is in; ``a@b`` is an
    exclusion unless the section is ``opposition``. Raises :class:`DataError` naming ``where``.
    """
    s = re.sub(r"\s+", "", text)
    expect = "expected a<b, a<b+c, a<bZ or a@b"
    if s.count("<") == 1 and "@" not in s:
        left, right = s.split("<")
        target = _term(left, where)
        if not right or any(not p for p in right.split("+")):
            raise DataError(f"{where}: malformed rule {text.strip()!r}; {expect}")
        terms = tuple(_term(p, where) for p in right.split("+"))
        kind = "combination" if len(terms) > 1 else "strong" if terms[0].fuzzy else "domination"
    elif s.count("@") == 1 and "<" not in s:
        a, b = s.split("@")
        target, other = _term(a, where), _term(b, where)
        terms = (other,)
        kind = "opposition" if section == "opposition" else "exclusion"
        if other.fuzzy:
            raise DataError(f"{where}: {text.strip()!r}: {kind} rules take plain AU numbers")
    else:
        raise DataError(f"{where}: malformed rule {text.strip()!r}; {expect}")
    if target.fuzzy:
        raise DataError(f"{where}: {text.strip()!r}: the dominated AU takes no x/y/z suffix")
    if section is not None and section != kind:
        raise DataError(f"{where}: {text.strip()!r} is a {kind} rule but is listed under "
                        f"[{section}]")
    if any(t.fuzzy and t.fuzzy not in "xyz" for t in terms):  # pragma: no cover - regex
        raise DataError(f"{where}: unknown fuzzy set in {text.strip()!r}")
    if target.au in {t.au for t in terms}:
        raise DataError(f"{where}: {text.strip()!r} relates an AU to itself")
    return Rule(kind, target.au, terms)


def parse_rules(text: str, *, source: str = "<rules>") -> tuple[list[Rule], dict[str, FuzzySet]]:
    """Parse a rules file: ``[section]`` headers, one rule per line, ``#`` comments.

    Sections: ``[fuzzy]`` (``x small a b c d``), one per :data:`KINDS`, or none (kind inferred
    from the notation). Returns the rules and the fuzzy sets (defaults fill missing ones).
    Raises :class:`DataError` with ``source:line`` on any malformed line.
    """
    rules: list[Rule] = []
    fuzzy = {f.name: f for f in _FUZZY_DEFAULT}
    seen: dict[str, int] = {}
    section: str | None = None
    for n, raw in enumerate(text.splitlines(), start=1):
        line = raw.split("#", 1)[0].strip()
        where = f"{source}:{n}"
        if not line:
            continue
        m = re.fullmatch(r"\[\s*([a-z]+)\s*\]", line, re.IGNORECASE)
        if m:
            section = m.group(1).lower()
            if section not in (*KINDS, "fuzzy"):
                raise DataError(f"{where}: unknown section [{section}]; expected one of "
                                f"[fuzzy], {', '.join(f'[{k}]' for k in KINDS)}")
            continue
        if section == "fuzzy":
            fuzzy_set = _parse_fuzzy(line, where)
            fuzzy[fuzzy_set.name] = fuzzy_set
            continue
        rule = parse_rule(line, section=section, where=where)
        rule = Rule(rule.kind, rule.target, rule.terms, n, source)
        key = _key(rule)
        if key in seen:
            raise DataError(f"{where}: rule {rule.notation} repeats line {seen[key]}")
        seen[key] = n
        rules.append(rule)
    return rules, fuzzy


def _key(rule: Rule) -> str:
    if rule.kind == "opposition":  # 51@52 and 52@51 are the same rule
        a, b = sorted((rule.target, rule.terms[0].au))
        return f"{a}@{b}/o"
    return rule.notation


def _parse_fuzzy(line: str, where: str) -> FuzzySet:
    parts = line.split()
    if len(parts) != 6 or parts[0].lower() not in ("x", "y", "z"):
        raise DataError(f"{where}: fuzzy set line {line!r} must be 'NAME LABEL a b c d' with "
                        "NAME x, y or z")
    try:
        pts = tuple(float(p) for p in parts[2:])
    except ValueError:
        raise DataError(f"{where}: fuzzy set breakpoints {parts[2:]} must be numbers") from None
    if not all(0.0 <= p <= 1.0 for p in pts) or list(pts) != sorted(pts):
        raise DataError(f"{where}: fuzzy set breakpoints {pts} must be ascending within [0, 1]")
    return FuzzySet(parts[0].lower(), parts[1], pts)  # type: ignore[arg-type]


# -- results ----------------------------------------------------------------------------------
@dataclass(frozen=True)
class TraceEntry:
    """One rule that changed something: its notation, the inputs it read, what it proposed.

    Codes carry a side suffix (``AU07L``) when the rule acted differently on the two sides.
    """

    rule: str
    inputs: dict[str, float]
    outputs: dict[str, float]

    def to_dict(self) -> dict[str, Any]:
        return {"rule": self.rule, "inputs": dict(self.inputs), "outputs": dict(self.outputs)}


@dataclass(frozen=True)
class BlendResult:
    """Blended activations ``aus`` (canonical code → [0, 1]) and the ``trace`` of changes."""

    aus: dict[str, float]
    trace: list[TraceEntry] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        return {"aus": dict(self.aus), "trace": [t.to_dict() for t in self.trace]}


# -- the blender ------------------------------------------------------------------------------
class Blender:
    """Parsed co-occurrence rules and fuzzy sets; :meth:`blend` applies them.

    Parameters
    ----------
    rules : sequence of Rule
    fuzzy : mapping x/y/z → FuzzySet (defaults: see ``facs/data/rules.txt``)
    """

    def __init__(self, rules: Sequence[Rule], fuzzy: Mapping[str, FuzzySet] | None = None):
        self.rules: tuple[Rule, ...] = tuple(rules)
        self.fuzzy: dict[str, FuzzySet] = dict(fuzzy or {f.name: f for f in _FUZZY_DEFAULT})
        self._by_notation = {r.notation: r for r in self.rules}
        self._aliases = dict(self._by_notation)
        for r in self.rules:  # an opposition may be named either way round: 52@51 = 51@52
            if r.kind == "opposition":
                self._aliases.setdefault(f"{r.terms[0]}@{int(r.target[2:])}", r)

    @classmethod
    def from_text(cls, text: str, *, source: str = "<rules>") -> Blender:
        return cls(*parse_rules(text, source=source))

    @classmethod
    def from_file(cls, path: str | Path) -> Blender:
        """Load a rules file (same format as the built-in ``rules.txt``)."""
        p = Path(path)
        try:
            text = p.read_text("utf-8")
        except OSError as e:
            raise DataError(f"cannot read rules file {str(p)!r}: {e.strerror}") from None
        return cls.from_text(text, source=str(p))

    @classmethod
    def default(cls) -> Blender:
        """The Appendix C rules shipped with mimika (cached)."""
        return _default_blender()

    def __repr__(self) -> str:
        return f"Blender({len(self.rules)} rules)"

    def rule(self, notation: str) -> Rule:
        """The rule written ``notation`` (``"7<6"``, ``"AU07<AU06"``, ``"10<12z"``)."""
        return self._active([notation], invert=True)[0]

    def _active(self, disabled: Iterable[str], *, invert: bool = False) -> list[Rule]:
        if isinstance(disabled, str):
            disabled = [disabled]
        names: set[str] = set()
        for d in disabled:
            try:
                notation = parse_rule(str(d), where=f"rule {d!r}").notation
            except DataError:
                notation = str(d).strip()
            rule = self._aliases.get(notation)
            if rule is None:
                close = difflib.get_close_matches(notation, list(self._by_notation), n=3)
                hint = f"; did you mean {', '.join(close)}?" if close else ""
                raise ParameterError(f"no co-occurrence rule {str(d)!r}{hint} "
                                     "(run 'mimika blend --list-rules' for all rules)")
            names.add(rule.notation)
        if invert:
            return [self._by_notation[n] for n in names]
        return [r for r in self.rules if r.notation not in names]

    # -- arrays ---------------------------------------------------------------------------
    def _run(
        self, values: np.ndarray, channels: Sequence[str], rules: Sequence[Rule]
    ) -> tuple[np.ndarray, tuple[str, ...], dict[str, np.ndarray], list]:
        """Core: values (T, K) → (values', channels', per-side inputs, proposals)."""
        vals = np.asarray(values, dtype=np.float64)
        chans = [parse_au(c) for c in channels]
        n = vals.shape[0]
        # per-side effective activations (T, 2): clipped sums of bilateral + one-sided channels
        x: dict[str, np.ndarray] = {}
        for j, c in enumerate(chans):
            side = side_of(c)
            arr = x.setdefault(base_code(c), np.zeros((n, 2)))
            if side in (None, "L"):
                arr[:, 0] += vals[:, j]
            if side in (None, "R"):
                arr[:, 1] += vals[:, j]
        for arr in x.values():
            np.clip(arr, 0.0, 1.0, out=arr)
        zero = np.zeros((n, 2))

        def get(au: str) -> np.ndarray:
            return x.get(au, zero)

        out: dict[str, np.ndarray] = {}
        proposals: list[tuple[Rule, dict[str, np.ndarray]]] = []
        for r in rules:
            if not any(a in x for a in r.outputs):
                continue
            props = r.apply(get, self.fuzzy)
            proposals.append((r, props))
            for t, p in props.items():
                out[t] = np.minimum(out.get(t, get(t)), p)

        result = vals.copy()
        new_cols: list[tuple[str, np.ndarray]] = []
        for au, o in out.items():
            if au not in x:
                continue
            changed = np.any(o < x[au] - _EPS, axis=1)
            if not changed.any():
                continue
            idx = {side_of(c): j for j, c in enumerate(chans) if base_code(c) == au}
            o_min = o.min(axis=1)
            if not AU_CATALOGUE[au].sided:
                result[:, idx[None]] = np.where(changed, o_min, result[:, idx[None]])
                continue
            bil = o_min if None in idx else np.zeros(n)
            if None in idx:
                result[:, idx[None]] = np.where(changed, bil, result[:, idx[None]])
            for k, side in enumerate(("L", "R")):
                rest = np.maximum(o[:, k] - bil, 0.0)
                if side in idx:
                    result[:, idx[side]] = np.where(changed, rest, result[:, idx[side]])
                elif np.any(changed & (rest > _EPS)):
                    new_cols.append((au + side, np.where(changed, rest, 0.0)))
        if new_cols:
            result = np.concatenate([result, np.stack([c for _, c in new_cols], axis=1)], axis=1)
            chans += [name for name, _ in new_cols]
        return result, tuple(chans), x, proposals

    def blend_frames(
        self,
        values: np.ndarray,
        channels: Sequence[str],
        *,
        disabled: Iterable[str] = (),
        counts: dict[str, int] | None = None,
    ) -> tuple[np.ndarray, tuple[str, ...]]:
        """Blend every frame of an AU array.

        Parameters
        ----------
        values : ndarray, shape (n_frames, n_channels), in [0, 1]
        channels : AU codes naming the columns
        disabled : rule notations to switch off
        counts : if given, filled with ``{rule: number of frames it lowered an AU}``

        Returns
        -------
        values : ndarray, shape (n_frames, n_channels'), float32
        channels : the input channels, plus ``AUxxL``/``AUxxR`` where a bilateral AU had to be
            lowered on one side only (e.g. ``AU07`` under a one-sided ``AU06L``).
        """
        v = np.asarray(values, dtype=np.float64)
        if v.ndim != 2 or v.shape[1] != len(channels):
            raise ParameterError(f"values must have shape (n_frames, {len(channels)}), "
                                 f"got {v.shape}")
        if v.size and (not np.all(np.isfinite(v)) or v.min() < 0 or v.max() > 1):
            raise ParameterError("AU values must be finite and within [0, 1]")
        res, chans, x, proposals = self._run(v, channels, self._active(disabled))
        if counts is not None:
            for r, props in proposals:
                hit = np.zeros(v.shape[0], bool)
                for t, p in props.items():
                    hit |= np.any(p < x.get(t, 0.0) - _EPS, axis=1)
                if hit.any():
                    counts[r.notation] = counts.get(r.notation, 0) + int(hit.sum())
        return res.astype(np.float32), chans

    def blend(self, aus: Mapping[str, float], *, disabled: Iterable[str] = ()) -> BlendResult:
        """Blend one set of activations ``{code: value in [0, 1]}``.

        Returns the blended activations (same codes, plus one-sided codes where a bilateral AU
        is lowered on one side only) and a trace of the rules that lowered something.
        """
        parsed = parse_au_values(aus)
        chans = list(parsed)
        vals = np.array([[parsed[c] for c in chans]], dtype=np.float64).reshape(1, len(chans))
        res, out_chans, x, proposals = self._run(vals, chans, self._active(disabled))
        blended = {c: _r(res[0, j]) for j, c in enumerate(out_chans)}
        for c in chans:  # untouched channels keep their exact input value
            if _r(parsed[c]) == blended[c]:
                blended[c] = parsed[c]
        trace: list[TraceEntry] = []
        for r, props in proposals:
            changed = [np.any(p[0] < x.get(t, np.zeros((1, 2)))[0] - _EPS)
                       for t, p in props.items()]
            if not any(changed):
                continue
            zero = np.zeros(2)
            ins = {a: x[a][0] if a in x else zero for a in r.aus}
            symmetric = all(abs(v[0] - v[1]) < _EPS for v in ins.values()) and all(
                abs(p[0, 0] - p[0, 1]) < _EPS for p in props.values())
            sides = [(None, 0)] if symmetric else [("L", 0), ("R", 1)]
            for side, k in sides:
                if side and not any(p[0, k] < ins[t][k] - _EPS for t, p in props.items()):
                    continue

                def name(a: str, side: str | None = side) -> str:
                    return a + side if side and AU_CATALOGUE[a].sided else a

                trace.append(TraceEntry(
                    r.notation,
                    {name(a): _r(v[k]) for a, v in sorted(ins.items())},
                    {name(t): _r(p[0, k]) for t, p in props.items()},
                ))
        if trace:
            log.debug("blend: %d rule(s) changed %s", len(trace), ", ".join(t.rule for t in trace))
        return BlendResult(blended, trace)

    def blend_track(self, track: AUTrack, *, disabled: Iterable[str] = ()) -> AUTrack:
        """Blend every frame of ``track``; ``meta["blender"]`` records ``{rule: frames}``."""
        from mimika.tracks import AUTrack

        counts: dict[str, int] = {}
        vals, chans = self.blend_frames(track.values, track.channels, disabled=disabled,
                                        counts=counts)
        meta = dict(track.meta)
        meta["blender"] = counts
        return AUTrack(vals, chans, track.fps, meta)


def _r(v: float) -> float:
    return round(float(v), 6)


@lru_cache(maxsize=1)
def _default_blender() -> Blender:
    text = resources.files("mimika.facs").joinpath("data/rules.txt").read_text("utf-8")
    return Blender.from_text(text, source="rules.txt")


def default_rules() -> tuple[Rule, ...]:
    """The built-in Appendix C rules, in file order."""
    return Blender.default().rules


def blend(aus: Mapping[str, float], *, disabled: Iterable[str] = (),
          blender: Blender | None = None) -> BlendResult:
    """Blend ``aus`` with the built-in rules (or ``blender``). See :meth:`Blender.blend`."""
    return (blender or Blender.default()).blend(aus, disabled=disabled)


def blend_frames(values: np.ndarray, channels: Sequence[str], *, disabled: Iterable[str] = (),
                 blender: Blender | None = None) -> tuple[np.ndarray, tuple[str, ...]]:
    """Blend an AU array (T, K) with the built-in rules. See :meth:`Blender.blend_frames`."""
    return (blender or Blender.default()).blend_frames(values, channels, disabled=disabled)


def blend_track(track: AUTrack, *, disabled: Iterable[str] = (),
                blender: Blender | None = None) -> AUTrack:
    """Blend every frame of an :class:`~mimika.tracks.AUTrack`; returns a new track."""
    return (blender or Blender.default()).blend_track(track, disabled=disabled)
