"""``xarm-emu proxy``: a transparent relay between a program and a control box, recording both ways.

The proxy listens on the box's standard ports (502: the command port, with standard Modbus-TCP on the
same port; 30000-30003: the reports, manual 2.1.6) and, for every connection a program opens, opens
one to the same port of the box and copies every byte both ways unchanged, in order, as it arrives.
It never sends anything of its own to the box: no probe, no keep-alive, no connection the program did
not open; when either side closes, the other is closed after what was already read is written.

What passes is queued to a :class:`~.xrec.RecordWriter`, which cuts frames, decodes them and
compresses on its own thread, so recording adds no work to a byte's way through. A full socket
buffer on one side pauses reading on the other (back-pressure), as a direct connection would.
The time a command-port chunk spends inside the proxy (read to written) is measured for every chunk
(:attr:`Proxy.hold_times`).
"""

from __future__ import annotations

import asyncio
import logging
import socket
import time
from dataclasses import dataclass, field

from ..protocol.frame import COMMAND_PORT
from ..protocol.reports import DEVELOP_PORT, NORMAL_PORT, REALTIME_PORT, RICH_PORT
from .xrec import TO_BOX, TO_PROGRAM, RecordWriter

log = logging.getLogger("xarm_emu.proxy")

#: The box's standard ports the proxy relays.
STANDARD_PORTS = (COMMAND_PORT, REALTIME_PORT, NORMAL_PORT, RICH_PORT, DEVELOP_PORT)
#: Seconds to wait for the box to accept a connection before closing the program's.
CONNECT_TIMEOUT = 5.0


@dataclass
class ProxyConfig:
    """Where the proxy listens and where it forwards: standard port -> port number on each side."""

    target: str
    host: str = "127.0.0.1"
    listen: dict[int, int] = field(default_factory=lambda: {p: p for p in STANDARD_PORTS})
    to: dict[int, int] = field(default_factory=lambda: {p: p for p in STANDARD_PORTS})

    @classmethod
    def offsets(cls, target: str, host: str = "127.0.0.1", listen_offset: int = 0,
                to_offset: int = 0) -> ProxyConfig:
        """Every standard port, shifted by ``listen_offset`` where the proxy listens and by
        ``to_offset`` at the box (tests and proxies without root use them)."""
        return cls(target, host, {p: p + listen_offset for p in STANDARD_PORTS},
                   {p: p + to_offset for p in STANDARD_PORTS})


class _Half(asyncio.Protocol):
    """One socket of a relayed connection; ``other`` is the socket it copies to."""

    def __init__(self, link: _Link, direction: int) -> None:
        self.link, self.direction = link, direction
        self.transport: asyncio.Transport | None = None
        self.other: _Half | None = None
        self.pending: list[bytes] = []

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        self.transport = transport  # type: ignore[assignment]
        if self.direction == TO_BOX:  # the program connected: connect to the box for it
            self.link.task = asyncio.get_running_loop().create_task(self.link.proxy._connect_box(self.link))

    def data_received(self, data: bytes) -> None:
        t0 = time.perf_counter()
        other = self.other
        if other is None or other.transport is None:
            self.pending.append(data)  # the box is not connected yet
        else:
            other.transport.write(data)
        self.link.seen(t0, self.direction, data)

    def eof_received(self) -> bool | None:
        other = self.other
        if other is not None and other.transport is not None and other.transport.can_write_eof():
            other.transport.write_eof()
            return True  # keep our side open for the other direction
        return None

    def connection_lost(self, exc: Exception | None) -> None:
        self.link.lost()

    def pause_writing(self) -> None:  # our peer reads slowly: stop reading from the other side
        if self.other is not None and self.other.transport is not None:
            self.other.transport.pause_reading()

    def resume_writing(self) -> None:
        if self.other is not None and self.other.transport is not None:
            self.other.transport.resume_reading()


