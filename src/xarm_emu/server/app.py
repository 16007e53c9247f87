"""The asyncio emulator: command port, report ports and the control loop.

- Command port (502): frames of section 2.1.2; each reply is one write on a
  TCP_NODELAY socket (research note section 0.5). Protocol 1 (SDK heartbeat)
  gets no reply; protocol 0 (standard Modbus TCP) is answered by the standard map
  (controller.modbus_map); a frame that cannot be framed closes that connection only.
- Report ports (30001 normal 5 Hz, 30002 rich 5 Hz, 30003 develop 100 Hz), section
  2.1.6: each tick encodes one frame and writes it to every client whose socket is
  keeping up; a slow reader skips frames instead of slowing anyone down.
- The control loop steps the controller on its period in real or scaled time.
- The admin channel (fault injection, :mod:`.admin`) listens on loopback only, and only when
  ``ServerConfig.admin`` is set.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import socket
import struct
import threading
import time
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from ..controller import modbus_map
from ..controller.base import PERIOD
from ..controller.emulator import Emulator
from ..protocol import reports
from ..protocol.frame import (
    COMMAND_PORT,
    MAX_LENGTH,
    PRIVATE_PROTOCOLS,
    PROTOCOL_HEARTBEAT,
    PROTOCOL_STANDARD,
    FrameDecoder,
    FrameError,
    encode_reply,
)
from .admin import AdminProtocol, admin_host, derive_admin_port
from .clock import ScaledClock, Ticker
from .trace import CommandTrace

if TYPE_CHECKING:
    from ..viewer.app import Viewer

log = logging.getLogger("xarm_emu.server")

#: A report client whose unsent data (beyond the kernel's buffer) exceeds this many bytes skips frames.
SLOW_READER_BYTES = 16 * 1024
#: Kernel send buffer of a report socket. Small, so that a reader that stalls gets recent frames
#: when it resumes instead of megabytes of old ones (about 4 s of develop frames).
REPORT_SNDBUF = 32 * 1024


@dataclass
class ServerConfig:
    host: str = "127.0.0.1"
    port: int = COMMAND_PORT
    normal_port: int = reports.NORMAL_PORT
    rich_port: int = reports.RICH_PORT
    develop_port: int = reports.DEVELOP_PORT
    speed: float = 1.0  # controller seconds per wall second
    admin: bool = False  # fault-injection channel (issue 5 item 5), off by default
    admin_port: int | None = None  # None: command port + admin.ADMIN_PORT_OFFSET (0 if port is 0)
    #: Lockstep: controller time advances only by the admin channel's ``step`` command (an outside
    #: harness drives the clock); needs ``admin``.
    stepped: bool = False
    view: bool = False  # the 3D view in the browser (viewer/app.py), off by default
    view_host: str = "127.0.0.1"
    view_port: int = 8080
    #: Append every command-port request and reply to this JSON-lines file (server/trace.py).
    trace: Path | None = None
    #: Faults and inputs at given controller times, from this TOML file (server/faults.py).
    faults: Path | None = None
    report_rates: dict[str, float] = field(default_factory=lambda: {
        "develop": reports.DEVELOP_RATE, "normal": reports.NORMAL_RATE, "rich": reports.RICH_RATE})


_ENCODERS: dict[str, Callable[[reports.ReportSnapshot], bytes]] = {
    "develop": reports.encode_develop,
    "normal": reports.encode_normal,
    "rich": reports.encode_rich,
}


def _nodelay(writer: asyncio.StreamWriter) -> None:
    sock = writer.get_extra_info("socket")
    if sock is not None:
        with contextlib.suppress(OSError):
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)


class _CommandProtocol(asyncio.Protocol):
    """One command-port connection; sans-IO decoding, controller calls in the loop thread."""

    def __init__(self, server: EmulatorServer) -> None:
        self.server = server
        self.decoder = FrameDecoder()
        self.transport: asyncio.Transport | None = None
        self.peer = ""

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        self.transport = transport  # type: ignore[assignment]  # uvloop's transports are not subclasses
        sock = transport.get_extra_info("socket")
        if sock is not None:
            with contextlib.suppress(OSError):
                sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        peer = transport.get_extra_info("peername")
        self.peer = f"{peer[0]}:{peer[1]}" if isinstance(peer, tuple) and len(peer) >= 2 else str(peer)
        self.server.command_clients.add(self)
        if self.server.trace is not None:
            self.server.trace.event(self.server.emulator.time, self.peer, "connect")

    def connection_lost(self, exc: Exception | None) -> None:
        self.server.command_clients.discard(self)
        if self.server.trace is not None:
            self.server.trace.event(self.server.emulator.time, self.peer, "close")

    def data_received(self, data: bytes) -> None:
        transport = self.transport
        if transport is None or transport.is_closing():
            return
        # Fast path: the usual case, exactly one whole private-protocol frame in this read.
        n = len(data)
        if n >= 7 and not self.decoder.pending:
            tid, prot, length = _HEADER.unpack_from(data)
            if length + 6 == n and length <= MAX_LENGTH and prot in PRIVATE_PROTOCOLS:
                self._reply(transport, self.server.answer(tid, prot, data[6], data[7:], self.peer))
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
                out.append(answer(req.tid, prot, req.register, req.params, self.peer))  # type: ignore[union-attr]
            elif prot == PROTOCOL_HEARTBEAT:
                continue
            elif prot == PROTOCOL_STANDARD:
                out.append(modbus_map.answer(self.server, req.tid, req.register, req.params))  # type: ignore[union-attr]
            else:
                log.info("closing command connection: unknown protocol id %d", prot)
                transport.close()
                return
        if out:
            self._reply(transport, out[0] if len(out) == 1 else b"".join(out))

    def _reply(self, transport: asyncio.Transport, payload: bytes) -> None:
        """One write per read (research note 0.5), now or after the injected reply delay."""
        delay = self.server.reply_delay
        if delay > 0.0:
            asyncio.get_running_loop().call_later(delay, self._send, payload)
        else:
            transport.write(payload)

    def _send(self, payload: bytes) -> None:
        if self.transport is not None and not self.transport.is_closing():
            self.transport.write(payload)


#: Shortest sleep of the control loop when woken before a step was due (seconds).
#: The control loop runs the due control periods at least this often (wall seconds); commands,
#: report frames and admin actions run them before they act (EmulatorServer.catch_up).
IDLE_WAKE = 0.02
#: Most control periods one catch-up runs (1 s of controller time): beyond it the rest stays due for
#: the next one, so at a --speed the machine cannot sustain the emulator runs slower, not stalled.
MAX_CATCH_UP = 250

_HEADER = struct.Struct(">HHH")
_TID_PROT = struct.Struct(">HH")

#: Registers whose reply with no parameters is a pure read of the controller's state (manual 2.1.3:
#: version, serial number, state, cmdnum, error/warning, TCP pose, joints). Between two control steps,
#: and until any other command or injection, their answer cannot change, so it is computed once.
PURE_READS = frozenset({1, 2, 13, 14, 15, 41, 42})


class EmulatorServer:
    """Runs one emulator on its ports."""

    def __init__(self, emulator: Emulator, config: ServerConfig | None = None) -> None:
        self.emulator = emulator
        self.config = config or ServerConfig()
        self.clock = ScaledClock(PERIOD, self.config.speed)
        self.command_clients: set[_CommandProtocol] = set()
        self.report_clients: dict[str, set[asyncio.StreamWriter]] = {k: set() for k in _ENCODERS}
        #: Set while a report stream has clients; its loop sleeps without waking up otherwise.
        self._has_clients: dict[str, asyncio.Event] = {k: asyncio.Event() for k in _ENCODERS}
        self._servers: list[asyncio.AbstractServer] = []
        self._tasks: list[asyncio.Task[None]] = []
        self.ports: dict[str, int] = {}
        self.reply_delay = 0.0  # fault injection: seconds before each reply
        self.report_pause_until = 0.0  # fault injection: loop time until which reports pause
        self.frames_sent: dict[str, int] = {k: 0 for k in _ENCODERS}
        self.frames_skipped: dict[str, int] = {k: 0 for k in _ENCODERS}  # per slow client and frame
        # Set to a dict to record each report frame's send time (time.perf_counter(); benchmarks).
        self.frame_times: dict[str, list[float]] | None = None
        self._stopped = asyncio.Event()
        #: register -> (emulator generation, reply frame after tid and protocol)
        self._read_cache: dict[int, tuple[int, bytes]] = {}
        self._loop: asyncio.AbstractEventLoop | None = None
        self._ticker: Ticker | None = None
        self.viewer: Viewer | None = None
        self.trace: CommandTrace | None = None  # opened by start() when ``config.trace`` is set
        self._client_tasks: set[asyncio.Task[None]] = set()
        self.admin_clients: set[AdminProtocol] = set()
        if self.config.faults is not None:  # checked whole here, before any port opens
            from .faults import read_schedule, schedule

            n = schedule(self, read_schedule(self.config.faults))
            log.info("fault schedule %s: %d entries", self.config.faults, n)

    async def start(self) -> None:
        loop = asyncio.get_running_loop()
        cfg = self.config
        if cfg.stepped and not cfg.admin:
            raise ValueError("lockstep (stepped) time is driven through the admin channel: add --admin")
        if cfg.trace is not None and self.trace is None:
            try:
                self.trace = CommandTrace(cfg.trace)
            except OSError as exc:
                raise ValueError(f"cannot open the trace file {cfg.trace}: {exc.strerror or exc}") from None
        srv = await loop.create_server(lambda: _CommandProtocol(self), cfg.host, cfg.port, reuse_address=True)
        self._servers.append(srv)
        self.ports["command"] = srv.sockets[0].getsockname()[1]
        report_ports = (("normal", cfg.normal_port), ("rich", cfg.rich_port), ("develop", cfg.develop_port))
        for kind, port in report_ports:
            s = await asyncio.start_server(self._report_client(kind), cfg.host, port, reuse_address=True)
            self._servers.append(s)
            self.ports[kind] = s.sockets[0].getsockname()[1]
        if cfg.admin:
            admin_port = cfg.admin_port
            if admin_port is None:
                admin_port = 0 if cfg.port == 0 else derive_admin_port(self.ports["command"])
            # Loopback only, whatever ``host`` is (the protocol also refuses non-loopback peers): the
            # arm's own address when that is a loopback one, else 127.0.0.1.
            a = await loop.create_server(lambda: AdminProtocol(self), admin_host(cfg.host), admin_port,
                                         reuse_address=True)
            self._servers.append(a)
            self.ports["admin"] = a.sockets[0].getsockname()[1]
        if cfg.view:
            from ..viewer.app import Viewer  # optional dependency (viser), imported on demand

            self.viewer = Viewer(self.emulator, cfg.view_host, cfg.view_port)
            self.viewer.start()
            self.ports["view"] = self.viewer.port
        self._ticker = Ticker()
        self._loop = loop
        self.clock.start(loop.time())
        self._tasks.append(asyncio.create_task(self._control_loop()))
        for kind in _ENCODERS:
            self._tasks.append(asyncio.create_task(self._report_loop(kind)))

    def _report_client(
            self, kind: str) -> Callable[[asyncio.StreamReader, asyncio.StreamWriter], Awaitable[None]]:
        async def on_client(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
            _nodelay(writer)
            sock = writer.get_extra_info("socket")
            if sock is not None:
                with contextlib.suppress(OSError):
                    sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, REPORT_SNDBUF)
            task = asyncio.current_task()
            if task is not None:
                self._client_tasks.add(task)
                task.add_done_callback(self._client_tasks.discard)
            self.report_clients[kind].add(writer)
            self._has_clients[kind].set()
            try:
                # Clients never write on report ports (research note section 1.2); read until EOF.
                while await reader.read(4096):
                    pass
            except (ConnectionError, OSError):
                pass
            finally:
                self.report_clients[kind].discard(writer)
                with contextlib.suppress(Exception):
                    writer.close()

        return on_client

    def catch_up(self) -> int:
        """Run the control periods that are due by now (real or scaled time).

        Returns the number of periods run. Called before every command, report frame and admin
        action, so that whatever anyone observes is the state after every period that has elapsed:
        stepping in batches this way is indistinguishable from stepping on every period, and the
        control loop only has to wake up now and then (:data:`IDLE_WAKE`) when nobody is looking.
        """
        loop = self._loop
        if loop is None or self.config.stepped:
            return 0
        n = self.clock.due(loop.time(), MAX_CATCH_UP)
        if n:
            self.emulator.step(n)
        return n

    def answer(self, tid: int, protocol: int, register: int, params: bytes, peer: str = "") -> bytes:
        """The reply frame to one private-protocol request (manual 2.1.2)."""
        self.catch_up()
        emu = self.emulator
        if not params and register in PURE_READS:
            hit = self._read_cache.get(register)
            if hit is not None and hit[0] == emu.generation:
                tail = hit[1]
            else:
                state, reply = emu.handle(register, params)
                tail = encode_reply(0, 0, register, state, reply)[4:]
                self._read_cache[register] = (emu.generation, tail)
            frame = _TID_PROT.pack(tid & 0xFFFF, protocol) + tail
        else:
            state, reply = emu.handle(register, params)
            frame = encode_reply(tid, protocol, register, state, reply)
        if self.trace is not None:
            self.trace.command(self.emulator.time, peer, tid, protocol, register, params, frame)
        return frame

    def advance(self, seconds: float) -> int:
        """Lockstep: run ``seconds`` of controller time now (whole control periods); returns the
        number of periods run."""
        n = max(0, round(seconds / PERIOD))
        self.emulator.step(n)
        return n

    async def _control_loop(self) -> None:
        """Keep controller time up with the wall clock while nobody asks (see :meth:`catch_up`)."""
        while True:
            backlog = self.catch_up() == MAX_CATCH_UP  # more is due: yield to clients, then go on
            if self.trace is not None:
                self.trace.flush()
            await asyncio.sleep(0.0 if backlog else IDLE_WAKE)

    async def _report_loop(self, kind: str) -> None:
        loop = asyncio.get_running_loop()
        rate = self.config.report_rates[kind]
        interval = 1.0 / rate
        encode = _ENCODERS[kind]
        clients = self.report_clients[kind]
        ticker = self._ticker
        next_t = time.perf_counter()
        has_clients = self._has_clients[kind]
        while True:
            if not clients:
                has_clients.clear()
                await has_clients.wait()  # no reader: no wake-ups at all
                next_t = time.perf_counter()
            next_t += interval
            now = time.perf_counter()
            if next_t < now - interval:  # fell far behind (suspended process): re-anchor
                next_t = now + interval
            if ticker is not None:
                await ticker.wait_until(next_t)
            else:
                await asyncio.sleep(max(0.0, next_t - time.perf_counter()))
            if not clients or loop.time() < self.report_pause_until:
                continue
            self.catch_up()
            frame = encode(self.emulator.snapshot())
            if self.frame_times is not None:
                self.frame_times.setdefault(kind, []).append(time.perf_counter())
            for w in tuple(clients):
                transport = w.transport
                if transport.is_closing():
                    clients.discard(w)
                    continue
                if transport.get_write_buffer_size() > SLOW_READER_BYTES:
                    self.frames_skipped[kind] += 1
                    continue  # slow reader: skip whole frames, never block
                transport.write(frame)
            self.frames_sent[kind] += 1

    def drop_clients(self, abort: bool = False) -> int:
        """Close every command and report connection (fault injection ``drop-clients``); returns
        how many were closed. Admin connections stay. ``abort`` discards unsent data."""
        n = 0
        transports: list[asyncio.BaseTransport] = [c.transport for c in self.command_clients
                                                   if c.transport is not None]
        transports += [w.transport for group in self.report_clients.values() for w in group]
        for t in transports:
            if abort and hasattr(t, "abort"):  # uvloop's transports are not asyncio subclasses
                t.abort()
                n += 1
            elif not t.is_closing():
                t.close()
                n += 1
        return n

    def pause_reports(self, seconds: float) -> None:
        """No report frame goes out for ``seconds`` of wall time (fault injection ``report-pause``)."""
        self.report_pause_until = asyncio.get_running_loop().time() + seconds

    def reports_paused(self) -> bool:
        return asyncio.get_running_loop().time() < self.report_pause_until

    async def close(self) -> None:
        if self.viewer is not None:
            self.viewer.stop()
            self.viewer = None
        for t in self._tasks:
            t.cancel()
        for t in self._tasks:
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await t
        self._tasks.clear()
        if self._ticker is not None:
            self._ticker.close()
            self._ticker = None
        for s in self._servers:
            s.close()
        self.drop_clients(abort=True)
        for a in tuple(self.admin_clients):
            if a.transport is not None:
                a.transport.abort()
        handlers = tuple(self._client_tasks)
        if handlers:  # aborted transports end their handlers (EOF); cancel only stragglers
            _, late = await asyncio.wait(handlers, timeout=1.0)
            for t in late:
                t.cancel()
            await asyncio.gather(*late, return_exceptions=True)
        for s in self._servers:
            with contextlib.suppress(Exception):
                await s.wait_closed()
        self._servers.clear()
        for _ in range(3):  # let connection_lost callbacks close the sockets
            await asyncio.sleep(0)
        if self.trace is not None:
            self.trace.close()
            self.trace = None
        self._stopped.set()

    async def serve_forever(self) -> None:
        """Start (unless started) and serve until :meth:`close`."""
        if not self._servers:
            await self.start()
        await self._stopped.wait()


def new_event_loop(use_uvloop: bool = False) -> asyncio.AbstractEventLoop:
    """A fresh event loop; uvloop's when asked for and installed (Linux, macOS)."""
    if use_uvloop:
        try:
            import uvloop  # type: ignore[import-not-found]

            return uvloop.new_event_loop()
        except ImportError:
            pass
    return asyncio.new_event_loop()


