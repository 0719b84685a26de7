"""The ``mimika`` command line: thin commands over the library.

Every error a user can cause prints one line (``mimika: error: …``) and exits with code 2;
``--debug`` shows the traceback instead.
"""

from __future__ import annotations

import argparse
import difflib
import importlib
import os
import sys
from collections.abc import Sequence

from mimika.commands import MODULES
from mimika.errors import MimikaError
from mimika.plugins import load_plugins


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


def build_parser() -> argparse.ArgumentParser:
    load_plugins()  # e.g. the timeline's 'learned' easing (light: no torch)
    p = _Parser(prog="mimika", description="Animate 3D faces with FACS Action Units.")
    p.add_argument("--debug", action="store_true", help="show tracebacks on errors")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for name in MODULES:
        importlib.import_module(f"mimika.commands.{name}").register(sub)
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
    except BrokenPipeError:  # output piped into e.g. `head`, which has closed
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
