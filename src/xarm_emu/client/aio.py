"""Asyncio twin of :mod:`xarm_emu.client.sync`."""

from __future__ import annotations

import asyncio
import socket
import struct
from collections.abc import AsyncIterator
from typing import Any

from ..protocol.frame import FrameDecoder, Reply
from ..protocol.reports import ReportSnapshot
from .common import REPORT_DECODERS, ClientError, Response, add_register_methods, build, parse


class AsyncClient:
    """Async connection to the command port; one request in flight at a time."""

    def __init__(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        self._reader = reader
        self._writer = writer
        self._decoder = FrameDecoder(replies=True)
        self._pending: list[Reply] = []
        self._tid = 0
        self._lock = asyncio.Lock()

    @classmethod
    async def connect(cls, host: str = "127.0.0.1", port: int = 502) -> AsyncClient:
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
        async with self._lock:
            self._tid = self._tid % 0xFFFF + 1
            reg, frame = build(self._tid, register, values, raw)
            self._writer.write(frame)
            while True:
                while self._pending:
                    reply = self._pending.pop(0)
                    if reply.tid == self._tid:
                        return parse(reg, reply)
                data = await self._reader.read(65536)
                if not data:
                    raise ClientError("connection closed by the control box")
                self._pending.extend(self._decoder.feed(data))  # type: ignore[arg-type]

    async def get_version(self) -> str:
        return str((await self.call(1))["version"])

    async def get_state(self) -> int:
        return int((await self.call(13))["state"])

    async def get_err_warn(self) -> tuple[int, int]:
        r = await self.call(15)
        return int(r["error"]), int(r["warning"])

    async def get_position(self) -> tuple[float, ...]:
        return tuple((await self.call(41))["pose"])

    async def get_joints(self) -> tuple[float, ...]:
        return tuple((await self.call(42))["joints"])

    async def motion_enable(self, enable: bool = True, joint: int = 8) -> Response:
        return await self.call(11, joint=joint, enable=int(enable))

    async def set_mode(self, mode: int) -> Response:
        return await self.call(19, mode=mode)

    async def set_state(self, state: int) -> Response:
        return await self.call(12, state=state)


add_register_methods(AsyncClient, asynchronous=True)


async def subscribe(kind: str = "develop", host: str = "127.0.0.1",
                    port: int | None = None) -> AsyncIterator[ReportSnapshot]:
    """Async iterator over decoded report frames of ``kind``."""
    default_port, decode = REPORT_DECODERS[kind]
    reader, writer = await asyncio.open_connection(host, port or default_port)
    try:
        while True:
            try:
                head = await reader.readexactly(4)
                (size,) = struct.unpack(">I", head)
                body = await reader.readexactly(size - 4)
            except asyncio.IncompleteReadError as exc:
                raise ClientError("report connection closed") from exc
            yield decode(head + body)
    finally:
        writer.close()
