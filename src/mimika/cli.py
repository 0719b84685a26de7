"""The ``mimika`` command line: thin commands over the library.

Every error a user can cause prints one line (``mimika: error: …``) and exits with code 2;
``--debug`` shows the traceback instead.
"""

from __future__ import annotations

import argparse
import difflib
import json
import sys
from collections.abc import Sequence

from mimika.errors import MimikaError, ParameterError

VIEWS = ("front", "three-quarter", "profile")


class _Parser(argparse.ArgumentParser):
    """argparse with 'did you mean' for commands and exit code 2 for usage errors."""

    def error(self, message: str) -> None:  # type: ignore[override]
        if "invalid choice" in message and self._subparsers is not None:
            bad = message.split("'")[1] if "'" in message else ""
            choices = [c for a in self._subparsers._group_actions for c in (a.choices or {})]
            close = difflib.get_close_matches(bad, choices, n=1)
            if close:
                message += f"; did you mean '{close[0]}'?"
        self.exit(2, f"mimika: error: {message}\n")


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(x) for x in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"size {text!r} must look like 640x480") from None
    if not (16 <= w <= 8192 and 16 <= h <= 8192):
        raise argparse.ArgumentTypeError(f"size {text!r}: width and height must be 16…8192")
    return w, h


def _progress(quiet: bool, label: str):
    if quiet or not sys.stderr.isatty():
        return None

    def report(done: int, total: int) -> None:
        bar = "#" * (30 * done // total)
        sys.stderr.write(f"\r{label} [{bar:<30}] {done}/{total}")
        if done == total:
            sys.stderr.write("\n")
        sys.stderr.flush()

    return report


# --- commands ----------------------------------------------------------------------------------


def cmd_aus(args: argparse.Namespace) -> int:
    from mimika.face.blendshape import load_table
    from mimika.face.field import load_fields
    from mimika.facs import AU_CATALOGUE

    builtin = set(load_fields().aus)
    ict = set(load_table()["aus"])
    rows = []
    for code, au in AU_CATALOGUE.items():
        if args.modelled and code not in builtin | ict:
            continue
        rows.append({
            "code": code, "name": au.name, "group": au.group, "objects": list(au.objects),
            "kind": au.kind, "subobject": au.subobject, "seed": au.seed,
            "sides": [code + "L", code + "R"] if au.sided else [],
            "builtin": code in builtin, "ict": code in ict,
        })
    if args.json:
        print(json.dumps(rows, indent=1))
        return 0
    print(f"{'code':<6}{'name':<26}{'group':<20}{'objects':<17}{'L/R':<5}"
          f"{'seed':<6}{'builtin':<9}ict")
    for r in rows:
        yes = {True: "yes", False: "-"}
        print(f"{r['code']:<6}{r['name']:<26}{r['group']:<20}{';'.join(r['objects']):<17}"
              f"{yes[bool(r['sides'])]:<5}{yes[r['seed']]:<6}{yes[r['builtin']]:<9}"
              f"{yes[r['ict']]}")
    n_b = sum(r["builtin"] for r in rows)
    n_i = sum(r["ict"] for r in rows)
    print(f"\n{len(rows)} AUs; modelled: builtin {n_b}, ict {n_i}. "
          "Unilateral variants: append L or R (AU12L). Input also accepts 12, au12, AU1.")
    return 0


def cmd_heads(args: argparse.Namespace) -> int:
    from mimika.face.heads import list_heads

    for h in list_heads():
        mark = "available" if h.available else "missing"
        print(f"{h.name:<8} {h.rig:<14} {mark:<10} {h.description}")
    return 0


def cmd_pose(args: argparse.Namespace) -> int:
    from mimika.face.heads import load_head
    from mimika.facs import parse_au_values
    from mimika.pose import au_sheet, render_pose
    from mimika.render import save_png

    if not args.output.lower().endswith(".png"):
        raise ParameterError(f"output {args.output!r} must be a .png file")
    if args.grid and args.au:
        raise ParameterError("--grid renders every AU; do not combine it with --au")
    aus = parse_au_values(args.au or [])
    _, rig = load_head(args.head, fields=args.fields)
    if args.grid:
        img = au_sheet(head=rig, view=args.view, columns=args.columns,
                       progress=_progress(args.quiet, "rendering AUs"))
    else:
        img = render_pose(aus, head=rig, view=args.view, size=args.size, samples=args.samples)
    save_png(img, args.output)
    if not args.quiet:
        print(f"wrote {args.output} ({img.shape[1]}x{img.shape[0]})")
    return 0


# --- parser ------------------------------------------------------------------------------------


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="mimika", description="Animate 3D faces with FACS Action Units.")
    p.add_argument("--debug", action="store_true", help="show tracebacks on errors")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)

    a = sub.add_parser("aus", help="list the FACS Action Units and which heads model them")
    a.add_argument("--modelled", action="store_true", help="only AUs some head models")
    a.add_argument("--json", action="store_true", help="machine-readable output")
    a.set_defaults(func=cmd_aus)

    h = sub.add_parser("heads", help="list the heads mimika can animate")
    h.set_defaults(func=cmd_heads)

    q = sub.add_parser("pose", help="render a still image of AU intensities (or --grid: all AUs)")
    q.add_argument("--au", action="append", metavar="AU=VALUE",
                   help="an AU and its intensity in [0, 1] or A–E, e.g. AU12=1 (repeatable)")
    q.add_argument("--head", default="builtin",
                   help="builtin (default), ict, an ICT-FaceKit folder or an .obj face mesh")
    q.add_argument("--fields", help="AU field parameters (JSON) for a FieldRig head")
    q.add_argument("--view", default="front", choices=VIEWS)
    q.add_argument("--size", type=_size, default=(640, 480), help="WIDTHxHEIGHT (640x480)")
    q.add_argument("--samples", type=int, default=4, choices=(0, 2, 4, 8),
                   help="multisample anti-aliasing samples")
    q.add_argument("--grid", action="store_true",
                   help="a labelled contact sheet: one tile per modelled AU at full intensity")
    q.add_argument("--columns", type=int, default=8, help="tiles per row for --grid")
    q.add_argument("-o", "--output", required=True, help="PNG file to write")
    q.add_argument("-q", "--quiet", action="store_true")
    q.set_defaults(func=cmd_pose)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except MimikaError as e:
        if args.debug:
            raise
        print(f"mimika: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("mimika: interrupted", file=sys.stderr)
        return 130
