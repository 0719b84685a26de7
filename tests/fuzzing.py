"""Fuzz targets for mimika's readers (issue 20), shared by ``tests/test_fuzz.py`` (a small,
time-bounded share in CI) and ``bench/fuzz.py`` (≥ 100 000 cases, ``make fuzz``).

Hypothesis draws a seed and a few choices; fast generators expand them into input — random
text, and structured input near each grammar with hostile values mixed in (huge and
5000-digit integers, NaN, infinity, deep nesting, control characters, YAML aliases and tags,
far-off times, swapped timecodes). The contract of every target: it returns, or raises a
:class:`~mimika.errors.MimikaError`; anything else is a crash, and a case running over
:data:`HANG_SECONDS` is a hang.
"""

from __future__ import annotations

import json
import random
import signal
import tempfile
from collections.abc import Callable
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from hypothesis import strategies as st

from mimika.errors import MimikaError

#: a case running longer than this (CPU seconds) is a hang
HANG_SECONDS = 10.0
R = random.Random

# -- building blocks -----------------------------------------------------------------------------
HUGE = ["1" + "0" * 400, "9" * 5000, "-" + "9" * 30, "1e999", "-1e999", "1e308", "2e-320",
        "NaN", "Infinity", "-Infinity", "0x1F", "1_000", "-0", "1e-400"]
TIMES = ["0", "0.5s", "300ms", "-2s", "+0.2s", "36000s", "1e7s", "1e999s", "nan", "inf", "",
         " 2 s", ".5", "1e-400s", "99999999999999999999s", "3599s", "1.5", "-0s"]
WORDS = ["happiness", "surprise", "template/fear", "neutral", "AU12", "AU12=0.8 AU06",
         "AU99", "left", "up-right", "both", "cosine", "linear", "learned", "face", "x-slow",
         "80%", "+10%", "true", "no", "3", "101", "0", "-1", "E", "en", "happy", "inf"]
ALPHABET = ("abcxyzABC012 ,.;:!?<>&\"'=/\\-_+*#[]{}()\n\t é€😀\u200b\ufeff"
            "\x00\x01\x07\x1b\x7f\ud7ff\ufffe")


def text(r: R, n: int = 12) -> str:
    return "".join(r.choice(ALPHABET) for _ in range(r.randint(0, n)))


def number(r: R) -> Any:
    return r.choice([r.random(), r.uniform(-1e3, 1e3), r.randint(-5, 5), 10 ** r.randint(15, 60),
                     -(10 ** r.randint(15, 40)), float("nan"), float("inf"), -float("inf"),
                     1e308, 0, 1, 0.5])


def scalar(r: R) -> Any:
    k = r.randint(0, 5)
    return [None, r.random() < 0.5, number(r), text(r), r.choice(WORDS), r.choice(TIMES)][k]


def json_value(r: R, depth: int = 3) -> Any:
    if depth <= 0 or r.random() < 0.5:
        return scalar(r)
    if r.random() < 0.5:
        return [json_value(r, depth - 1) for _ in range(r.randint(0, 4))]
    return {r.choice(KEYS) if r.random() < 0.7 else text(r, 6): json_value(r, depth - 1)
            for _ in range(r.randint(0, 4))}


def mutating(r: R) -> R:
    """Give the case a mutation rate: some cases are near-valid, some are anything."""
    r.mut = r.choice([0.0, 0.0, 0.02, 0.1, 0.3])  # type: ignore[attr-defined]
    return r


def bad(r: R) -> bool:
    """Whether to put something hostile here (at the case's mutation rate)."""
    return r.random() < getattr(r, "mut", 0.25)


def maybe(r: R, good: Any) -> Any:
    """``good`` (a value or a callable), or — at the mutation rate — anything."""
    if not bad(r):
        return good() if callable(good) else good
    return json_value(r, 2)


def deep(n: int, open_: str = "[", close: str = "]", inner: str = "") -> str:
    return open_ * n + inner + close * n


def seeded(gen: Callable[[R], Any]) -> st.SearchStrategy[Any]:
    """A hypothesis strategy of ``gen(Random(seed))`` for drawn seeds."""
    return st.integers(0, 2 ** 63).map(lambda s: gen(random.Random(s)))


