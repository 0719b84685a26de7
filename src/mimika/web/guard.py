"""Host validation for the studio and ``mimika serve``: a defence against DNS rebinding.

A page on ``attacker.test`` whose DNS name is re-pointed at 127.0.0.1 reaches the server with
``Host: attacker.test:PORT`` and a matching ``Origin`` — same-origin as far as the browser
knows. The server therefore answers only Host names it serves: the address it binds,
``localhost``, any IP literal when it binds every interface (an IP cannot be rebound), and
the names the user allows (``--allow-host NAME``,
``MIMIKA_STUDIO_ALLOWED_HOSTS=a.example,*.lan``). Anything else gets 403, on HTTP and
WebSocket alike.
"""

from __future__ import annotations

import ipaddress
import json
import os
import re
import socket
from collections.abc import Iterable
from typing import Any

LOOPBACK_NAMES = ("localhost", "127.0.0.1", "::1")
WILDCARDS = ("0.0.0.0", "::", "")
ENV = "MIMIKA_STUDIO_ALLOWED_HOSTS"


#: a DNS name as a Host header may carry it (letters, digits, ``-`` and ``_``, dot-separated)
_NAME = re.compile(r"[a-z0-9_-]+(?:\.[a-z0-9_-]+)*\.?")
_PORT = re.compile(r":[0-9]{1,5}")


def host_name(header: str) -> str | None:
    """The name of a Host header (an RFC 3986 authority without userinfo), lower-case,
    without port, brackets or trailing dot; None when it is not one — userinfo (``a@b``),
    text after a bracketed IPv6 literal, a port that is not digits, characters no name has."""
    h = header.strip().lower()
    if h.startswith("["):  # [::1]:8765
        end = h.find("]")
        name, rest = (h[1:end], h[end + 1:]) if end > 0 else ("", "")
        if ":" not in name or not _is_ip(name):
            return None
    elif _is_ip(h):  # a bare IP address (an IPv6 bind address: ::1)
        return h
    else:
        name, sep, port = h.partition(":")
        rest = sep + port
        if not _NAME.fullmatch(name):
            return None
    if rest and not _PORT.fullmatch(rest):
        return None
    return name.rstrip(".")


def _pattern(entry: str) -> str | None:
    """An allow-list entry: a name, or ``*.suffix`` for every name under it."""
    e = entry.strip().lower()
    if e.startswith("*."):
        rest = host_name(e[2:])
        return None if rest is None else "*." + rest
    return host_name(e)


def _is_ip(name: str) -> bool:
    try:
        ipaddress.ip_address(name)
    except ValueError:
        return False
    return True


class HostPolicy:
    """Which Host names a server bound to ``bind`` answers (see the module docstring)."""

    def __init__(self, bind: str = "127.0.0.1", allowed: Iterable[str] = ()):
        self.bind = (host_name(bind) or bind) if bind not in WILDCARDS else bind
        extra = [*allowed, *os.environ.get(ENV, "").split(",")]
        self.allowed = {p for p in map(_pattern, extra) if p}
        self.names = {"localhost", self.bind}
        if self.bind in ("127.0.0.1", "::1", "localhost"):
            self.names.update(LOOPBACK_NAMES)
        self.any_ip = self.bind in WILDCARDS
        if self.any_ip:
            hostname = socket.gethostname().lower()
            self.names.update({hostname, hostname.split(".")[0]})

    def allows(self, header: str | None) -> bool:
        if header is None:  # not a browser (every browser sends Host): no rebinding
            return True
        name = host_name(header)
        if name is None:  # not an authority: nothing a served name could be
            return False
        if name in self.names or name in self.allowed:
            return True
        if any(a.startswith("*.") and name.endswith(a[1:]) for a in self.allowed):
            return True
        return self.any_ip and _is_ip(name)


class HostGuard:
    """ASGI middleware: 403 (HTTP) or a refused handshake (WebSocket) for unknown Hosts."""

    def __init__(self, app: Any, policy: HostPolicy, command: str = "studio"):
        self.app = app
        self.policy = policy
        self.command = command  #: the ``mimika`` command serving (named in the refusal)

    async def __call__(self, scope: dict, receive: Any, send: Any) -> None:
        if scope["type"] in ("http", "websocket"):
            host = next((v.decode("latin-1") for k, v in scope.get("headers", [])
                         if k == b"host"), None)
            if not self.policy.allows(host):
                where = self.policy.bind if not self.policy.any_ip else "its address"
                await refuse(scope, send, 403, f"host {host!r} is not served here; open "
                                               f"mimika {self.command} at {where} or allow "
                                               f"the name with mimika {self.command} "
                                               "--allow-host")
                return
        await self.app(scope, receive, send)


async def refuse(scope: dict, send: Any, status: int, message: str) -> None:
    """Answer a refused request: a closed handshake (1008) for a WebSocket, else ``status``
    with ``{"error": message}``."""
    if scope["type"] == "websocket":
        await send({"type": "websocket.close", "code": 1008})
        return
    body = json.dumps({"error": message}).encode()
    await send({"type": "http.response.start", "status": status,
                "headers": [(b"content-type", b"application/json"),
                            (b"content-length", str(len(body)).encode())]})
    await send({"type": "http.response.body", "body": body})
