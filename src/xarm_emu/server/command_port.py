"""The command port (502): frames of manual section 2.1.2 in, replies out.

Each reply is one write on a TCP_NODELAY socket, so the SDK reads it in one piece. Protocol 1 (SDK
heartbeat) gets no reply; protocol 0 (standard Modbus TCP) is answered by the standard map
(:mod:`xarm_emu.protocol.modbus`); a frame that cannot be framed closes that connection only. Protocol
ids 2 and 3 are answered alike and echoed (the SDK switches between them on one connection).

Firmware >= 2.0.102 also pushes unsolicited 21-byte 0xFF feedback frames on the connection whose
command they report (:meth:`CommandProtocol.send_feedback`), as whole writes between replies; a
connection that does not read them gets none (dropped and counted). Decoding is
:class:`~xarm_emu.protocol.frame.FrameDecoder` (sans-IO); the answers come from the server's
:meth:`CommandTarget.answer`.
"""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import logging
import socket
from typing import Any, Protocol

from ..controller.emulator import Emulator
from ..protocol.frame import (
    HEADER,
    HEADER_SIZE,
    MAX_LENGTH,
    PRIVATE_PROTOCOLS,
    PROTOCOL_HEARTBEAT,
    PROTOCOL_STANDARD,
    FrameDecoder,
    FrameError,
    encode_reply,
)
from .trace import CommandTrace

log = logging.getLogger("xarm_emu.server")

#: A command connection whose unsent data (beyond the kernel's buffer) exceeds this many bytes gets no
#: feedback frames (they are dropped and counted, as report frames to a slow reader are skipped).
FEEDBACK_SLOW_BYTES = 16 * 1024

#: Registers whose reply with no parameters is a pure read of the controller's state (manual 2.1.3:
#: version, serial number, state, cmdnum, error/warning, TCP pose, joints). Between two control steps,
#: and until any other command or injection, their answer cannot change, so it is computed once.
PURE_READS = frozenset({1, 2, 13, 14, 15, 41, 42})


def set_nodelay(endpoint: Any) -> None:
    """TCP_NODELAY on the socket of a transport or stream writer (no effect without one)."""
    sock = endpoint.get_extra_info("socket")
    if sock is not None:
        with contextlib.suppress(OSError):
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)


class ReadCache:
    """Reply frames of :data:`PURE_READS`, reused while the emulator's generation stays the same."""

    def __init__(self) -> None:
        #: register -> (emulator generation, length field, reply after the header)
        self._entries: dict[int, tuple[int, int, bytes]] = {}

    def reply(self, emu: Emulator, tid: int, protocol: int, register: int) -> bytes:
        """The reply frame to a parameterless pure read (manual 2.1.2 header with ``tid``)."""
        hit = self._entries.get(register)
        if hit is None or hit[0] != emu.generation:
            state, values = emu.handle(register, b"")
            frame = encode_reply(0, 0, register, state, values)
            hit = (emu.generation, HEADER.unpack_from(frame)[2], frame[HEADER_SIZE:])
            self._entries[register] = hit
        return HEADER.pack(tid & 0xFFFF, protocol, hit[1]) + hit[2]


class CommandTarget(Protocol):
    """What a command connection needs of its server."""

    emulator: Emulator
    trace: CommandTrace | None
    command_clients: set[CommandProtocol]

    @property
    def reply_delay(self) -> float: ...

    def answer(self, tid: int, protocol: int, register: int, params: bytes, peer: str = "",
               client: int = 0) -> bytes: ...

    def command_closed(self, client: int) -> None: ...

    def answer_modbus(self, tid: int, unit: int, pdu: bytes) -> bytes: ...


_client_ids = itertools.count(1)


class CommandProtocol(asyncio.Protocol):
    """One command-port connection; sans-IO decoding, controller calls in the loop thread."""

    def __init__(self, server: CommandTarget) -> None:
        self.server = server
        self.decoder = FrameDecoder()
        self.transport: asyncio.Transport | None = None
        self.peer = ""
        #: This connection's key in the controller's feedback queue (never 0, never reused).
        self.client_id = next(_client_ids)
        self.feedback_sent = 0
        self.feedback_dropped = 0

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        self.transport = transport  # type: ignore[assignment]  # uvloop's transports are not subclasses
        set_nodelay(transport)
        peer = transport.get_extra_info("peername")
        self.peer = f"{peer[0]}:{peer[1]}" if isinstance(peer, tuple) and len(peer) >= 2 else str(peer)
        self.server.command_clients.add(self)
        if self.server.trace is not None:
            self.server.trace.event(self.server.emulator.time, self.peer, "connect")

    def connection_lost(self, exc: Exception | None) -> None:
        self.server.command_clients.discard(self)
        self.server.command_closed(self.client_id)
        if self.server.trace is not None:
            self.server.trace.event(self.server.emulator.time, self.peer, "close")

    def data_received(self, data: bytes) -> None:
        transport = self.transport
        if transport is None or transport.is_closing():
            return
        # Fast path: the usual case, exactly one whole private-protocol frame in this read.
        n = len(data)
        if n > HEADER_SIZE and not self.decoder.pending:
            tid, prot, length = HEADER.unpack_from(data)
            if length + HEADER_SIZE == n and length <= MAX_LENGTH and prot in PRIVATE_PROTOCOLS:
                self._reply(transport, self.server.answer(tid, prot, data[6], data[7:], self.peer,
                                                          self.client_id))
                return
        try:
            frames = self.decoder.feed(data)
        except FrameError as exc:
            log.info("closing command connection: %s", exc)
            transport.close()
            return
        answer = self.server.answer
        out = []
        for req in frames:
            prot = req.protocol  # type: ignore[union-attr]
            if prot in PRIVATE_PROTOCOLS:
                out.append(answer(req.tid, prot, req.register, req.params, self.peer,  # type: ignore[union-attr]
                                  self.client_id))
            elif prot == PROTOCOL_HEARTBEAT:
                continue
            elif prot == PROTOCOL_STANDARD:
                out.append(self.server.answer_modbus(req.tid, req.register, req.params))  # type: ignore[union-attr]
            else:
                log.info("closing command connection: unknown protocol id %d", prot)
                transport.close()
                return
        if out:
            self._reply(transport, out[0] if len(out) == 1 else b"".join(out))

    def _reply(self, transport: asyncio.Transport, payload: bytes) -> None:
        """One write per read, now or after the injected reply delay."""
        delay = self.server.reply_delay
        if delay > 0.0:
            asyncio.get_running_loop().call_later(delay, self._send, payload)
        else:
            transport.write(payload)

    def _send(self, payload: bytes) -> None:
        if self.transport is not None and not self.transport.is_closing():
            self.transport.write(payload)

    # -- feedback frames (firmware >= 2.0.102) ----------------------------------------------------
    def send_feedback(self, frame: bytes) -> bool:
        """Write one unsolicited 0xFF feedback frame as one whole write between replies; ``False``
        (the frame dropped and counted) when the connection is closing or its reader is not keeping
        up."""
        transport = self.transport
        if transport is None or transport.is_closing() or (
                transport.get_write_buffer_size() > FEEDBACK_SLOW_BYTES):
            self.feedback_dropped += 1
            return False
        transport.write(frame)
        self.feedback_sent += 1
        return True