# -- script --------------------------------------------------------------------------------------
ELEMENTS = ["p", "s", "break", "prosody", "mark", "sub", "say-as", "lang", "emphasis", "speak",
            "expr", "aus", "gaze", "tilt", "turn", "blink", "nod", "shake", "neutral", "channel",
            "settings", "mood", "m:expr", "m:aus", "m:nod", "x:bad", "foo"]
ATTRS = ["time", "strength", "rate", "name", "set", "dir", "count", "start", "end", "dur", "at",
         "intensity", "onset", "offset", "ease", "channel", "override", "bridge", "mood",
         "duration", "side", "alias", "xmlns", "xmlns:m", "pitch", "xml:lang"]


def _esc(s: str) -> str:
    return s.replace("&", "&amp;").replace("<", "&lt;").replace('"', "&quot;")


def _attr_value(r: R) -> str:
    if not bad(r):
        return r.choice(["1s", "300ms", "0.5", "happiness", "AU12=0.8 AU06", "left", "2", "fast",
                         "cosine", "face", "true", "+0.2s", "medium", "happy"])
    return str(r.choice([r.choice(TIMES), r.choice(WORDS), text(r, 6), r.choice(HUGE)]))


def _xml(r: R, depth: int) -> str:
    parts = []
    for _ in range(r.randint(0, 3)):
        if depth <= 0 or r.random() < 0.45:
            parts.append(r.choice(["Hello there. ", "Good evening! ", "Is it? ", "1,000,000 ",
                                   "&amp; "]) if not bad(r) else
                         r.choice(["&#0; ", "&bogus; ", _esc(text(r, 15))]))
            continue
        tag = r.choice(ELEMENTS)
        attrs = "".join(f' {a}="{_esc(_attr_value(r))}"'
                        for a in dict.fromkeys(r.choice(ATTRS) for _ in range(r.randint(0, 3))))
        inner = _xml(r, depth - 1)
        parts.append(f"<{tag}{attrs}/>" if not inner and r.random() < 0.5
                     else f"<{tag}{attrs}>{inner}</{tag}>")
    return "".join(parts)


def gen_script(r: R) -> str:
    mutating(r)
    k = r.random()
    if k < 0.6:
        return f"<speak>{_xml(r, 4)}</speak>" if r.random() < 0.8 else _xml(r, 4)
    if k < 0.7:
        s = f"<speak>{_xml(r, 3)}</speak>"  # a damaged document
        i = r.randint(0, len(s))
        return s[:i] + r.choice(["<", ">", "&", "</p>", "<!--", "\x00", "]]>", "\ud800"]) + s[i:]
    if k < 0.8:
        n = r.choice([10, 63, 65, 100, 3000])
        return "<speak>" + "<p>" * n + "x" + "</p>" * n + "</speak>"
    if k < 0.85:
        return "word " * r.choice([1, 1000, 40_000, 120_000])
    return text(r, 60)


def run_script(case: str) -> None:
    from mimika.markup import parse_script

    parse_script(case, source="fuzz.xml")


# -- project -------------------------------------------------------------------------------------
KEYS = ["format", "version", "settings", "timeline", "head", "fps", "view", "lang", "blend",
        "size", "rate", "mood", "duration", "speech", "channels", "name", "override", "ease",
        "bridge", "events", "kind", "start", "aus", "intensity", "onset", "offset", "count",
        "anchor", "at", "tokens", "attrs", "text", "open", "close", "empty"]
KINDS = ["expression", "aus", "gaze", "tilt", "turn", "blink", "nod", "shake", "bogus"]


def _time(r: R, lo: float = 0.0, hi: float = 30.0) -> Any:
    if not bad(r):
        return round(r.uniform(lo, hi), 3)
    return r.choice([0, 1e7, 36000, 3599.9, 1e308, -1, 10 ** 30, r.randint(0, 5000)])


_GOOD = {"expression": ["happiness", "surprise", "template/fear", "neutral", "sadness"],
         "gaze": ["left", "up-right", "ahead"], "tilt": ["left", "none"],
         "turn": ["right", "down"], "blink": ["both", "left"], "aus": [""], "nod": [""],
         "shake": [""]}