class _Link:
    """A program's connection and the proxy's connection to the box for it."""

    def __init__(self, proxy: Proxy, conn: int, port: int) -> None:
        self.proxy, self.conn, self.port = proxy, conn, port
        self.program = _Half(self, TO_BOX)
        self.box = _Half(self, TO_PROGRAM)
        self.program.other, self.box.other = self.box, self.program
        self.closed = False
        self.task: asyncio.Task[None] | None = None  # connecting to the box

    def seen(self, t0: float, direction: int, data: bytes) -> None:
        p = self.proxy
        if self.port == COMMAND_PORT:
            p.hold_times.append(time.perf_counter() - t0)
        p.bytes[direction] += len(data)
        if p.recorder is not None:
            p.recorder.data(t0 - p.t0, self.conn, self.port, direction, data)

    def lost(self) -> None:
        if self.closed:
            return
        self.closed = True
        for half in (self.program, self.box):
            if half.transport is not None:
                half.transport.close()
        if self.proxy.recorder is not None:
            self.proxy.recorder.closed(self.conn, self.port)
        self.proxy.links.discard(self)


class Proxy:
    """The relay of :class:`ProxyConfig` (module docstring); ``recorder`` records what passes."""

    def __init__(self, config: ProxyConfig, recorder: RecordWriter | None = None) -> None:
        self.config = config
        self.recorder = recorder
        self.t0 = recorder._t0 if recorder is not None else time.perf_counter()
        self.hold_times: list[float] = []
        self.bytes = [0, 0]
        self.links: set[_Link] = set()
        self.ports: dict[int, int] = {}
        self._servers: list[asyncio.Server] = []
        self._conns = 0

    async def start(self) -> None:
        """Listen on every port of the configuration (0: a free port; :attr:`ports` has them)."""
        loop = asyncio.get_running_loop()
        try:
            for std, listen in self.config.listen.items():
                srv = await loop.create_server(lambda std=std: self._accept(std),  # type: ignore[misc]
                                               self.config.host, listen, reuse_address=True)
                self._servers.append(srv)
                self.ports[std] = srv.sockets[0].getsockname()[1]
        except OSError:
            await self.close()
            raise

    def _accept(self, std: int) -> _Half:
        self._conns += 1
        link = _Link(self, self._conns, std)
        self.links.add(link)
        return link.program

    async def _connect_box(self, link: _Link) -> None:
        loop = asyncio.get_running_loop()
        prog = link.program.transport
        if prog is None:
            return
        prog.pause_reading()
        peer = prog.get_extra_info("peername")
        if self.recorder is not None:
            self.recorder.opened(link.conn, link.port, f"{peer[0]}:{peer[1]}" if peer else "")
        try:
            await asyncio.wait_for(loop.create_connection(
                lambda: link.box, self.config.target, self.config.to[link.port]), CONNECT_TIMEOUT)
        except (OSError, TimeoutError) as exc:
            log.info("box %s:%d refused a connection (%s); closing the program's",
                     self.config.target, self.config.to[link.port], getattr(exc, "strerror", None) or exc)
            link.lost()
            return
        box = link.box.transport
        if box is not None:
            sock = box.get_extra_info("socket")
            if sock is not None:
                sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            for data in link.program.pending:
                box.write(data)
            link.program.pending.clear()
        if not link.closed:
            prog.resume_reading()

    async def close(self) -> None:
        for srv in self._servers:
            srv.close()
        for link in list(self.links):
            link.lost()
        for srv in self._servers:
            await srv.wait_closed()
        self._servers = []

    def latency(self) -> dict[str, float]:
        """Percentiles (seconds) of the time command-port chunks spent in the proxy."""
        times = sorted(self.hold_times)
        if not times:
            return {}

        def pct(q: float) -> float:
            return times[min(len(times) - 1, int(q * len(times)))]

        return {"p50": pct(0.5), "p90": pct(0.9), "p99": pct(0.99), "max": times[-1], "n": float(len(times))}
