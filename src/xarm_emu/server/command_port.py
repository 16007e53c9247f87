"""The command port (502): frames of manual section 2.1.2 in, replies out.

Each reply is one write on a TCP_NODELAY socket, so the SDK reads it in one piece. Protocol 1 (SDK
heartbeat) gets no reply; protocol 0 (standard Modbus TCP) is answered by the standard map
(:mod:`xarm_emu.protocol.modbus`); a frame that cannot be framed closes that connection only. Protocol
ids 2 and 3 are answered alike and echoed (the SDK switches between them on one connection).

Firmware with feedback frames (``FirmwareProfile.feedback``) also pushes unsolicited 21-byte 0xFF feedback
frames on the connection whose command they report (:meth:`CommandProtocol.send_feedback`), as whole writes
between replies; a connection that does not read them gets none (dropped and counted). Decoding is
:class:`~xarm_emu.protocol.frame.FrameDecoder` (sans-IO); the answers come from the server's
:meth:`CommandTarget.answer`.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextlib
import itertools
import logging
import socket
from collections import deque
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
from ..protocol.modbus import respond
from .fairness import (
    COMMAND_SNDBUF,
    DECODE_SLICE,
    MAX_INBOX,
    WRITE_HIGH_WATER,
    BurstLog,
    CommandScheduler,
    Limits,
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
#: Registers whose work reaches the disk (39 delete and 40 save the configuration, manual 2.1.3):
#: their reply goes out when the server's disk worker is done, and the connection's later requests
#: wait behind it; other connections are not held.
DISK_REGISTERS = frozenset({39, 40})
#: Registers whose reply waits for a motion they start (204, load identification: its result):
#: the connection's later requests wait behind it; other connections are not held.
LATER_REGISTERS = frozenset({204})
#: Registers whose reply may wait (either kind above): never answered by the one-frame fast path.
HELD_REGISTERS = DISK_REGISTERS | LATER_REGISTERS


def set_nodelay(endpoint: Any) -> None:
    """TCP_NODELAY on the socket of a transport or stream writer (no effect without one)."""
    sock = endpoint.get_extra_info("socket")
    if sock is not None:
        with contextlib.suppress(OSError):
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)


def _host_of(peer: str) -> str:
    """The address part of ``host:port`` (so a flood from one host repeats one log line)."""
    return peer.rsplit(":", 1)[0] if ":" in peer else peer


class ReadCache:
    """Reply frames of :data:`PURE_READS`, reused while the emulator is unchanged since the reply
    was made (``Emulator.mark``, ``Emulator.unchanged``; none of them shows the clock)."""

    def __init__(self) -> None:
        #: register -> (the emulator's mark, length field, reply after the header)
        self._entries: dict[int, tuple[tuple[int, float], int, bytes]] = {}

    def hit(self, emu: Emulator, tid: int, protocol: int, register: int) -> bytes | None:
        """The reply frame to a parameterless pure read if one was made since which the emulator is
        unchanged, else ``None``."""
        hit = self._entries.get(register)
        if hit is None or not emu.unchanged(hit[0]):
            return None
        return HEADER.pack(tid & 0xFFFF, protocol, hit[1]) + hit[2]

    def reply(self, emu: Emulator, tid: int, protocol: int, register: int) -> bytes:
        """The reply frame to a parameterless pure read (manual 2.1.2 header with ``tid``)."""
        frame = self.hit(emu, tid, protocol, register)
        if frame is not None:
            return frame
        state, values = emu.handle(register, b"")
        made = encode_reply(0, 0, register, state, values)
        entry = self._entries[register] = (emu.mark(), HEADER.unpack_from(made)[2], made[HEADER_SIZE:])
        return HEADER.pack(tid & 0xFFFF, protocol, entry[1]) + entry[2]


class CommandTarget(Protocol):
    """What a command connection needs of its server."""

    emulator: Emulator
    trace: CommandTrace | None
    command_clients: set[CommandProtocol]
    scheduler: CommandScheduler
    burst_log: BurstLog

    @property
    def limits(self) -> Limits: ...

    @property
    def reply_delay(self) -> float: ...

    def answer(self, tid: int, protocol: int, register: int, params: bytes, peer: str = "",
               client: int = 0) -> bytes: ...

    def command_closed(self, client: int) -> None: ...

    def answer_modbus(self, tid: int, unit: int, pdu: bytes, peer: str = "") -> bytes: ...


    def disk_job(self) -> concurrent.futures.Future[Any] | None: ...

    def answer_later(self, tid: int, protocol: int, register: int) -> asyncio.Future[bytes] | None: ...

    def answer_after_disk(self, frame: bytes,
                          job: concurrent.futures.Future[Any]) -> asyncio.Future[bytes]: ...


_client_ids = itertools.count(1)


class CommandProtocol(asyncio.Protocol):
    """One command-port connection; sans-IO decoding, controller calls in the loop thread.

    A read holding exactly one frame, on a connection with nothing waiting, is answered at once;
    otherwise the requests wait in :attr:`pending` and the server's
    :class:`~xarm_emu.server.fairness.CommandScheduler` answers them round-robin with the other
    connections'. Reading stops while :data:`~xarm_emu.server.fairness.MAX_PENDING` requests wait or
    the peer leaves its replies unread (write buffer above the high-water mark), and resumes when
    both have drained: a client that floods the port costs only itself.
    """

    def __init__(self, server: CommandTarget) -> None:
        self.server = server
        self.decoder = FrameDecoder()
        self.transport: asyncio.Transport | None = None
        self.peer = ""
        #: This connection's key in the controller's feedback queue (never 0, never reused).
        self.client_id = next(_client_ids)
        self.feedback_sent = 0
        self.feedback_dropped = 0
        #: Requests read but not answered yet, in order (protocol, tid, register/unit, params).
        self.pending: deque[tuple[int, int, int, bytes]] = deque()
        #: Bytes read but not decoded yet (at most about :data:`MAX_INBOX` before reading stops).
        self.inbox = bytearray()
        self.queued = False  # in the scheduler's ready queue
        self._write_paused = False
        self._read_paused = False
        self._refused = False
        self._partial_since: float | None = None
        self._timer: asyncio.TimerHandle | None = None
        #: The reply of a save/delete waiting for the disk (DISK_REGISTERS); later requests wait.
        self._waiting: asyncio.Future[bytes] | None = None
        self._eof = False  # the peer has closed its sending side (see eof_received)
        self._delayed = 0  # replies held back by an injected reply delay, not written yet

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        self.transport = transport  # type: ignore[assignment]  # uvloop's transports are not subclasses
        peer = transport.get_extra_info("peername")
        self.peer = f"{peer[0]}:{peer[1]}" if isinstance(peer, tuple) and len(peer) >= 2 else str(peer)
        if not self._admit(transport):
            return
        set_nodelay(transport)
        sock = transport.get_extra_info("socket")
        if sock is not None:  # a fixed kernel buffer: unread replies stop the reading early
            with contextlib.suppress(OSError):
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, COMMAND_SNDBUF)
        with contextlib.suppress(AttributeError, ValueError):
            transport.set_write_buffer_limits(high=WRITE_HIGH_WATER)  # type: ignore[attr-defined]
        self.server.command_clients.add(self)
        log.info("command client connected from %s", _host_of(self.peer))
        self._arm_timer()
        if self.server.trace is not None:
            self.server.trace.event(self.server.emulator.time, self.peer, "connect")

    def connection_lost(self, exc: Exception | None) -> None:
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None
        self.pending.clear()
        self.inbox.clear()
        if self._refused:
            return
        self.server.command_clients.discard(self)
        self.server.command_closed(self.client_id)
        log.info("command client from %s left%s", _host_of(self.peer), f" ({exc})" if exc else "")
        if self.server.trace is not None:
            self.server.trace.event(self.server.emulator.time, self.peer, "close")

    def eof_received(self) -> bool:
        """The peer has sent all it will (a TCP half-close): what it sent before is still answered,
        in order, and the connection closes once the last reply is written, as a box that reads its
        socket to the end does. ``True`` keeps the transport open for those replies."""
        self._eof = True
        return not self._close_if_done()

    def _close_if_done(self) -> bool:
        """After the peer's half-close: close once nothing is left to answer; whether it closed."""
        transport = self.transport
        if not self._eof or transport is None:
            return False
        if self.pending or self.inbox or self._waiting is not None or self._delayed:
            return False
        if not transport.is_closing():
            transport.close()  # the replies already written still go out
        return True

    # -- bounds (fairness.Limits) -------------------------------------------------------------------
    def _admit(self, transport: asyncio.BaseTransport) -> bool:
        """Refuse the connection (close it at once) when the port already has its cap of clients."""
        cap = self.server.limits.cap()
        if len(self.server.command_clients) < cap:
            return True
        self._refused = True
        self.server.burst_log.event("cap-command", "command port: %d connections (the cap), refusing new "
                                    "ones (serve --max-connections)", cap)
        transport.close()
        return False

    def _arm_timer(self) -> None:
        timeout = self.server.limits.frame_timeout
        if timeout > 0:
            self._partial_since = asyncio.get_running_loop().time()
            self._timer = asyncio.get_running_loop().call_later(timeout, self._check_partial)

    def _check_partial(self) -> None:
        """Close a connection whose first or partial frame is older than the frame timeout."""
        self._timer = None
        transport = self.transport
        if transport is None or transport.is_closing():
            return
        since = self._partial_since
        loop = asyncio.get_running_loop()
        timeout = self.server.limits.frame_timeout
        if since is None:
            return
        age = loop.time() - since
        if age >= timeout:
            self.server.burst_log.event("frame-timeout", "closing command connection %s: no complete "
                                        "frame for %.0f s (serve --frame-timeout)", self.peer, age,
                                        level=logging.INFO)
            transport.close()
            return
        self._timer = loop.call_later(timeout - age, self._check_partial)

    def _track_partial(self) -> None:
        """Note when the buffered partial frame began (``None`` once whole frames are decoded)."""
        if self.decoder.pending:
            if self._partial_since is None:
                self._partial_since = asyncio.get_running_loop().time()
                if self._timer is None and self.server.limits.frame_timeout > 0:
                    self._timer = asyncio.get_running_loop().call_later(
                        self.server.limits.frame_timeout, self._check_partial)
        else:
            self._no_partial()

    def _no_partial(self) -> None:
        """No frame is awaited in part: the frame timer stops (it runs only while the first frame or
        the rest of one is awaited, so a loop serving whole frames keeps no timer; see
        ``EmulatorServer._nap``)."""
        self._partial_since = None
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None

    # -- flow control -------------------------------------------------------------------------------
    def pause_writing(self) -> None:
        """The peer leaves its replies unread: stop reading its requests."""
        self._write_paused = True
        self._update_reading()

    def resume_writing(self) -> None:
        self._write_paused = False
        self._update_reading()
        if self.pending or self.inbox:
            self.server.scheduler.wake(self)

    def _update_reading(self) -> None:
        transport = self.transport
        if transport is None or transport.is_closing():
            return
        stop = self._write_paused or len(self.inbox) >= MAX_INBOX
        if stop and not self._read_paused:
            self._read_paused = True
            transport.pause_reading()
        elif not stop and self._read_paused:
            self._read_paused = False
            transport.resume_reading()

    def has_work(self) -> bool:
        transport = self.transport
        return bool(self.pending or self.inbox) and not self._write_paused and self._waiting is None \
            and transport is not None and not transport.is_closing()

    # -- requests -----------------------------------------------------------------------------------
    def data_received(self, data: bytes) -> None:
        transport = self.transport
        if transport is None or transport.is_closing():
            return
        # Fast path: the usual case, exactly one whole private-protocol frame in this read.
        n = len(data)
        if n > HEADER_SIZE and not self.decoder.pending and not self.inbox and not self.pending \
                and self._waiting is None:
            tid, prot, length = HEADER.unpack_from(data)
            if length + HEADER_SIZE == n and length <= MAX_LENGTH and prot in PRIVATE_PROTOCOLS \
                    and data[6] not in HELD_REGISTERS:
                if self._timer is not None or self._partial_since is not None:
                    self._no_partial()
                self._reply(transport, self.server.answer(tid, prot, data[6], data[7:], self.peer,
                                                          self.client_id))
                return
        # Otherwise the bytes wait and are decoded a slice at a time as the scheduler serves them,
        # so one large read never holds the loop.
        self.inbox += data
        self._update_reading()
        self.server.scheduler.wake(self)

    def _decode_slice(self) -> bool:
        """Decode the next :data:`DECODE_SLICE` bytes of :attr:`inbox` into :attr:`pending`;
        ``False`` when the bytes cannot be framed (the connection is then closed)."""
        chunk = bytes(self.inbox[:DECODE_SLICE])
        del self.inbox[:DECODE_SLICE]
        try:
            frames = self.decoder.feed(chunk)
        except FrameError as exc:
            log.info("closing command connection: %s", exc)
            self.inbox.clear()
            self.pending.clear()
            if self.transport is not None:
                self.transport.close()
            return False
        for req in frames:
            self.pending.append((req.protocol, req.tid, req.register, req.params))  # type: ignore[union-attr]
        self._track_partial()
        return True

    def serve(self, batch: int) -> int:
        """Answer up to ``batch`` waiting requests in one write; returns how many were taken."""
        transport = self.transport
        pending = self.pending
        if transport is None or transport.is_closing():
            pending.clear()
            self.inbox.clear()
            return 0
        answer = self.server.answer
        out = []
        taken = 0
        while taken < batch:
            if not pending:
                if not self.inbox or not self._decode_slice():
                    break
                continue
            prot, tid, register, params = pending.popleft()
            taken += 1
            if prot in PRIVATE_PROTOCOLS:
                frame = answer(tid, prot, register, params, self.peer, self.client_id)
                job = self.server.disk_job() if register in DISK_REGISTERS else None
                if job is not None:  # this reply when the disk is done; the replies before it now
                    self._waiting = self.server.answer_after_disk(frame, job)
                    self._waiting.add_done_callback(self._disk_done)
                    break
                later = self.server.answer_later(tid, prot, register) if register in LATER_REGISTERS else None
                if later is not None:  # this reply when its motion is over; the replies before it now
                    self._waiting = later
                    later.add_done_callback(self._disk_done)
                    break
                out.append(frame)
            elif prot == PROTOCOL_HEARTBEAT:
                continue
            elif prot == PROTOCOL_STANDARD:
                reply, close = respond(tid, register, params, self._answer_modbus)
                if reply:
                    out.append(reply)
                if close:  # modbus.screen: the replies so far go out, then the connection closes
                    pending.clear()
                    self.inbox.clear()
                    if out:
                        self._reply(transport, b"".join(out))
                    transport.close()
                    return taken
            else:
                log.info("closing command connection: unknown protocol id %d", prot)
                pending.clear()
                self.inbox.clear()
                transport.close()
                return taken
        if transport.is_closing():
            return taken
        if out:
            self._reply(transport, out[0] if len(out) == 1 else b"".join(out))
        self._update_reading()
        self._close_if_done()
        return taken

    def _disk_done(self, fut: asyncio.Future[bytes]) -> None:
        """The disk has answered a save/delete: its reply goes out and the connection goes on."""
        self._waiting = None
        transport = self.transport
        if transport is None or transport.is_closing() or fut.cancelled():
            return
        self._reply(transport, fut.result())
        self._update_reading()
        if self.pending or self.inbox:
            self.server.scheduler.wake(self)
        self._close_if_done()

    def _answer_modbus(self, tid: int, unit: int, pdu: bytes) -> bytes:
        """One standard Modbus request the screen passed (:func:`~xarm_emu.protocol.modbus.respond`),
        answered by the server and traced with this connection's peer."""
        return self.server.answer_modbus(tid, unit, pdu, self.peer)

    def _reply(self, transport: asyncio.Transport, payload: bytes) -> None:
        """One write per read, now or after the injected reply delay."""
        delay = self.server.reply_delay
        if delay > 0.0:
            self._delayed += 1
            asyncio.get_running_loop().call_later(delay, self._send, payload)
        else:
            transport.write(payload)

    def _send(self, payload: bytes) -> None:
        self._delayed -= 1
        if self.transport is not None and not self.transport.is_closing():
            self.transport.write(payload)
            self._close_if_done()

    # -- feedback frames (FirmwareProfile.feedback) -----------------------------------------------
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