def _event(r: R, start: float) -> dict:
    kind = r.choice(KINDS[:-1]) if not bad(r) else r.choice([*KINDS, text(r, 5)])
    dur = _time(r, 0.1, 3.0)
    e: dict = {"kind": kind, "start": maybe(r, start), "duration": dur}
    if kind in _GOOD and _GOOD[kind] != [""]:
        e["name"] = maybe(r, lambda: r.choice(_GOOD[kind]))
    if kind == "aus" or bad(r):
        e["aus"] = maybe(r, lambda: [[c, round(r.random(), 3)] for c in
                                     r.sample(["AU01", "AU06", "AU12", "AU12L", "AU26"],
                                              r.randint(1, 3))])
    for key, good in (("intensity", lambda: round(r.random(), 3)),
                      ("onset", lambda: 0.1), ("offset", lambda: 0.1),
                      ("count", lambda: r.randint(1, 4)),
                      ("ease", lambda: r.choice(["cosine", "linear"])),
                      ("at", lambda: _time(r, -0.5, 0.5)),
                      ("anchor", lambda: sorted(r.randint(0, 5) for _ in range(2)))):
        if r.random() < 0.2:
            e[key] = maybe(r, good)
    if bad(r):
        e.pop(r.choice(list(e)))
    return e


def gen_project_data(r: R) -> Any:
    mutating(r)
    if r.random() < 0.05:
        return json_value(r, 4)
    tokens = [{"text": "Hello there. "}, {"open": "p", "attrs": []}, {"text": "Good news! "},
              {"empty": "break", "attrs": [["time", "300ms"]]}, {"close": "p"}]
    tokens = tokens[:r.choice([0, 1, 3, 5])] if not bad(r) else [
        r.choice([{"text": text(r, 10)}, {"open": r.choice(ELEMENTS)},
                  {"close": r.choice(ELEMENTS)}, json_value(r, 2),
                  {"empty": "break", "attrs": [["time", r.choice(TIMES)]]}])
        for _ in range(r.randint(0, 4))]
    if len(tokens) in (2, 3) and not bad(r):
        tokens.append({"close": "p"})
    channels = [{"name": maybe(r, name), "events": maybe(r, lambda: [
                     _event(r, 4.0 * i) for i in range(r.randint(0, 3))]),
                 "bridge": maybe(r, lambda: r.choice([None, 0.5]))}
                for name in r.sample(["face", "head", "gaze", "extra"], r.randint(0, 3))]
    timeline = {"rate": maybe(r, lambda: r.uniform(0.01, 1)),
                "mood": maybe(r, lambda: r.choice([None, "happy"])),
                "duration": maybe(r, lambda: r.choice([None, _time(r, 20, 40)])),
                "speech": maybe(r, {"attrs": [], "tokens": tokens}),
                "channels": maybe(r, channels)}
    settings = {"head": maybe(r, "builtin"),
                "fps": maybe(r, lambda: r.choice([25, 30.0, 60, 1000])),
                "view": maybe(r, "front"), "lang": maybe(r, lambda: r.choice(["en", "de"])),
                "blend": maybe(r, False), "size": maybe(r, [640, 480])}
    doc = {"format": maybe(r, "mimika-project"), "version": maybe(r, 1),
           "settings": maybe(r, {k: v for k, v in settings.items() if r.random() < 0.5}),
           "timeline": maybe(r, {k: v for k, v in timeline.items() if r.random() < 0.7})}
    return {k: v for k, v in doc.items() if not bad(r)}


def gen_project_text(r: R) -> str:
    t = json.dumps(gen_project_data(r), allow_nan=True)
    k = r.random()
    if k < 0.3:  # a hostile literal spliced in
        i = r.randint(0, len(t))
        return t[:i] + r.choice([*HUGE, deep(r.choice([70, 2000, 50_000])), '"\\ud800"']) + t[i:]
    if k < 0.35:
        return t.replace("{}", deep(r.choice([65, 20_000]), "{\"a\":", "}", "1"), 1)
    if k < 0.4:
        return text(r, 80)
    return t


