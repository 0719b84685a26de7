"""``mimika fit``: fit seed-002 AU fields to scanned shapes; ``mimika transfer``: carry a fitted
fields file to another head by its 68 landmarks."""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from mimika.commands._util import progress_bar
from mimika.errors import DataError, ParameterError


def _write_json(doc: dict, path: str) -> None:
    p = Path(path)
    if p.suffix.lower() != ".json":
        raise ParameterError(f"output {path!r} must be a .json file")
    p.parent.mkdir(parents=True, exist_ok=True)
    p.write_text(json.dumps(doc, indent=1) + "\n", "utf-8")


def _target_head(name: str, identity):
    from mimika.face.heads import load_head

    head, _ = load_head(name, identity=identity) if identity is not None else load_head(name)
    return head


def _identity(args: argparse.Namespace):
    if getattr(args, "identity", None) is not None and getattr(args, "identity_weights", None):
        raise ParameterError("give --identity or --identity-weights, not both")
    if getattr(args, "identity_weights", None):
        try:
            return [float(x) for x in args.identity_weights.split(",")]
        except ValueError:
            raise ParameterError(f"--identity-weights {args.identity_weights!r} must be "
                                 f"comma-separated numbers") from None
    return getattr(args, "identity", None)


def cmd_fit(args: argparse.Namespace) -> int:
    from mimika.face.fitting import (
        FitOptions,
        fit_ict,
        report_csv,
        report_markdown,
        transfer_fields,
    )
    from mimika.face.rigs.field import parse_fields

    shapes = Path(args.shapes)
    if not shapes.is_dir():
        raise DataError(f"--shapes {args.shapes}: no such folder (give an ICT-FaceKit checkout "
                        f"or its FaceXModel folder)")
    opt = FitOptions(family=args.family, seed=args.seed, max_vertices=args.max_vertices,
                     psi_evals=args.psi_evals, phi_evals=args.phi_evals)
    t0 = time.perf_counter()
    res = fit_ict(str(shapes), aus=args.au, options=opt,
                  progress=progress_bar(args.quiet, f"fitting AUs ({args.family})"))
    doc = res.document
    if args.target:
        doc = transfer_fields(doc, _target_head(args.target, _identity(args)))
    parse_fields(doc, source=args.output)  # the file must load
    _write_json(doc, args.output)
    if args.report:
        rdir = Path(args.report)
        rdir.mkdir(parents=True, exist_ok=True)
        stem = f"accuracy_{args.family}"
        (rdir / f"{stem}.csv").write_text(report_csv(res.accuracy), "utf-8")
        title = (f"{args.family} family — held-out vertices ({opt.holdout:.0%} of the moving "
                 f"ones), mm")
        (rdir / f"{stem}.md").write_text(report_markdown(res.accuracy, title), "utf-8")
    if not args.quiet:
        n = sum(1 for r in res.accuracy if r.obj == "face")
        where = f" (carried to {args.target})" if args.target else ""
        print(f"wrote {args.output}{where}: {len(doc['aus'])} AUs, {n} fitted "
              f"({args.family} family) in {time.perf_counter() - t0:.1f} s")
        if args.report:
            print(f"wrote {Path(args.report) / f'accuracy_{args.family}.md'} and .csv")
    print(f"mean e/d_max over {sum(1 for r in res.accuracy if r.obj == 'face')} fitted AUs "
          f"(held-out vertices): {100 * res.mean_e_rel:.2f} %")
    return 0


def cmd_transfer(args: argparse.Namespace) -> int:
    from mimika.face.fitting import read_fields_json, transfer_fields
    from mimika.face.rigs.field import parse_fields

    doc = transfer_fields(read_fields_json(args.fields), _target_head(args.to, _identity(args)))
    parse_fields(doc, source=args.output)
    _write_json(doc, args.output)
    if not args.quiet:
        sim = doc["source"]["similarity"]
        print(f"wrote {args.output}: {len(doc['aus'])} AUs carried to {args.to} "
              f"(scale {sim['scale']:.4f})")
    return 0


def _identity_args(q) -> None:
    q.add_argument("--identity", type=int, metavar="K",
                   help="ICT target only: identity mode K (0–9)")
    q.add_argument("--identity-weights", metavar="W,…",
                   help="ICT target only: identity mode weights, e.g. 0.5,-1,0")


def register(sub) -> None:
    q = sub.add_parser("fit", help="fit seed-002 AU fields (Ψ·φ) to scanned shapes (ICT)")
    q.add_argument("--shapes", required=True, metavar="DIR",
                   help="ICT-FaceKit checkout (or its FaceXModel folder)")
    q.add_argument("-o", "--output", required=True, help="fields file to write (.json)")
    q.add_argument("--au", action="append", metavar="AU",
                   help="fit only this AU (repeatable; default: every AU the ICT table covers)")
    q.add_argument("--family", default="seed", choices=("seed", "rich"),
                   help="seed: Ψ·φ as in seed 002; rich: plus a smooth RBF residual")
    q.add_argument("--report", metavar="DIR",
                   help="write accuracy_<family>.md/.csv (seed Table 4.3, mm) here")
    q.add_argument("--target", metavar="HEAD",
                   help="carry the fitted fields to this head (builtin, ict, an .obj)")
    _identity_args(q)
    q.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    q.add_argument("--max-vertices", type=int, default=1500,
                   help="moving vertices per field used by the optimiser (default 1500)")
    q.add_argument("--psi-evals", type=int, default=6000,
                   help="Nelder–Mead evaluations for Ψ per field (default 6000)")
    q.add_argument("--phi-evals", type=int, default=3000,
                   help="Nelder–Mead evaluations for φ per field (default 3000)")
    q.add_argument("-q", "--quiet", action="store_true")
    q.set_defaults(func=cmd_fit)

    t = sub.add_parser("transfer", help="carry a fitted fields file to another head "
                       "(landmark similarity transform)")
    t.add_argument("fields", help="fields file written by 'mimika fit'")
    t.add_argument("--to", required=True, metavar="HEAD",
                   help="target head: builtin, ict, an .obj face mesh")
    _identity_args(t)
    t.add_argument("-o", "--output", required=True, help="fields file to write (.json)")
    t.add_argument("-q", "--quiet", action="store_true")
    t.set_defaults(func=cmd_transfer)
