"""Asyncio twin of :mod:`xarm_emu.client.sync`: asyncio streams around the same sans-IO
:class:`~.session.Session` and :class:`~.session.ReportStream`, with the same methods."""

from __future__ import annotations

import asyncio
import socket
from collections.abc import AsyncIterator
from typing import Any

from ..protocol.frame import COMMAND_PORT
from ..protocol.reports import ReportSnapshot
from .common import Response
from .helpers import Helpers, add_register_methods
from .session import ReportStream, Session

_READ = 65536


class AsyncClient(Helpers):
    """Async connection to the command port; one request in flight at a time."""

    def __init__(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        self._reader = reader
        self._writer = writer
        self._session = Session()
        self._lock = asyncio.Lock()

    @classmethod
    async def connect(cls, host: str = "127.0.0.1", port: int = COMMAND_PORT) -> AsyncClient:
        reader, writer = await asyncio.open_connection(host, port)
        sock = writer.get_extra_info("socket")
        if sock is not None:
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        return cls(reader, writer)

    async def close(self) -> None:
        self._writer.close()
        try:
            await self._writer.wait_closed()
        except (ConnectionError, OSError):
            pass

    async def __aenter__(self) -> AsyncClient:
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.close()

    async def call(self, register: int | str, raw: bytes | None = None, **values: Any) -> Response:
        """Send one request (register code or name; values by the request layout, or ``raw``
        parameters) and wait for its reply."""
        async with self._lock:
            tid, frame = self._session.request(register, values, raw)
            self._writer.write(frame)
            while True:
                response = self._session.next_response()
                if response is None:
                    self._session.receive_data(await self._reader.read(_READ))
                elif response.tid == tid:
                    return response


add_register_methods(AsyncClient)


async def subscribe(kind: str = "develop", host: str = "127.0.0.1",
                    port: int | None = None) -> AsyncIterator[ReportSnapshot]:
    """Async iterator over decoded report frames of ``kind`` (section 2.1.6)."""
    stream = ReportStream(kind)
    reader, writer = await asyncio.open_connection(host, port or stream.port)
    try:
        while True:
            snapshot = stream.next_report()
            if snapshot is None:
                stream.receive_data(await reader.read(_READ))
            else:
                yield snapshot
    finally:
        writer.close()