def gen_project(r: R) -> tuple[str, Any]:
    return ("text", gen_project_text(r)) if r.random() < 0.5 else ("data", gen_project_data(r))


def run_project(case: tuple[str, Any]) -> None:
    from mimika.limits import loads_json
    from mimika.markup.project import project_from_dict, project_to_dict, save_project

    kind, value = case
    data = loads_json(value, "fuzz.json", check=False) if kind == "text" else value
    proj = project_from_dict(data, source="fuzz.json")
    assert project_from_dict(project_to_dict(proj)) == proj  # what loads round-trips
    with _scratch() as d:  # and saves
        save_project(proj, d / "p.json")


# -- batch spec ----------------------------------------------------------------------------------
TOP = ["name", "aus", "expressions", "intensities", "neutral", "sample", "heads", "identities",
       "views", "size", "samples", "blend", "disabled_rules", "seed", "animation", "bogus"]
YAML_SNIPPETS = [
    "aus: [[AU12]]", "aus: modelled", "aus: seed", "expressions: [happiness, sadness]",
    "intensities: [0.5, 1, E]", "neutral: true", "neutral: !!int", "neutral: !!int 1.0",
    "neutral: !!timestamp x", "neutral: !!foo x", "seed: !!float nan", "seed: .inf",
    "sample: {count: 3, max_aus: 2}", "sample: {count: 100000000000}", "views: [front, side]",
    "size: 320x240", "size: [1" + "0" * 30 + ", 2]", "seed: " + "9" * 5000,
    "animation: {fps: 1e999, onset: 0.2}", "animation: true", "heads: [builtin, ict]",
    "heads: [/nonexistent/head.obj]", "identities: [0, 3]", "disabled_rules: [7<6]",
    "a: &a [x, x, x, x]\nb: &b [*a, *a, *a, *a]\nc: [*b, *b, *b, *b]", "x: &x {y: *x}",
    "? [complex, key]\n: 1", "aus: " + deep(100), "aus: " + deep(5000), "- just\n- a list",
    "%YAML 1.1\n---\naus: [[AU12]]", "aus: [[AU12]]\n---\nneutral: true",
    "aus: [[AU12]]\naus: [[AU01]]", "'unterminated", "\t- tab", "<<: *undefined",
    "sample: {count: 5, pool: [AU01, AU02], max_aus: 3}", "intensities: [2, -1, .nan]",
    "aus: [AU06+AU12, {AU06: 1, AU07: 0.8}, AU07=0.8]", "seed: -1", "samples: 3",
    "size: [15, 9000]", "animation: {format: mp4}\nsize: [321, 240]",
]


#: near-valid specs: one line per key, each valid on its own
GOOD_SPEC = {
    "aus": ["aus: [[AU12]]", "aus: seed", "aus: [AU06+AU12, {AU06: 1, AU07: 0.8}, AU07=0.8]",
            "aus: [[AU01, AU02], [AU04]]"],
    "expressions": ["expressions: [happiness, sadness]", "expressions: surprise"],
    "intensities": ["intensities: [0.5, 1, E]", "intensities: 0.4"],
    "neutral": ["neutral: true", "neutral: false"],
    "sample": ["sample: {count: 3, max_aus: 2}", "sample: 4",
               "sample: {count: 5, pool: [AU01, AU02, AU12], max_aus: 3, levels: [0.4, 1]}"],
    "views": ["views: [front, profile]", "views: three-quarter"],
    "size": ["size: 320x240", "size: [64, 48]"], "samples": ["samples: 0", "samples: 4"],
    "blend": ["blend: false"], "seed": ["seed: 7"], "name": ["name: set one"],
    "disabled_rules": ["disabled_rules: [7<6]"],
    "animation": ["animation: true", "animation: {fps: 12, onset: 0.2, format: strip}"],
}


