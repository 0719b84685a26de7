"""``mimika train transitions`` and ``mimika transition``: learned expression transitions.

``train`` is a command group; other modules add their own sub-commands to it with
:func:`train_subparsers` (e.g. ``train_subparsers(sub).add_parser("gan", …)``), in any order.
"""

from __future__ import annotations

import argparse
import sys
import time

from mimika.commands._util import add_head_arg, limit_options
from mimika.errors import ParameterError


def train_subparsers(sub) -> argparse._SubParsersAction:
    """The sub-parsers of ``mimika train`` (created on the first call for this ``sub``)."""
    t = sub.choices.get("train")
    if t is None:
        t = sub.add_parser("train", help="train a learned model (transitions, …)")
        t.models = t.add_subparsers(dest="train_what", required=True,
                                    parser_class=type(t), metavar="MODEL")
    return t.models


def cmd_train_transitions(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from mimika.learn.train import RECIPES, load_state, prepare, save_checkpoint, train, validate

    if not args.output.endswith(".pt"):
        raise ParameterError(f"output {args.output!r} must be a .pt file")
    if args.epochs is not None and args.epochs < 1:
        raise ParameterError(f"--epochs={args.epochs} must be ≥ 1")
    say = (lambda *a: None) if args.quiet else (lambda *a: print(*a, file=sys.stderr))
    t0 = time.perf_counter()
    data = prepare(args.data, val=args.val, test=args.test)
    n = {k: len(data.items(k)) for k in ("train", "val", "test")}
    say(f"takes: train {', '.join(data.split.train)} | val {', '.join(data.split.val)} | "
        f"test {', '.join(data.split.test)}; transitions {n['train']}/{n['val']}/{n['test']} "
        f"({time.perf_counter() - t0:.1f} s)")
    cfg = replace(RECIPES[args.model], seed=args.seed, threads=args.threads)
    if args.epochs is not None:
        cfg.epochs = args.epochs
    if args.lr is not None:
        cfg.lr = args.lr

    def progress(epoch: int, total: int, rec: dict) -> None:
        say(f"epoch {epoch}/{total}  train {rec['train']:.5f}  val {rec['val']:.5f}  "
            f"lr {rec['lr']:.0e}  {rec['time']:.0f} s")

    ck = train(data, cfg, progress=progress)
    ck["validation"] = validate(load_state(ck), data)
    p = save_checkpoint(ck, args.output, half=args.half)
    if not args.quiet:
        print(f"wrote {p} ({args.model}, {ck['n_params']:,} parameters, best val MSE "
              f"{ck['best_val']:.5f} at epoch {ck['best_epoch']}, "
              f"{ck['train_seconds']:.0f} s, {p.stat().st_size / 1e6:.1f} MB)")
        for b in (ck["validation"] or {}).get("bins", []):
            use = "model" if b["use_model"] else f"falls back to {b['baseline'] or 'default'}"
            rel = f", {100 * b['rel']:+.1f} % MSE vs {b['baseline']}" if b["n"] else ""
            print(f"  ease=learned, {b['name']} transitions ({b['n']} validated{rel}): {use}")
    return 0


def cmd_transition(args: argparse.Namespace) -> int:
    from mimika.knowledge.expressions import get_expression
    from mimika.learn.interp import transition

    out = args.output
    if not out.lower().endswith((".csv", ".png", ".mp4")):
        raise ParameterError(f"output {out!r} must be a .csv, .png or .mp4 file")
    a = get_expression(args.start, args.intensity)
    b = get_expression(args.to, args.intensity)
    track = transition(a, b, duration=args.duration, fps=args.fps, model=args.model,
                       fallback=not args.no_fallback)
    if out.lower().endswith(".csv"):
        from mimika.io.tracks import write_au_csv

        write_au_csv(track, out)
    elif out.lower().endswith(".mp4"):
        from mimika.face.heads import load_head
        from mimika.render.video import write_track_video

        _, rig = load_head(args.head)
        write_track_video(rig, track, out)
    else:
        from mimika.learn.plots import transition_png

        transition_png(track, out, title=f"{args.start} → {args.to}, {args.duration:g} s",
                       frames=args.frames, head=args.head)
    if not args.quiet:
        print(f"wrote {out} ({track.n_frames} frames at {track.fps:g} fps, "
              f"{len(track.channels)} AUs)")
    return 0


def register(sub) -> None:
    tsub = train_subparsers(sub)
    q = tsub.add_parser("transitions", help="train a transition generator on a folder of "
                        "takes (Live Link Face / OpenFace / AU CSV)")
    q.add_argument("--data", required=True, metavar="DIR", help="folder of *.csv takes")
    q.add_argument("-o", "--output", required=True, help="checkpoint to write (.pt)")
    q.add_argument("--model", default="timing", choices=("timing", "seed", "rtn"),
                   help="timing: the learned timing model (default, shipped); seed: seed "
                   "000's LSTM; rtn: an LSTM with Harvey et al.'s RTN ideas")
    q.add_argument("--epochs", type=int, default=None, help="epochs (default: the model's "
                   "recipe — timing 40, seed up to 60 with early stopping, rtn 40)")
    q.add_argument("--lr", type=float, default=None, help="Adam learning rate (×0.1 at each "
                   "quarter of the run; default: the model's recipe)")
    q.add_argument("--val", action="append", metavar="TAKE", help="validation take (file stem; "
                   "repeatable; default 'facial' or the second-to-last)")
    q.add_argument("--test", action="append", metavar="TAKE", help="held-out test take "
                   "(repeatable; default 'apfel' or the last)")
    q.add_argument("--threads", type=int, default=1, help="torch CPU threads (default 1)")
    q.add_argument("--seed", type=int, default=0, help="random seed")
    q.add_argument("--half", action="store_true", help="store float16 weights (half size)")
    q.add_argument("-q", "--quiet", action="store_true")
    q.set_defaults(func=cmd_train_transitions)

    r = sub.add_parser("transition", help="a learned transition between two expressions "
                       "(AU CSV, PNG plot + rendered strip, or MP4 on the head)")
    r.add_argument("--from", dest="start", required=True, metavar="EXPR",
                   help="start expression (library name, e.g. happiness or neutral)")
    r.add_argument("--to", required=True, metavar="EXPR", help="target expression")
    r.add_argument("--duration", type=float, default=1.0, help="seconds (default 1)")
    r.add_argument("--fps", type=float, default=30.0, help="frame rate (default 30)")
    r.add_argument("--intensity", type=float, default=1.0, help="scale of both expressions")
    r.add_argument("--model", default=None, help="checkpoint, or a shipped model: builtin "
                   "(default, the timing model) or seed (seed 000's LSTM, for comparison)")
    r.add_argument("--no-fallback", action="store_true", help="always the model's curves, "
                   "also where validation found it worse than interpolation")
    r.add_argument("--frames", type=int, default=6,
                   help="rendered frames in the PNG strip (0: plot only)")
    add_head_arg(r)
    r.add_argument("-o", "--output", required=True, help=".csv (AU CSV), .png or .mp4")
    r.add_argument("-q", "--quiet", action="store_true")
    limit_options(r, "max_duration", "max_frames")
    r.set_defaults(func=cmd_transition)