class ServerThread:
    """The emulator server on a background thread with its own event loop (tests, embedding)."""

    def __init__(self, emulator: Emulator, config: ServerConfig | None = None, *,
                 use_uvloop: bool = False) -> None:
        self.server = EmulatorServer(emulator, config)
        self.loop = new_event_loop(use_uvloop)
        self._thread = threading.Thread(target=self._run, name="xarm-emu-server", daemon=True)
        self._ready = threading.Event()
        self._error: BaseException | None = None

    @property
    def emulator(self) -> Emulator:
        return self.server.emulator

    @property
    def ports(self) -> dict[str, int]:
        return self.server.ports

    def _run(self) -> None:
        asyncio.set_event_loop(self.loop)
        try:
            self.loop.run_until_complete(self.server.start())
        except BaseException as exc:  # noqa: BLE001 - reported to the starting thread
            self._error = exc
            with contextlib.suppress(Exception):
                self.loop.run_until_complete(self.server.close())
            self.loop.close()
            self._ready.set()
            return
        self._ready.set()
        self.loop.run_forever()

    def start(self) -> ServerThread:
        self._thread.start()
        self._ready.wait(10)
        if self._error is not None:
            self._thread.join(10)
            raise self._error
        return self

    def call(self, fn: Callable[[], object]) -> object:
        """Run ``fn`` in the server's loop thread and return its result."""
        async def wrapper() -> object:
            self.server.catch_up()
            try:
                return fn()
            finally:
                self.server.emulator.touch()

        return asyncio.run_coroutine_threadsafe(wrapper(), self.loop).result(10)

    def stop(self) -> None:
        if not self._thread.is_alive():
            return
        fut = asyncio.run_coroutine_threadsafe(self.server.close(), self.loop)
        with contextlib.suppress(Exception):
            fut.result(10)
        self.loop.call_soon_threadsafe(self.loop.stop)
        self._thread.join(10)
        self.loop.close()

    def __enter__(self) -> ServerThread:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()