def gen_spec(r: R) -> str:
    k = r.random()
    if k < 0.3:
        keys = ["aus", *r.sample(sorted(GOOD_SPEC), r.randint(0, 5))]
        lines = [r.choice(GOOD_SPEC[key]) for key in dict.fromkeys(keys)]
        if r.random() < 0.5:  # one line damaged or hostile
            i = r.randrange(len(lines))
            key = lines[i].split(":")[0]
            lines[i] = r.choice([f"{key}: {r.choice(HUGE)}", f"{key}: {deep(70)}",
                                 f"{key}: !!int x", f"{key}: *nope", f"{key}: [{text(r, 4)}]",
                                 lines[i] + chr(r.randint(0, 31)), f"{key}: .nan"])
        return "\n".join(lines)
    if k < 0.6:
        lines = [r.choice(YAML_SNIPPETS) for _ in range(r.randint(1, 5))]
        if r.random() < 0.2:
            lines.insert(r.randint(0, len(lines)), chr(r.randint(0, 31)))
        return "\n".join(lines)
    if k < 0.8:
        import yaml

        return yaml.safe_dump({r.choice(TOP): json_value(r, 3) for _ in range(r.randint(0, 5))},
                              allow_unicode=True)
    if k < 0.9:
        n, w = r.randint(2, 12), r.randint(2, 12)
        return "\n".join(["l0: &l0 [lol]"] + [f"l{i}: &l{i} [{', '.join([f'*l{i - 1}'] * w)}]"
                                              for i in range(1, n)])
    return text(r, 80)


def run_spec(case: str) -> None:
    from mimika.batch.spec import SpecError, parse_spec
    from mimika.io.yamlsafe import read_yaml

    data, lines = read_yaml(case, "fuzz.yaml", error=SpecError)
    parse_spec(data, source="fuzz.yaml", lines=lines)


# -- expression library --------------------------------------------------------------------------
def gen_library(r: R) -> str:
    mutating(r)
    if r.random() < 0.15:
        return gen_project_text(r) if r.random() < 0.5 else text(r, 60)
    entries = []
    for i in range(r.randint(0, 4)):
        e = {"name": maybe(r, f"my-smile-{i}") if not bad(r) else
             r.choice(["a/b", "Bad Name", "", "template/x", "happiness", 5, None]),
             "aus": maybe(r, lambda: {c: round(r.random(), 2) for c in
                                      r.sample(["AU06", "AU12", "au1", "AU12L"], 2)}),
             "onset": maybe(r, 0.2), "duration": maybe(r, lambda: r.uniform(0.5, 5)),
             "offset": maybe(r, 0.2), "description": maybe(r, "")}
        entries.append({k: v for k, v in e.items() if not bad(r)})
    return json.dumps({"version": maybe(r, 1), "expressions": maybe(r, entries)}, allow_nan=True)


def run_library(case: str) -> None:
    from mimika.knowledge.expressions import ExpressionLibrary

    with _scratch() as d:
        p = d / "expressions.json"
        p.write_text(case, "utf-8", errors="surrogatepass")
        lib = ExpressionLibrary(p)
        for name in lib.user_names():
            lib.get(name).scaled(0.5)
        lib.names()


# -- CSV readers ---------------------------------------------------------------------------------
def _cell(r: R) -> str:
    k = r.random()
    if k < 0.5:
        return repr(r.random())
    if k < 0.6:
        return f"{r.uniform(0, 5):.2f}"
    return str(r.choice([r.choice(HUGE), "", " ", "nan", '"', "0", "1", "-0.1", "5.01",
                         text(r, 5)]))


PYFEAT = ["FaceRectX", "FaceRectY", "FaceRectWidth", "FaceRectHeight", "FaceScore", "Pitch",
          "Roll", "Yaw", "input", "frame", "approx_time"]


def _tc(seconds: int, frame: int, ms: int) -> str:
    h, m, sec = seconds // 3600 % 24, seconds // 60 % 60, seconds % 60
    return f"{h:02d}:{m:02d}:{sec:02d}:{frame:02d}.{ms:03d}"


def _timecode(r: R) -> str:
    if r.random() < 0.8:
        return _tc(r.randint(0, 86399), r.randint(0, 59), r.randint(0, 999))
    return r.choice(["99:00:00:00.000", "00:00:00:04", "00:00:00:00.000", "1:2:3:4",
                     "24:00:00:00.000", "00:00:00:" + "9" * 30, "x", ""])


