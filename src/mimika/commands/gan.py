"""``mimika gan``: the WGAN latent-slider controller (sample, grid, invert) and its trainer.

``register(sub)`` adds ``gan``; the trainer is :func:`train_gan_command` with
:func:`add_train_gan_arguments`, wired as ``mimika train gan`` by the module owning ``train``.
"""

from __future__ import annotations

import argparse
import re
import sys

from mimika.commands._util import add_head_arg, progress_bar, size_arg
from mimika.errors import ParameterError

VIEWS = ("front", "three-quarter", "profile")
#: "-3,2,0,0" is a value, not an option (argparse would take it for a flag)
_NUMBERS = re.compile(r"^-\d*\.?\d+([,\s]+-?\d*\.?\d+)*$")


def parse_floats(text: str, what: str = "--z") -> list[float]:
    """``"-3,2,0,0"`` → ``[-3.0, 2.0, 0.0, 0.0]``; raises :class:`ParameterError`."""
    try:
        vals = [float(x) for x in text.replace(" ", "").split(",") if x != ""]
    except ValueError:
        raise ParameterError(f"{what} {text!r} must be comma-separated numbers, e.g. "
                             "-3,2,0,0") from None
    if not vals:
        raise ParameterError(f"{what} is empty; give comma-separated numbers, e.g. 0,1.5,0,0")
    return vals


def _controller(args: argparse.Namespace):
    from mimika.learn.controller import Controller

    conditional = bool(getattr(args, "conditional", False) or getattr(args, "label", None))
    return Controller.load(args.model, conditional=conditional and args.model is None)


def _png(path: str) -> str:
    if not path.lower().endswith(".png"):
        raise ParameterError(f"output {path!r} must be a .png file")
    return path


def cmd_sample(args: argparse.Namespace) -> int:
    from mimika.render import save_png

    if args.output:
        _png(args.output)
    c = _controller(args)
    z = parse_floats(args.z) if args.z is not None else [0.0] * c.latent_dim
    aus = c.sample(z, label=args.label)  # validates z length and label
    if args.output:
        img = c.render(z, label=args.label, head=args.head, size=args.size, view=args.view)
        save_png(img, args.output)
    if not args.quiet or not args.output:
        active = {k: v for k, v in aus.items() if v >= 0.005}
        print(" ".join(f"{k}={v:.2f}" for k, v in active.items()) or "(neutral: every AU < 0.005)")
    if args.output and not args.quiet:
        print(f"wrote {args.output} ({args.size[0]}x{args.size[1]})")
    return 0


def cmd_grid(args: argparse.Namespace) -> int:
    from mimika.render import save_png

    _png(args.output)
    c = _controller(args)
    values = parse_floats(args.values, "--values")
    if args.label is not None:
        c.label_index(args.label)
    img = c.render_grid(head=args.head, values=values, label=args.label, tile=args.tile,
                        view=args.view, progress=progress_bar(args.quiet, "rendering grid"))
    save_png(img, args.output)
    if not args.quiet:
        print(f"wrote {args.output} ({img.shape[1]}x{img.shape[0]}): {c.latent_dim} rows × "
              f"{len(values)} columns")
    return 0


def cmd_invert(args: argparse.Namespace) -> int:
    import numpy as np

    from mimika.learn.gan_data import read_take_frames

    c = _controller(args)
    frames, fps = read_take_frames(args.take)
    if args.frame < 0 or args.frame >= len(frames):
        raise ParameterError(f"--frame {args.frame} is outside the take ({len(frames)} frames, "
                             f"0…{len(frames) - 1})")
    if args.label is not None:
        c.label_index(args.label)
    x = frames[args.frame]
    z, rec = c.invert_batch(x[None], None if args.label is None else [args.label])
    err = rec[0] - x
    worst = int(np.argmax(np.abs(err)))
    print(f"z = {','.join(f'{v:.3f}' for v in z[0])}")
    print(f"frame {args.frame} ({args.frame / fps:.2f} s) of {args.take}: reconstruction RMSE "
          f"{float(np.sqrt(np.mean(err ** 2))):.4f}, max |error| {abs(float(err[worst])):.3f} "
          f"({c.channels[worst]}) over {len(x)} AU channels")
    if args.verbose:
        for ch, a, b in zip(c.channels, x, rec[0], strict=True):
            print(f"  {ch}  frame {a:.3f}  sliders {b:.3f}")
    return 0


