"""Blocking client for the command port and the report ports: a socket around the sans-IO
:class:`~.session.Session` and :class:`~.session.ReportStream`."""

from __future__ import annotations

import socket
from collections.abc import Iterator
from typing import Any

from ..protocol.frame import COMMAND_PORT
from ..protocol.reports import ReportSnapshot
from .common import Response
from .helpers import Helpers, add_register_methods
from .session import ReportStream, Session

_READ = 65536


class Client(Helpers):
    """A connection to an xArm control box (real or emulated) on its command port.

    ``client.call("GET_STATE")`` or ``client.call(13)`` sends one request and returns a
    :class:`Response`; the typed helpers and the per-register methods are shared with
    :class:`~.aio.AsyncClient`.
    """

    def __init__(self, host: str = "127.0.0.1", port: int = COMMAND_PORT, timeout: float = 5.0) -> None:
        self.host = host
        self.port = port
        self.timeout = timeout
        self._sock = socket.create_connection((host, port), timeout=timeout)
        self._sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._session = Session()

    def close(self) -> None:
        self._sock.close()

    def __enter__(self) -> Client:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def call(self, register: int | str, raw: bytes | None = None, **values: Any) -> Response:
        """Send one request (register code or name; values by the request layout, or ``raw``
        parameters) and wait for its reply."""
        tid, frame = self._session.request(register, values, raw)
        self._sock.sendall(frame)
        while True:
            response = self._session.next_response()
            if response is None:
                self._session.receive_data(self._sock.recv(_READ))
            elif response.tid == tid:
                return response


add_register_methods(Client)


def subscribe(kind: str = "develop", host: str = "127.0.0.1", port: int | None = None,
              timeout: float = 5.0) -> Iterator[ReportSnapshot]:
    """Iterate over decoded report frames of ``kind`` ('develop', 'normal' or 'rich'; section 2.1.6)."""
    stream = ReportStream(kind)
    with socket.create_connection((host, port or stream.port), timeout=timeout) as sock:
        while True:
            snapshot = stream.next_report()
            if snapshot is None:
                stream.receive_data(sock.recv(_READ))
            else:
                yield snapshot
