"""``mimika serve``: a headless server giving talking agents a face (WebSocket API + player)."""

from __future__ import annotations

import argparse
import secrets
import sys

from mimika.commands._util import LOOPBACK, check_web_server, limit_options


def cmd_serve(args: argparse.Namespace) -> int:
    check_web_server("serve", args.port)
    from mimika.serve.app import create_app
    from mimika.web.server import server

    token = args.token
    if token is None and args.host not in LOOPBACK:
        token = secrets.token_urlsafe(18)  # reachable from elsewhere: never without a token
    app = create_app(head=args.head, host=args.host, allowed_hosts=args.allow_host or (),
                     token=token, warm_up=True)
    host = f"[{args.host}]" if ":" in args.host else args.host
    url = f"http://{host}:{args.port}/" + (f"?token={token}" if token else "")
    print(f"mimika serve on {url} (WebSocket at ws://{host}:{args.port}/ws"
          f"{'?token=…' if token else ''}); Ctrl-C stops it", file=sys.stderr)
    server(app, args.host, args.port, quiet=args.quiet).run()
    return 0


def register(sub) -> None:
    q = sub.add_parser("serve", help="headless server for talking agents: speak text, get "
                                     "audio + timed face frames over a WebSocket; a web player")
    q.add_argument("--port", type=int, default=8787, help="TCP port (default 8787)")
    q.add_argument("--host", default="127.0.0.1",
                   help="address to bind (default 127.0.0.1: this computer only; any other "
                        "address needs a token, made up and printed unless --token)")
    q.add_argument("--token", help="the token clients must send (?token= or Authorization: "
                                   "Bearer)")
    q.add_argument("--head", metavar="NAME", help="the head /head.glb serves (default the "
                                                  "default character; 'mimika heads')")
    q.add_argument("--allow-host", action="append", metavar="NAME",
                   help="also answer requests for this Host name (repeatable)")
    q.add_argument("-q", "--quiet", action="store_true")
    limit_options(q, "max_body", "max_duration")
    q.set_defaults(func=cmd_serve)
