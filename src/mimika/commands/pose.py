"""``mimika pose``: a still image of AU intensities, or a contact sheet of every AU."""

from __future__ import annotations

import argparse

from mimika.commands._util import add_head_arg, add_light_arg, progress_bar, size_arg
from mimika.errors import ParameterError

VIEWS = ("front", "three-quarter", "profile")


def cmd_pose(args: argparse.Namespace) -> int:
    from mimika.face.heads import load_head
    from mimika.facs import parse_au_values
    from mimika.pose import au_sheet, render_pose
    from mimika.render import save_png
    from mimika.render.lighting import parse_light

    if not args.output.lower().endswith(".png"):
        raise ParameterError(f"output {args.output!r} must be a .png file")
    if args.grid and (args.au or args.expression):
        raise ParameterError("--grid renders every AU; do not combine it with --au/--expression")
    aus: dict[str, float] = {}
    if args.expression:
        from mimika.knowledge.expressions import expression_aus

        aus = expression_aus(args.expression, args.intensity)
    from mimika.render.camera import FILL

    light = parse_light(args.light)
    fill = FILL if args.face_height is None else args.face_height
    if not 0.05 <= fill <= 1.0:
        raise ParameterError(f"--face-height {fill:g} must be in [0.05, 1]: the "
                             "share of the image height the face fills (0.6 a portrait, 0.75 "
                             "a close-up)")
    if args.intensity != 1.0 and not args.expression:
        raise ParameterError("--intensity scales an --expression; give one with it")
    for code, value in parse_au_values(args.au or []).items():
        aus[code] = value  # explicit AUs override the expression's
    identity = None
    if args.identity is not None and args.identity_weights:
        raise ParameterError("give --identity or --identity-weights, not both")
    if args.identity_weights:
        try:
            identity = [float(x) for x in args.identity_weights.split(",")]
        except ValueError:
            raise ParameterError(f"--identity-weights {args.identity_weights!r} must be "
                                 "comma-separated numbers") from None
    elif args.identity is not None:
        identity = args.identity
    _, rig = load_head(args.head, fields=args.fields, identity=identity)
    if args.grid:
        img = au_sheet(head=rig, view=args.view, columns=args.columns, lighting=light,
                       fill=fill, progress=progress_bar(args.quiet, "rendering AUs"))
    else:
        img = render_pose(aus, head=rig, view=args.view, size=args.size, samples=args.samples,
                          lighting=light, fill=fill)
    save_png(img, args.output)
    if not args.quiet:
        print(f"wrote {args.output} ({img.shape[1]}x{img.shape[0]})")
    return 0


def register(sub) -> None:
    q = sub.add_parser("pose", help="render a still image of AU intensities (or --grid: all AUs)")
    q.add_argument("--au", action="append", metavar="AU=VALUE",
                   help="an AU and its intensity in [0, 1] or A–E, e.g. AU12=1 (repeatable)")
    q.add_argument("--expression", metavar="NAME",
                   help="a named expression from the library (see 'mimika expressions')")
    q.add_argument("--intensity", type=float, default=1.0,
                   help="scale of the --expression's AUs, in [0, 1] (default 1)")
    add_head_arg(q)
    q.add_argument("--fields", help="AU field parameters (JSON) for a FieldRig head")
    q.add_argument("--identity", type=int, metavar="K",
                   help="ICT head only: identity mode K (0–9) of the ICT model")
    q.add_argument("--identity-weights", metavar="W,…",
                   help="ICT head only: identity mode weights, e.g. 0.5,-1,0 (up to 10)")
    q.add_argument("--view", default="front", choices=VIEWS)
    q.add_argument("--size", type=size_arg, default=(640, 480), help="WIDTHxHEIGHT (640x480)")
    q.add_argument("--samples", type=int, default=4, choices=(0, 2, 4, 8),
                   help="multisample anti-aliasing samples")
    add_light_arg(q, "studio")
    q.add_argument("--face-height", type=float, default=None, metavar="F",
                   help="share of the image height the face (hairline to chin) fills, "
                        "0.05–1 (default 0.6, a portrait; 0.75 a close-up)")
    q.add_argument("--grid", action="store_true",
                   help="a labelled contact sheet: one tile per modelled AU at full intensity")
    q.add_argument("--columns", type=int, default=8, help="tiles per row for --grid")
    q.add_argument("-o", "--output", required=True, help="PNG file to write")
    q.add_argument("-q", "--quiet", action="store_true")
    q.set_defaults(func=cmd_pose)
