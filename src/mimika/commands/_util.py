"""Helpers shared by the CLI commands: argument types and progress bars."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable


def size_arg(text: str) -> tuple[int, int]:
    """``"640x480"`` → ``(640, 480)`` (an argparse type)."""
    try:
        w, h = (int(x) for x in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"size {text!r} must look like 640x480") from None
    if not (16 <= w <= 8192 and 16 <= h <= 8192):
        raise argparse.ArgumentTypeError(f"size {text!r}: width and height must be 16…8192")
    return w, h


def progress_bar(quiet: bool, label: str) -> Callable[[int, int], None] | None:
    """A ``progress(done, total)`` callback drawing a bar on stderr (None when quiet/no TTY)."""
    if quiet or not sys.stderr.isatty():
        return None

    def report(done: int, total: int) -> None:
        bar = "#" * (30 * done // max(total, 1))
        sys.stderr.write(f"\r{label} [{bar:<30}] {done}/{total}")
        if done >= total:
            sys.stderr.write("\n")
        sys.stderr.flush()

    return report


HEAD_HELP = ("a character preset (default: {default}; see 'mimika characters'), a character "
             "file (.yaml), builtin, ict, an ICT-FaceKit folder or an .obj face mesh")


def add_head_arg(parser: argparse.ArgumentParser) -> None:
    """``--head``: which head to animate (default: the default character)."""
    from mimika.face.heads import DEFAULT_HEAD

    parser.add_argument("--head", default=DEFAULT_HEAD,
                        help=HEAD_HELP.format(default=DEFAULT_HEAD))