def _common(q: argparse.ArgumentParser, *, render: bool = True) -> None:
    q.add_argument("--model", help="a checkpoint from 'mimika train controller/gan', or a "
                                   "shipped model: default (the WAE controller), seed (seed "
                                   "001's WGAN); the conditional one with --label/--conditional")
    q.add_argument("--conditional", action="store_true",
                   help="use the shipped conditional (emotion-label) model")
    q.add_argument("--label", help="emotion for a conditional model (e.g. surprise)")
    if render:
        add_head_arg(q)
        q.add_argument("--view", default="front", choices=VIEWS)
    q.add_argument("-q", "--quiet", action="store_true")


def register(sub) -> None:
    g = sub.add_parser("gan", help="latent-slider face controller (WAE; seed 001's WGAN)")
    gs = g.add_subparsers(dest="gan_command", required=True, parser_class=type(g))

    s = gs.add_parser("sample", help="one face from slider values z (prints its AUs)")
    s._negative_number_matcher = _NUMBERS  # "--z -3,2,0,0" is a value
    s.add_argument("--z", help="comma-separated slider values, one per latent variable "
                               "(default all 0), e.g. -3,2,0,0")
    _common(s)
    s.add_argument("--size", type=size_arg, default=(640, 480), help="WIDTHxHEIGHT (640x480)")
    s.add_argument("-o", "--output", help="PNG file to render the face to")
    s.set_defaults(func=cmd_sample)

    r = gs.add_parser("grid", help="latent traversal grid: rows = sliders, columns = values")
    r._negative_number_matcher = _NUMBERS
    _common(r)
    r.add_argument("--values", default="-3,-2,-1,0,1,2,3",
                   help="slider values of the columns (default -3,-2,-1,0,1,2,3)")
    r.add_argument("--tile", type=size_arg, default=(160, 160), help="tile size (160x160)")
    r.add_argument("-o", "--output", required=True, help="PNG file to write")
    r.set_defaults(func=cmd_grid)

    v = gs.add_parser("invert", help="put a real frame on the sliders: frame → z")
    v.add_argument("take", help="a take (Live Link Face, OpenFace or AU CSV)")
    v.add_argument("--frame", type=int, default=0, help="frame index (default 0)")
    _common(v, render=False)
    v.add_argument("-v", "--verbose", action="store_true", help="list every channel")
    v.set_defaults(func=cmd_invert)

    from mimika.commands.learn import train_subparsers

    t = train_subparsers(sub).add_parser(
        "gan", help="train seed 001's latent-slider WGAN (or the conditional one) on takes")
    add_train_gan_arguments(t)
    c = train_subparsers(sub).add_parser(
        "controller", help="train the default latent-slider controller (WAE) on takes")
    c.add_argument("--data", help="folder of takes (default $MIMIKA_MOTION_DIR)")
    c.add_argument("--latent", type=int, default=6, help="sliders d (default 6)")
    c.add_argument("--iters", type=int, default=None, help="iterations (default 10000)")
    c.add_argument("--test-take", action="append", default=[], metavar="NAME",
                   help="take to leave out (file stem, repeatable; default none)")
    c.add_argument("--seed", type=int, default=0)
    c.add_argument("-o", "--output", required=True, help="checkpoint to write (.pt)")
    c.add_argument("-q", "--quiet", action="store_true")
    c.set_defaults(func=train_controller_command)


def _check_training(args: argparse.Namespace, *counts: str) -> None:
    """A ``.pt`` output and counts of at least 1 (those given) for the train commands."""
    if not args.output.lower().endswith(".pt"):
        raise ParameterError(f"output {args.output!r} must be a .pt file")
    for name in counts:
        v = getattr(args, name)
        if v is not None and v < 1:
            raise ParameterError(f"--{name.replace('_', '-')} {v} must be ≥ 1")


