"""``mimika studio``: the web editor (AU designer, expression library, timeline, live speech)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from mimika.commands._util import LOOPBACK, check_web_server, limit_options
from mimika.face.heads import DEFAULT_HEAD


def default_projects_dir() -> Path:
    from mimika.knowledge.expressions import default_library_path

    return default_library_path().parent / "projects"


def cmd_studio(args: argparse.Namespace) -> int:
    check_web_server("studio", args.port)
    from mimika.studio.app import create_app
    from mimika.web.server import server
    from mimika.web.three import ensure_vendor

    ensure_vendor()
    projects = Path(args.projects) if args.projects else default_projects_dir()
    app = create_app(projects, head=args.head, library_path=args.library, warm_up=True,
                     host=args.host, allowed_hosts=args.allow_host or ())
    host = args.host
    url = f"http://{'[' + host + ']' if ':' in host else host}:{args.port}/"
    if host not in LOOPBACK:
        print(f"mimika studio: warning: listening on {host}; anyone who can reach it can edit "
              "your projects (there is no login)", file=sys.stderr)
    print(f"mimika studio on {url} (projects in {projects}); Ctrl-C stops it", file=sys.stderr)
    if not args.no_browser:
        import threading
        import webbrowser

        threading.Timer(1.0, webbrowser.open, args=(url,)).start()
    server(app, host, args.port, quiet=args.quiet).run()
    return 0


def register(sub) -> None:
    q = sub.add_parser("studio", help="start the web editor (AU sliders, expressions, timeline, "
                                      "live speech) in the browser")
    q.add_argument("--port", type=int, default=8765, help="TCP port (default 8765)")
    q.add_argument("--host", default="127.0.0.1",
                   help="address to bind (default 127.0.0.1: this computer only)")
    q.add_argument("--projects", metavar="DIR",
                   help="folder of project files (default: ~/.local/share/mimika/projects)")
    q.add_argument("--head", default=DEFAULT_HEAD, metavar="NAME",
                   help="the head the page opens with: a name from 'mimika heads' (default "
                        f"{DEFAULT_HEAD}); the page switches heads without a restart")
    q.add_argument("--library", metavar="FILE",
                   help="user expression library (default: ~/.local/share/mimika/expressions.json)")
    q.add_argument("--no-browser", action="store_true", help="do not open a browser window")
    q.add_argument("--allow-host", action="append", metavar="NAME",
                   help="also answer requests for this Host name (repeatable; *.example.org "
                        "matches subdomains); others get 403 — a guard against DNS rebinding")
    q.add_argument("-q", "--quiet", action="store_true")
    limit_options(q, "max_duration", "max_frames", "max_export_seconds", "max_body")
    q.set_defaults(func=cmd_studio)
