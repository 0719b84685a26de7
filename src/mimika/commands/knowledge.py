"""``mimika blend``, ``mimika expressions`` and ``mimika check``: AU Blender, expression library
and knowledge base on the command line."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from mimika.errors import DataError, ParameterError
from mimika.limits import loads_json


def _fmt(v: float) -> str:
    return f"{v:.3f}".rstrip("0").rstrip(".") if v else "0"


# -- blend ------------------------------------------------------------------------------------
def cmd_blend(args: argparse.Namespace) -> int:
    from mimika.facs import parse_au_values
    from mimika.facs.blender import Blender

    blender = Blender.from_file(args.rules) if args.rules else Blender.default()
    if args.list_rules:
        if args.json:
            print(json.dumps([{"rule": r.notation, "kind": r.kind} for r in blender.rules],
                             indent=2))
        else:
            for r in blender.rules:
                print(f"{r.notation:<10} {r.kind}")
        return 0
    if not args.au:
        raise ParameterError("give AU values with --au, e.g. --au AU06=1 --au AU07=0.8")
    res = blender.blend(parse_au_values(args.au), disabled=args.disable or ())
    if args.json:
        print(json.dumps(res.to_dict(), indent=2, ensure_ascii=False))
        return 0
    for code, v in res.aus.items():
        print(f"{code:<6} {_fmt(v)}")
    if res.trace:
        print("trace:")
        for t in res.trace:
            ins = " ".join(f"{c}={_fmt(v)}" for c, v in t.inputs.items())
            outs = " ".join(f"{c}={_fmt(v)}" for c, v in t.outputs.items())
            print(f"  {t.rule:<9} {ins}  ->  {outs}")
    else:
        print("trace: no rule changed anything")
    return 0


# -- expressions ------------------------------------------------------------------------------
def cmd_expressions(args: argparse.Namespace) -> int:
    from mimika.facs import parse_au_values
    from mimika.knowledge.expressions import ExpressionLibrary

    lib = ExpressionLibrary(args.library)
    action = args.action or "list"
    if action == "list":
        exprs = lib.list()
        if args.json:
            print(json.dumps([e.to_dict() | {"builtin": e.builtin} for e in exprs], indent=2,
                             ensure_ascii=False))
            return 0
        for e in exprs:
            aus = " ".join(f"{c}={_fmt(v)}" for c, v in e.aus.items()) or "-"
            tag = "" if e.builtin else " (user)"
            print(f"{e.name:<26} {e.duration:>5.2f} s  {aus}{tag}")
        return 0
    if not args.name:
        raise ParameterError(f"'mimika expressions {action}' needs a NAME")
    if action == "show":
        e = lib.get(args.name)
        if args.json:
            print(json.dumps(e.to_dict() | {"builtin": e.builtin}, indent=2, ensure_ascii=False))
            return 0
        print(f"{e.name}{'' if e.builtin else ' (user)'}: {e.description}")
        for c, v in e.aus.items():
            print(f"  {c:<6} {_fmt(v)}")
        print(f"  onset {e.onset:g} s, apex {e.apex:g} s, offset {e.offset:g} s "
              f"(duration {e.duration:g} s)")
        print(f"  source: {e.source}")
        return 0
    if action == "create":
        if not args.au:
            raise ParameterError("'mimika expressions create' needs --au values, e.g. "
                                 "--au AU12=0.8")
        e = lib.create(args.name, parse_au_values(args.au), onset=args.onset,
                       duration=args.duration, offset=args.offset,
                       description=args.description or "", force=args.force)
        print(f"saved {e.name} to {lib.path}")
        return 0
    if action == "delete":
        lib.delete(args.name)
        print(f"deleted {args.name.lower()} from {lib.path}")
        return 0
    raise ParameterError(f"unknown action {action!r}")  # pragma: no cover - argparse choices


# -- check ------------------------------------------------------------------------------------
def _read_text(arg: str) -> str:
    p = Path(arg)
    if p.suffix.lower() in (".txt", ".md") or (len(arg) < 256 and "\n" not in arg and p.is_file()):
        try:
            return p.read_text("utf-8")
        except OSError as e:
            raise DataError(f"cannot read text file {arg!r}: {e.strerror}") from None
    return arg


def cmd_check(args: argparse.Namespace) -> int:
    from mimika.knowledge.expressions import ExpressionLibrary
    from mimika.knowledge.rules import check

    events = []
    if args.events:
        try:
            events = loads_json(Path(args.events).read_bytes(), args.events)
        except OSError as e:
            raise DataError(f"cannot read events file {args.events!r}: {e.strerror}") from None
        if isinstance(events, dict):
            events = events.get("events", [])
        if not isinstance(events, list):
            raise DataError(f"{args.events}: expected a list of events")
    text = _read_text(args.text) if args.text else None
    if text is None and not events:
        raise ParameterError("give a TEXT (or text file) and/or --events FILE")
    report = check(events, text=text, lang=args.lang, context=args.context, mood=args.mood,
                   role=args.role, rate=args.rate, dropped=args.drop or (),
                   library=ExpressionLibrary() if events else None)
    if args.json:
        print(json.dumps(report.to_dict(), indent=2, ensure_ascii=False))
        return 1 if report.errors else 0
    for c in report.constituents:
        print(f"[{c.start:6.2f}–{c.end:6.2f}] {c.text}")
    if report.words:
        print("emotional words:")
        for w in report.words:
            print(f"  {w['start']:6.2f} s  {w['word']:<16} {w['category']}")
    if report.suggestions:
        print("suggested expressions:")
        for s in report.suggestions:
            e = s.event
            print(f"  {e.start:6.2f}–{e.end:6.2f} s  {e.name:<24} {e.intensity:<4g} "
                  f"{s.rule}  [{s.id}]")
    other = [f for f in report.findings if f.level != "suggestion"
             or f.fix is None or "add" not in f.fix]
    if other:
        print("findings:")
        for f in other:
            at = f"{f.time:6.2f} s  " if f.time is not None else ""
            print(f"  {f.level:<10} {f.rule:<24} {at}{f.message}")
    if not report.findings:
        print("no findings")
    return 1 if report.errors else 0


def register(sub) -> None:
    b = sub.add_parser("blend", help="apply the FACS co-occurrence rules (AU Blender) to AUs")
    b.add_argument("--au", action="append", metavar="AU=VALUE",
                   help="an AU and its intensity in [0, 1] or A–E, e.g. AU06=1 (repeatable)")
    b.add_argument("--disable", action="append", metavar="RULE",
                   help="switch a rule off by its notation, e.g. '7<6' (repeatable)")
    b.add_argument("--rules", help="a rules file instead of the built-in Appendix C rules")
    b.add_argument("--list-rules", action="store_true", help="list the rules and exit")
    b.add_argument("--json", action="store_true", help="print {aus, trace} as JSON")
    b.set_defaults(func=cmd_blend)

    e = sub.add_parser("expressions", help="list, show, create or delete library expressions")
    e.add_argument("action", nargs="?", choices=("list", "show", "create", "delete"),
                   default="list")
    e.add_argument("name", nargs="?", help="expression name (show, create, delete)")
    e.add_argument("--au", action="append", metavar="AU=VALUE", help="AU values for create")
    e.add_argument("--onset", type=float, default=0.25, help="onset seconds (create)")
    e.add_argument("--duration", type=float, default=1.0, help="duration seconds (create)")
    e.add_argument("--offset", type=float, default=0.25, help="offset seconds (create)")
    e.add_argument("--description", help="a description (create)")
    e.add_argument("--force", action="store_true",
                   help="replace an existing user entry or shadow a built-in")
    e.add_argument("--library", help="user library file (default: $MIMIKA_DATA_DIR/"
                   "expressions.json or ~/.local/share/mimika/expressions.json)")
    e.add_argument("--json", action="store_true")
    e.set_defaults(func=cmd_expressions)

    c = sub.add_parser("check", help="knowledge-base defaults and warnings for a text and/or "
                       "timed expressions")
    c.add_argument("text", nargs="?", help="the text, or a .txt file holding it")
    c.add_argument("--events", help="JSON file: a list of {name, start, duration, intensity}")
    c.add_argument("--lang", default="en", choices=("en", "de", "pl"))
    c.add_argument("--context", default="conversation",
                   choices=("news", "narration", "conversation", "drama"),
                   help="sets the intensity of suggested expressions")
    c.add_argument("--mood", help="e.g. depressed, happy, confused, distracted")
    c.add_argument("--role", default="speaker", choices=("speaker", "listener"))
    c.add_argument("--rate", type=float, help="seconds per vowel unit (default 0.16)")
    c.add_argument("--drop", action="append", metavar="ID",
                   help="drop a suggestion by id or rule name (repeatable)")
    c.add_argument("--json", action="store_true")
    c.set_defaults(func=cmd_check)