def train_controller_command(args: argparse.Namespace) -> int:
    """``mimika train controller``: train the WAE controller and save its checkpoint."""
    _check_training(args, "latent", "iters")
    try:
        from mimika.learn.wae import train_from_takes
        from mimika.learn.wgan import save_checkpoint
    except ImportError:
        raise ParameterError("training needs PyTorch: pip install 'mimika[learn]'") from None
    state, res = train_from_takes(args.data, latent_dim=args.latent, iters=args.iters,
                                  test_takes=args.test_take, seed=args.seed,
                                  progress=progress_bar(args.quiet, "training"))
    save_checkpoint(args.output, state)
    if not args.quiet:
        print(f"wrote {args.output}: WAE d={args.latent}, {res.config.iters} iterations in "
              f"{res.seconds:.0f} s on {state['meta']['train_frames']} frames; final weighted "
              f"reconstruction {float(res.history['reconstruction'][-100:].mean()):.5f}")
    return 0


# -- mimika train gan -----------------------------------------------------------------------------
def add_train_gan_arguments(p: argparse.ArgumentParser) -> None:
    """Arguments of ``mimika train gan`` (added to the parser the ``train`` owner creates)."""
    p.add_argument("--data", help="folder of takes (Live Link Face CSV; default "
                                  "$MIMIKA_MOTION_DIR)")
    p.add_argument("--latent", type=int, default=4, help="latent sliders d (default 4)")
    p.add_argument("--n-critic", type=int, default=None,
                   help="critic steps per generator step (default 20; 5 with --conditional)")
    p.add_argument("--iters", type=int, default=None,
                   help="generator iterations (default 50000; 20000 with --conditional)")
    p.add_argument("--conditional", action="store_true",
                   help="train the conditional WGAN-GP with emotion labels")
    p.add_argument("--classifier", type=float, default=None, metavar="W",
                   help="with --conditional: weight of the auxiliary classifier loss "
                        "(default 10; 0 trains a plain conditional WGAN-GP)")
    p.add_argument("--test-take", action="append", metavar="NAME",
                   help="held-out take (file stem, repeatable; default apfel)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--encoder-steps", type=int, default=3000,
                   help="training steps of the inversion encoder (default 3000)")
    p.add_argument("-o", "--output", required=True, help="checkpoint to write (.pt)")
    p.add_argument("-q", "--quiet", action="store_true")
    p.set_defaults(func=train_gan_command)


def train_gan_command(args: argparse.Namespace) -> int:
    """``mimika train gan``: train a controller and save its checkpoint."""
    import numpy as np

    from mimika.learn.controller import train_controller
    from mimika.learn.wgan import save_checkpoint

    _check_training(args, "latent", "n_critic", "iters", "encoder_steps")
    if args.classifier is not None and (args.classifier < 0 or not args.conditional):
        raise ParameterError(f"--classifier {args.classifier} needs --conditional and must "
                             "be ≥ 0")
    try:
        import torch
    except ImportError:
        raise ParameterError("training needs PyTorch: pip install 'mimika[learn]'") from None
    torch.set_num_threads(max(1, min(torch.get_num_threads(), 4)))
    state, res = train_controller(args.data, latent_dim=args.latent, n_critic=args.n_critic,
                                  iters=args.iters, conditional=args.conditional,
                                  test_takes=args.test_take, seed=args.seed,
                                  classifier=args.classifier,
                                  encoder_steps=args.encoder_steps,
                                  progress=progress_bar(args.quiet, "training"))
    save_checkpoint(args.output, state)
    if not args.quiet:
        cfg, h = state["config"], state["history"]
        tail = max(1, len(res.w_train) // 50)
        wte = np.nanmean(res.w_test[-tail:]) if np.isfinite(res.w_test[-tail:]).any() else None
        test = f", test {wte:.4f}" if wte is not None else " (no test take)"
        print(f"wrote {args.output}: {state['kind'].upper()} d={cfg['latent_dim']}, n_critic "
              f"{cfg['n_critic']}, {h['iters']} iterations in {h['seconds']:.0f} s "
              f"({h['iters'] / max(h['seconds'], 1e-9):.0f} it/s); final W estimate train "
              f"{np.mean(res.w_train[-tail:]):.4f}{test}", file=sys.stdout)
    return 0
