"""Helpers shared by the CLI commands: argument types and progress bars."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable

from mimika.errors import ParameterError


def size_arg(text: str) -> tuple[int, int]:
    """``"640x480"`` → ``(640, 480)`` (an argparse type)."""
    try:
        w, h = (int(x) for x in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"size {text!r} must look like 640x480") from None
    if not (16 <= w <= 8192 and 16 <= h <= 8192):
        raise argparse.ArgumentTypeError(f"size {text!r}: width and height must be 16…8192")
    return w, h


def add_light_arg(parser: argparse.ArgumentParser, default: str) -> None:
    """``--light SPEC``: a lighting preset and changes (:func:`mimika.render.lighting.
    parse_light`; checked by the command, so a bad spec is one line and exit 2)."""
    from mimika.render.lighting import light_help

    parser.add_argument("--light", metavar="SPEC", default=default,
                        help=light_help().replace("(default: studio)", f"(default: {default})"))


#: help of the options that raise a limit (see mimika.limits and docs/limits.md)
_LIMIT_HELP = {
    "max_duration": ("SECONDS", float, "longest timeline or speech (default 3600)"),
    "max_frames": ("N", int, "most frames in one track or video (default 250 000)"),
    "max_text": ("CHARS", int, "largest text, script or article (default 500 000)"),
    "max_items": ("N", int, "most items in one batch (default 100 000)"),
    "max_export_seconds": ("SECONDS", float, "longest wall time of one export (default 600)"),
    "max_body": ("BYTES", int, "largest request body or WebSocket message (default 2 MiB)"),
}


def limit_options(p: argparse.ArgumentParser, *names: str) -> None:
    """Add ``--max-duration``-style options; ``mimika.cli.main`` applies the given ones."""
    from mimika.limits import OPTIONS

    g = p.add_argument_group("limits (docs/limits.md; also MIMIKA_MAX_… variables)")
    for name in names:
        metavar, kind, text = _LIMIT_HELP[name]
        g.add_argument(OPTIONS[name], dest=name, type=kind, metavar=metavar, help=text)


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


def add_voice_args(parser: argparse.ArgumentParser) -> None:
    """``--voice`` and ``--engine``: who speaks (:func:`mimika.speech.tts.choose_engine`)."""
    parser.add_argument("--voice", help="a Piper voice (PATH.onnx, or a name from 'mimika "
                                        "voices': en_US-joe-medium, joe) or an espeak-ng "
                                        "variant (f3, m2, klatt …)")
    parser.add_argument("--engine", choices=("auto", "piper", "espeak"),
                        help="speech engine: auto (default, or $MIMIKA_TTS) speaks with a "
                             "neural Piper voice where one speaks the language, else "
                             "espeak-ng")


#: addresses only this computer reaches
LOOPBACK = ("127.0.0.1", "localhost", "::1")


def check_web_server(name: str, port: int) -> None:
    """FastAPI and uvicorn are installed and ``port`` is a TCP port, else one clear error."""
    try:
        import fastapi  # noqa: F401
        import uvicorn  # noqa: F401
    except ImportError:
        raise ParameterError(f"mimika {name} needs FastAPI and uvicorn: "
                             "pip install 'mimika[studio]'") from None
    if not 1 <= port <= 65535:
        raise ParameterError(f"--port {port} must be within 1…65535")
