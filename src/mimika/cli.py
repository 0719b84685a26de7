"""The ``mimika`` command line: thin commands over the library.

Every error a user can cause prints one line (``mimika: error: …``) and exits with code 2;
``--debug`` shows the traceback instead.
"""

from __future__ import annotations

import argparse
import difflib
import importlib
import os
import re
import signal
import sys
import threading
from collections.abc import Sequence

from mimika.commands import MODULES
from mimika.errors import MimikaError
from mimika.limits import OPTIONS, override
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


class Terminated(BaseException):
    """SIGTERM / SIGHUP arrived: unwind (temporary files removed, workers stopped), exit."""


def _terminate(signum: int, frame: object) -> None:
    raise Terminated(signum)


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    old = {}
    if threading.current_thread() is threading.main_thread():
        for sig in (signal.SIGTERM, signal.SIGHUP):
            old[sig] = signal.signal(sig, _terminate)
    try:
        given = {k: getattr(args, k) for k in OPTIONS if getattr(args, k, None) is not None}
        with override(**given):
            return int(args.func(args) or 0)
    except Terminated as e:
        print(f"mimika: stopped by signal {e.args[0]}", file=sys.stderr)
        return 128 + int(e.args[0])
    except MimikaError as e:
        if args.debug:
            raise
        # one line, whatever a library's text inside the message held
        print("mimika: error: " + re.sub(r"\s*[\r\n]+\s*", " ", str(e).strip()),
              file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("mimika: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # output piped into e.g. `head`, which has closed
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    finally:
        for sig, handler in old.items():
            signal.signal(sig, handler)
