"""Sans-IO client sessions: bytes in, decoded replies and reports out; no sockets.

:class:`Session` speaks the command port (manual section 2.1.2): :meth:`Session.request` builds a
request frame through the register table and remembers its transaction id,
:meth:`Session.receive_data` takes bytes as they arrive (``b""`` for end of stream) and
:meth:`Session.next_response` hands out decoded replies to requests still outstanding.

:class:`ReportStream` does the same for the report ports (section 2.1.6): each frame starts with
its total length (u32 big-endian) and is decoded by :data:`xarm_emu.protocol.reports.DECODERS`.
The sync and async clients are transport shells around these two.
"""

from __future__ import annotations

import struct
from collections import deque
from collections.abc import Mapping
from typing import Any

from ..protocol import registers as regs
from ..protocol import reports
from ..protocol.frame import FrameDecoder, FrameError, Reply, encode_request
from ..protocol.layouts import LayoutError
from .common import ClientError, Response, resolve

__all__ = ["REPORT_PORTS", "ReportStream", "Session"]

#: Report kind -> its standard port (section 2.1.6); the port keys the decoder table.
REPORT_PORTS: dict[str, int] = {
    "develop": reports.DEVELOP_PORT,
    "normal": reports.NORMAL_PORT,
    "rich": reports.RICH_PORT,
}

_LENGTH = struct.Struct(">I")
#: Largest report frame accepted; the rich report (433 bytes) is the longest of the manual.
MAX_REPORT_SIZE = 4096


class Session:
    """The command-port conversation of one connection, in the manner of a sans-IO protocol object.

    Several requests may be outstanding; replies are matched to them by transaction id (1..65535,
    wrapping) and handed out in arrival order. A reply whose id matches no outstanding request
    (a late answer to an abandoned one) is dropped.
    """

    def __init__(self) -> None:
        self._decoder = FrameDecoder(replies=True)
        self._outstanding: dict[int, regs.Register] = {}
        self._ready: deque[tuple[regs.Register, Reply]] = deque()
        self._tid = 0
        self._closed = False

    @property
    def outstanding(self) -> int:
        """How many requests still wait for their reply."""
        return len(self._outstanding)

    def request(self, register: int | str, values: Mapping[str, Any] | None = None,
                raw: bytes | None = None) -> tuple[int, bytes]:
        """``(tid, frame)`` for ``register`` (code or name): ``values`` are encoded by the request
        layout, or ``raw`` parameters are sent as they are. :class:`KeyError` for an unknown
        register, :class:`ClientError` for values the layout cannot encode."""
        reg = resolve(register)
        if raw is None:
            try:
                raw = reg.request.encode(dict(values or {}))
            except (LayoutError, TypeError, ValueError, KeyError, struct.error) as exc:
                raise ClientError(f"register {reg.code} ({reg.name}): {exc}") from exc
        self._tid = self._tid % 0xFFFF + 1
        self._outstanding[self._tid] = reg
        return self._tid, encode_request(self._tid, reg.code, raw)

    def receive_data(self, data: bytes) -> None:
        """Feed bytes from the command port; ``b""`` means the control box closed the connection.
        A stream that cannot be framed raises :class:`ClientError`."""
        if not data:
            self._closed = True
            return
        try:
            replies = self._decoder.feed(data)
        except FrameError as exc:
            self._closed = True
            raise ClientError(f"cannot frame the control box's reply: {exc}") from exc
        for reply in replies:
            reg = self._outstanding.pop(reply.tid, None)
            if reg is not None:
                self._ready.append((reg, reply))  # type: ignore[arg-type]

    def next_response(self) -> Response | None:
        """The next decoded reply, or None when more bytes are needed. After the end of stream
        with requests outstanding, :class:`ClientError`."""
        if self._ready:
            reg, reply = self._ready.popleft()
            return _decode(reg, reply)
        if self._closed and self._outstanding:
            self._outstanding.clear()
            raise ClientError("connection closed by the control box")
        return None


def _decode(reg: regs.Register, reply: Reply) -> Response:
    """Reply parameters through the register's reply layout; a reply of another register for this
    transaction id is a :class:`ClientError`."""
    if reply.register != reg.code:
        raise ClientError(f"reply for register {reply.register}, expected {reg.code}")
    values: dict[str, Any] = {}
    if reply.params and reg.reply.accepts(len(reply.params)):
        values = reg.reply.decode(reply.params)
    return Response(reg.code, reply.state, values, reply.params, reply.tid)


class ReportStream:
    """Report frames of one kind ('develop', 'normal' or 'rich') from a byte stream (section 2.1.6)."""

    def __init__(self, kind: str = "develop") -> None:
        if kind not in REPORT_PORTS:
            raise KeyError(f"unknown report kind {kind!r}; one of {', '.join(REPORT_PORTS)}")
        self.kind = kind
        self.port = REPORT_PORTS[kind]
        self._decode = reports.DECODERS[self.port]
        self._buf = bytearray()
        self._closed = False

    def receive_data(self, data: bytes) -> None:
        """Feed bytes from the report port; ``b""`` means the connection closed."""
        if not data:
            self._closed = True
        self._buf += data

    def next_report(self) -> reports.ReportSnapshot | None:
        """The next decoded frame, or None when more bytes are needed; :class:`ClientError` for a
        frame that cannot be read or a stream closed before its next frame."""
        buf = self._buf
        if len(buf) >= _LENGTH.size:
            (size,) = _LENGTH.unpack_from(buf, 0)
            if not _LENGTH.size < size <= MAX_REPORT_SIZE:
                raise ClientError(f"{self.kind} report frame length {size} out of range")
            if len(buf) >= size:
                frame = bytes(buf[:size])
                del buf[:size]
                try:
                    return self._decode(frame)
                except reports.ReportError as exc:
                    raise ClientError(f"bad {self.kind} report frame: {exc}") from exc
        if self._closed:
            raise ClientError("report connection closed")
        return None
