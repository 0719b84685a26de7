"""The uvicorn server the studio and ``mimika serve`` run on, with one fix to its WebSocket
protocol: a message refused for its size is closed with 1009 that the client actually receives.

uvicorn closes the TCP connection as soon as websockets refuses a message; when the client is
still sending (a large message in many fragments), the unread bytes make the kernel answer
with a reset, and the close frame is lost (the client sees 1006). Here the connection lingers
for a moment, discarding what still arrives, so the close frame is read first."""

from __future__ import annotations

from typing import Any

from uvicorn import Config, Server
from uvicorn.protocols.websockets.websockets_sansio_impl import WebSocketsSansIOProtocol

LINGER = 2.0  # seconds a failed connection stays open to deliver its close frame


class WebSocketProtocol(WebSocketsSansIOProtocol):
    """uvicorn's websockets protocol; a refused message's close frame reaches the client."""

    _failed = False

    def handle_parser_exception(self) -> None:
        if self._failed:  # websockets discards what arrives after the failure
            return
        self._failed = True
        close = self.conn.close_sent
        self.queue.put_nowait({"type": "websocket.disconnect",
                               "code": close.code if close else 1006,
                               "reason": close.reason if close else ""})
        self.transport.write(b"".join(self.conn.data_to_send()))
        self.close_sent = True
        self.close_timer = self.loop.call_later(LINGER, self.transport.close)


def server(app: Any, host: str, port: int, *, quiet: bool = False) -> Server:
    """A uvicorn :class:`Server` for ``app`` whose WebSocket messages are limited to
    ``app.state.max_body`` bytes, counted over all fragments."""
    return Server(Config(app, host=host, port=port, ws=WebSocketProtocol,
                         log_level="warning" if quiet else "info",
                         ws_max_size=app.state.max_body))
