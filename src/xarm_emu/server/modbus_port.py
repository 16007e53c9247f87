"""A standard Modbus-TCP port beside the command port (``xarm-emu serve --modbus-port N``).

The control box answers standard Modbus TCP (protocol id 0) on its command port 502; tools that
cannot share that port (a PLC or SCADA driver that wants a port of its own) get the same map here.
Only MBAP frames of protocol id 0 are served, each through the server's
:meth:`~xarm_emu.server.core.EmulatorServer.answer_modbus`, so both ports read and write one state,
in order per connection. A frame of another protocol id cannot be framed: that connection is closed,
no other. What a malformed protocol-0 frame gets (an exception, a close) is decided for both ports by
:func:`xarm_emu.protocol.modbus.screen`.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import socket
import struct
from typing import Protocol

from ..protocol.modbus import MAX_PDU, respond
from .core import listen_args

log = logging.getLogger(__name__)

#: MBAP header: transaction id, protocol id, length (unit id + PDU), unit id.
MBAP = struct.Struct(">HHHB")
#: The protocol id of standard Modbus.
PROTOCOL_MODBUS = 0


class ModbusTarget(Protocol):
    """What the port needs of the server: the standard map's answer to one request."""

    def answer_modbus(self, tid: int, unit: int, pdu: bytes) -> bytes: ...



def split_frames(buf: bytearray) -> tuple[list[tuple[int, int, bytes]], bool]:
    """Take the whole MBAP frames off the front of ``buf`` as (tid, unit, pdu); the flag is False when
    the next frame cannot be framed (the connection must close)."""
    out: list[tuple[int, int, bytes]] = []
    while len(buf) >= MBAP.size:
        tid, prot, length, unit = MBAP.unpack_from(buf)
        if prot != PROTOCOL_MODBUS or not 1 <= length <= MAX_PDU + 1:  # too long: modbus.screen's close,
            return out, False                                        # told before the body is read
        end = MBAP.size - 1 + length
        if len(buf) < end:
            break
        out.append((tid, unit, bytes(buf[MBAP.size:end])))
        del buf[:end]
    return out, True


class ModbusPortProtocol(asyncio.Protocol):
    """One connection: frames in, one write per answer, in the order asked."""

    def __init__(self, target: ModbusTarget) -> None:
        self.target = target
        self.buf = bytearray()
        self.transport: asyncio.Transport | None = None

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        assert isinstance(transport, asyncio.Transport)
        self.transport = transport
        sock = transport.get_extra_info("socket")
        if sock is not None:
            with contextlib.suppress(OSError):
                sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)

    def data_received(self, data: bytes) -> None:
        if self.transport is None or self.transport.is_closing():
            return
        self.buf += data
        frames, ok = split_frames(self.buf)
        for tid, unit, pdu in frames:
            try:
                reply, close = respond(tid, unit, pdu, self.target.answer_modbus)
            except Exception:  # the map answers exceptions itself; anything else must not stall
                log.exception("modbus port: no answer to a request")
                ok = False
                break
            if reply:
                self.transport.write(reply)
            if close:
                ok = False
                break
        if not ok:
            self.transport.close()


class ModbusPort:
    """The listener, as a server attachment (:meth:`EmulatorServer.attach`)."""

    def __init__(self, target: ModbusTarget, host: str = "127.0.0.1", port: int = 5020,
                 backlog: int = 128) -> None:
        args = listen_args(host, port, backlog)
        self._sock: socket.socket | None = args.get("sock")
        if self._sock is None:
            self._sock = socket.create_server((host, port), backlog=backlog)
        self._sock.listen(backlog)  # connects made before the loop serves wait in the backlog
        self._sock.setblocking(False)
        self.port: int = self._sock.getsockname()[1]
        self.target = target
        self._server: asyncio.Server | None = None
        self._task: asyncio.Task[asyncio.Server] | None = None

    def start(self) -> None:
        loop = asyncio.get_running_loop()
        sock = self._sock
        assert sock is not None
        self._task = loop.create_task(loop.create_server(lambda: ModbusPortProtocol(self.target),
                                                         sock=sock))
        self._task.add_done_callback(self._started)

    def _started(self, task: asyncio.Task[asyncio.Server]) -> None:
        if not task.cancelled() and task.exception() is None:
            self._server = task.result()

    def stop(self) -> None:
        if self._task is not None and not self._task.done():
            self._task.cancel()
        if self._server is not None:
            self._server.close()
        elif self._sock is not None:
            self._sock.close()
        self._sock = None


def attach_modbus_port(server: object, host: str, port: int) -> None:
    """Have ``server`` (an EmulatorServer) serve its Modbus map on ``host``/``port`` too, under
    ``ports["modbus"]`` once started."""
    target: ModbusTarget = server  # type: ignore[assignment]
    backlog = max(1, server.limits.backlog) if hasattr(server, "limits") else 128
    server.attach("modbus", lambda: ModbusPort(target, host, port, backlog))  # type: ignore[attr-defined]