def gen_csv(r: R) -> tuple[str, str | None]:
    from mimika.io.arkit import LIVELINK_COLUMNS

    fmt = r.choice(["au", "openface", "arkit", "pyfeat", "garbage"])
    if fmt == "garbage":
        return text(r, 200), r.choice([None, "au", "openface", "arkit", "pyfeat"])
    mutating(r)
    if fmt == "au":
        header = ["time", *dict.fromkeys(r.choice(["AU01", "AU12", "AU12L", "au6"]) if not bad(r)
                                          else r.choice(["AU99", "x", "", "AU12", "time"])
                                          for _ in range(r.randint(1, 4)))]
    elif fmt == "openface":
        header = ["frame", "face_id", "timestamp", "confidence", "success", *dict.fromkeys(
            r.choice(["AU01_r", "AU12_r", "AU45_c", "AU12_c"]) if not bad(r)
            else r.choice(["AU99_r", "AU1_r", "x"]) for _ in range(r.randint(1, 3)))]
        if bad(r):
            r.shuffle(header)
    elif fmt == "pyfeat":
        header = [*PYFEAT, *dict.fromkeys(r.choice(["AU01", "AU12", "AU43", "mouthSmileLeft",
                                                     "browDownLeft", "jawOpen", "eyeBlinkLeft",
                                                     "gaze_yaw", "AU99"]) for _ in range(4))]
    else:
        header = list(LIVELINK_COLUMNS)
    step = r.choice([1 / 30, 1 / 25, 1 / 60]) if not bad(r) else r.choice([0.0, -0.1, 1e6])
    rows, t = [], 0.0
    base = r.randint(0, 23 * 3600) if fmt == "arkit" else 0
    for i in range(r.randint(0, 12)):
        t += step if not bad(r) else r.choice([0.0, -0.1, 1e6, 1 / 30])
        row = []
        for h in header:
            if h == "Timecode":
                if not bad(r):  # increasing, every 2nd frame of 60
                    row.append(_tc(base + (2 * i) // 60, (2 * i) % 60, 0))
                else:
                    row.append(_timecode(r))
            elif h in ("time", "timestamp") and not bad(r):
                row.append(f"{t:.3f}")
            elif h == "approx_time" and not bad(r):
                row.append(f"00:{int(t) % 60:02d}")
            elif h == "input" and not bad(r):
                row.append("v.mp4")
            elif h in ("FaceRectWidth", "FaceRectHeight") and not bad(r):
                row.append("100")
            elif h in ("frame", "face_id", "success", "BlendShapeCount") and not bad(r):
                row.append({"frame": str(i + 1 if fmt != "pyfeat" else 2 * i), "face_id": "0",
                            "success": "1",
                            "BlendShapeCount": "61"}[h])
            elif not bad(r):
                row.append(f"{r.random():.3f}")
            else:
                row.append(_cell(r))
        if bad(r):
            row = row[:r.randint(0, len(row))]
        rows.append(",".join(row))
    if len(rows) > 1 and bad(r):  # rows out of order (issue 20: swapped timecodes)
        i, j = r.sample(range(len(rows)), 2)
        rows[i], rows[j] = rows[j], rows[i]
    return "\n".join([",".join(header), *rows]) + "\n", r.choice([None, None, fmt])


def run_csv(case: tuple[str, str | None]) -> None:
    from mimika.io.tracks import read_track

    body, fmt = case
    with _scratch() as d:
        p = d / "take.csv"
        p.write_text(body, "utf-8", errors="surrogatepass")
        read_track(p, format=fmt)


# -- running -------------------------------------------------------------------------------------
_SCRATCH: list[Path] = []


@contextmanager
def _scratch():
    """One scratch folder per process (in memory where /dev/shm exists), emptied after use."""
    if not _SCRATCH:
        import atexit
        import shutil

        shm = Path("/dev/shm")
        d = Path(tempfile.mkdtemp(prefix="mimika-fuzz-", dir=shm if shm.is_dir() else None))
        atexit.register(shutil.rmtree, d, True)
        _SCRATCH.append(d)
    d = _SCRATCH[0]
    try:
        yield d
    finally:
        for p in d.iterdir():
            p.unlink()


class Hang(BaseException):
    """A case ran over :data:`HANG_SECONDS` of CPU time or :data:`WALL_SECONDS` of wall time."""


#: a case blocked this long (wall time) is a hang too, whatever CPU it used
WALL_SECONDS = 6 * HANG_SECONDS


@contextmanager
def time_limit(seconds: float = HANG_SECONDS, wall: float = WALL_SECONDS):
    """Raise :class:`Hang` in the main thread after ``seconds`` of the process's CPU time (on
    a shared machine wall time stretches: a 0.8 s case took 10 s there) or ``wall`` seconds."""
    def ring(signum, frame):
        raise Hang(f"over {seconds:g} s of CPU" if signum == signal.SIGPROF else
                   f"over {wall:g} s")

    old = {sig: signal.signal(sig, ring) for sig in (signal.SIGPROF, signal.SIGALRM)}
    signal.setitimer(signal.ITIMER_PROF, seconds)
    signal.setitimer(signal.ITIMER_REAL, wall)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_PROF, 0)
        signal.setitimer(signal.ITIMER_REAL, 0)
        for sig, handler in old.items():
            signal.signal(sig, handler)


# -- character files -----------------------------------------------------------------------------
_CHAR_VALUES = ["0.5", "34", "-1", "1e999", ".nan", "!!int", "!!int 1.0", "!!float x", "true",
                "null", "[]", "{}", "'#zzzzzz'", "\"#74492f\"", "{african: 0.9, asian: 0}",
                "{african: 0}", "{martian: 1}", "{1: 2}", "[afro01]", "{style: nope}", "*undefined",
                "&a [*a]", "9" * 400, "1" + "0" * 5000, "~", "'" + "x" * 300 + "'"]


def gen_character(r: R) -> str:
    from mimika.face.makehuman.character_file import _preset_text, preset_names

    mutating(r)
    lines = _preset_text(r.choice(preset_names())).splitlines()
    for _ in range(r.randint(1, 4)):
        i = r.randrange(len(lines))
        key, sep, _ = lines[i].partition(":")
        k = r.random()
        if k < 0.5 and sep:
            lines[i] = f"{key}: {r.choice(_CHAR_VALUES)}"
        elif k < 0.65:
            lines.insert(i, r.choice(YAML_SNIPPETS))
        elif k < 0.75:
            lines[i] = f"{key}: " + deep(r.choice([10, 70, 3000]))
        elif k < 0.85:
            lines.insert(i, f"{r.choice(['1', 'true', '[a]', '~', text(r, 5)])}: 1")
        elif k < 0.9:
            lines[i] += chr(r.randint(0, 31))
        else:
            del lines[i]
        if not lines:
            break
    if r.random() < 0.05:
        rows = ["l0: &l0 [x, x, x, x, x, x, x, x, x]"]
        rows += [f"l{j}: &l{j} [" + ", ".join([f"*l{j - 1}"] * 9) + "]" for j in range(1, 9)]
        lines.append("description:\n  " + "\n  ".join(rows))
    return "\n".join(lines)


def run_character(case: str) -> None:
    from mimika.face.makehuman.character_file import _parse, character_from_dict

    character_from_dict(_parse(case, "fuzz.yaml"), "fuzz.yaml", "fuzz")


from fuzz_recordings import gen_recording, run_recording  # noqa: E402

#: name → (generator of one case from a Random, run)
TARGETS: dict[str, tuple[Callable[[R], Any], Callable[[Any], None]]] = {
    "script": (gen_script, run_script),
    "project": (gen_project, run_project),
    "batch spec": (gen_spec, run_spec),
    "library": (gen_library, run_library),
    "csv": (gen_csv, run_csv),
    "character": (gen_character, run_character),
    "recording": (gen_recording, run_recording),
}


def check(run: Callable[[Any], None], case: Any) -> str | None:
    """Run one case: None if it passed (returned or raised a MimikaError), else what broke."""
    try:
        with time_limit():
            run(case)
    except MimikaError:
        return None
    except Hang as e:
        return f"hang: {e}"
    except Exception as e:  # a crash
        return f"crash: {type(e).__name__}: {str(e)[:200]}"
    return None
