"""The report ports (30001 normal 5 Hz, 30002 rich 5 Hz, 30003 develop 100 Hz), manual section 2.1.6,
and for firmware with ``FirmwareProfile.realtime_report`` the real-time report (30000, 250 Hz).

At each frame's deadline the process's report sender (:mod:`.report_sender`) encodes it from the
arm's state at that deadline with the encoder of the box's firmware (``reports.encoders_for``: the
manual's 87/145/433-byte frames for 1.x, 135/145/587 bytes for 2.x) and writes it to every client
whose socket is keeping up; a slow reader skips frames instead of slowing anyone down. Clients never
write on report ports; a connection is read here only until EOF.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import socket
import threading
from collections.abc import Awaitable, Callable
from typing import Any

from ..protocol import reports
from ..protocol.firmware import DEFAULT_PROFILE, FirmwareProfile
from . import report_sender
from .command_port import set_nodelay
from .report_sender import SendStream

log = logging.getLogger("xarm_emu.server")

#: Kernel send buffer of a report socket. Small, so that a reader that stalls gets recent frames
#: when it resumes instead of megabytes of old ones (about 4 s of develop frames).
REPORT_SNDBUF = 32 * 1024

#: Report kind -> its standard port, the key of ``reports.ENCODERS`` (section 2.1.6).
KIND_PORTS = {"normal": reports.NORMAL_PORT, "rich": reports.RICH_PORT, "develop": reports.DEVELOP_PORT}
#: The real-time report (port 30000, ``FirmwareProfile.realtime_report``), beside :data:`KIND_PORTS`.
REALTIME_KIND = "realtime"
ALL_KIND_PORTS = {**KIND_PORTS, REALTIME_KIND: reports.REALTIME_PORT}


def kinds_for(profile: FirmwareProfile) -> dict[str, int]:
    """Report kind -> standard port of the streams a box of ``profile`` serves."""
    ports = reports.encoders_for(profile)
    return {k: p for k, p in ALL_KIND_PORTS.items() if p in ports}


def encoders_by_kind(profile: FirmwareProfile) -> dict[str, Callable[[reports.ReportSnapshot], bytes]]:
    """Report kind -> the frame encoder of ``profile``'s firmware."""
    enc = reports.encoders_for(profile)
    return {k: enc[p] for k, p in kinds_for(profile).items()}


class ReportStreams:
    """The report streams of one server: their clients and counters; the frames are made and sent
    by the process's report sender (:mod:`.report_sender`) at their deadlines.

    ``frame`` is called by the sender thread at each deadline, under ``lock`` (the arm's lock):
    ``instant(deadline, interval)`` runs the control periods due by the deadline and says whether
    the frame is still due (``EmulatorServer.report_instant``), ``snapshot`` gives the state to report,
    ``paused`` says whether an injected report pause is on. ``quiet``, when given, is the box's
    pair (``Emulator.mark``, ``Emulator.unchanged``): a frame that carries no clock
    (``reports.CLOCKED_PORTS``) is encoded again only when the box may have changed since the last
    one was encoded, so an arm at rest costs one comparison per frame.
    """

    def __init__(self, snapshot: Callable[[], reports.ReportSnapshot], paused: Callable[[], bool],
                 rates: dict[str, float], profile: FirmwareProfile = DEFAULT_PROFILE,
                 quiet: tuple[Callable[[], Any], Callable[[Any], bool]] | None = None, *,
                 instant: Callable[[float, float], bool] = lambda deadline, interval: True,
                 lock: threading.RLock | None = None) -> None:
        self.snapshot = snapshot
        self.paused = paused
        self.quiet = quiet
        self.instant = instant
        self.rates = rates
        #: The arm's lock: held by the sender from catching up to the last write of each frame.
        self.lock = lock if lock is not None else threading.RLock()
        #: Report kind -> standard port of the streams this box serves (its firmware's).
        self.kinds = kinds_for(profile)
        self.encoders = encoders_by_kind(profile)
        self.clients: dict[str, set[asyncio.StreamWriter]] = {k: set() for k in self.kinds}
        #: Report kind -> the stream the sender writes.
        self.streams = {k: SendStream(k, 1.0 / rates[k], self._framer(k), self.lock) for k in self.kinds}
        self.client_tasks: set[asyncio.Task[None]] = set()
        #: Whether a new client of a kind may stay (the server's per-port cap); ``None``: always.
        self.admit: Callable[[str], bool] | None = None
        self._sender: report_sender.ReportSender | None = None
        self._frame_times: dict[str, list[float]] | None = None
        self._closing = False

    def _framer(self, kind: str) -> Callable[[float], bytes | None]:
        """The frame of ``kind`` for ``deadline`` (sender thread, under the lock): ``None`` while
        reports are paused or closing, ``b""`` when the deadline's state is gone or not reached
        (not sent)."""
        encode = self.encoders[kind]
        interval = 1.0 / self.rates[kind]
        quiet = None if ALL_KIND_PORTS[kind] in reports.CLOCKED_PORTS else self.quiet
        last: list[Any] = [None, b""]  # the box's mark when the last frame was encoded, the frame

        def frame(deadline: float) -> bytes | None:
            if self._closing or self.paused():
                return None
            if not self.instant(deadline, interval):  # the controller at the deadline's period
                return b""
            if quiet is None:
                return encode(self.snapshot())
            mark, unchanged = quiet
            if last[0] is None or not unchanged(last[0]):
                last[1] = encode(self.snapshot())
                last[0] = mark()
            return last[1]  # type: ignore[no-any-return]

        return frame

    def push(self, kind: str) -> bool:
        """Write ``kind``'s frame from the state now to every reader at once, off the sender's
        schedule (the stepped clock's deadlines, ``EmulatorServer.advance_to_report``), under the
        lock; whether every reader took it whole (a small frame into a reader's kernel buffer)."""
        stream = self.streams[kind]
        with self.lock:
            frame = self.encoders[kind](self.snapshot())
            took = [r.offer(frame) and not r.rest for r in stream.readers if not r.dead]
            stream.frames_sent += 1
        return all(took)

    # -- counters (written by the sender thread) -----------------------------------------------
    @property
    def frames_sent(self) -> dict[str, int]:
        return {k: s.frames_sent for k, s in self.streams.items()}

    @property
    def frames_skipped(self) -> dict[str, int]:
        """Frames not written to a slow reader, per reader and frame."""
        return {k: s.frames_skipped for k, s in self.streams.items()}

    @property
    def frames_missed(self) -> dict[str, int]:
        """Due frames never sent: the sender fell more than ``report_sender.LATE_FRAMES`` periods
        behind (the process was suspended or starved of CPU), or the deadline's state was gone or
        not reached when the sender came (``EmulatorServer.report_instant``); counted, not sent."""
        return {k: s.frames_missed for k, s in self.streams.items()}

    @property
    def frames_late(self) -> dict[str, int]:
        """Frames written more than ``report_sender.LATE_AFTER`` after their deadline (the process
        was too busy to make them in time)."""
        return {k: s.frames_late for k, s in self.streams.items()}

    @property
    def frame_times(self) -> dict[str, list[float]] | None:
        """Set to a dict to record each report frame's send time (time.perf_counter(); benchmarks)."""
        return self._frame_times

    @frame_times.setter
    def frame_times(self, value: dict[str, list[float]] | None) -> None:
        self._frame_times = value
        for kind, stream in self.streams.items():
            stream.frame_times = None if value is None else value.setdefault(kind, [])

    # -- lifetime ------------------------------------------------------------------------------
    def start(self, priority: int | None = None) -> str | None:
        """Use the process's report sender (the first user starts it), at real-time ``priority``
        when above 0 (``None``: the sender's default where the system allows it,
        :meth:`~.report_sender.ReportSender.set_priority`); returns why a priority asked for was
        refused."""
        if self._sender is None:
            self._sender = report_sender.acquire()
        return self._sender.set_priority(priority)

    @property
    def sender(self) -> report_sender.ReportSender | None:
        """The process's report sender while this server uses it (:meth:`start` to :meth:`stop`)."""
        return self._sender

    def quiesce(self) -> None:
        """Prepare no more frames (the server is closing): with many arms in one process, the
        frames of those still closing would otherwise keep the event loop busy and delay every
        close behind them."""
        self._closing = True

    def stop(self) -> None:
        """Stop using the sender (after every client is gone; the last user stops it)."""
        if self._sender is not None:
            self._sender = None
            report_sender.release()

    def on_client(self, kind: str) -> Callable[[asyncio.StreamReader, asyncio.StreamWriter], Awaitable[None]]:
        """The ``asyncio.start_server`` callback of the ``kind`` port."""
        async def serve(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
            if self.admit is not None and not self.admit(kind):
                writer.close()
                return
            set_nodelay(writer)
            sock = writer.get_extra_info("socket")
            sender = self._sender
            if sock is None or sender is None:
                writer.close()
                return
            with contextlib.suppress(OSError):
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, REPORT_SNDBUF)
            try:
                out = report_sender.Reader(sock)
            except OSError:  # out of descriptors
                writer.close()
                return
            task = asyncio.current_task()
            if task is not None:
                self.client_tasks.add(task)
                task.add_done_callback(self.client_tasks.discard)
            stream = self.streams[kind]
            self.clients[kind].add(writer)
            sender.add(stream, out)
            peer = writer.get_extra_info("peername")
            host = peer[0] if isinstance(peer, tuple) else "?"
            log.info("%s report client connected from %s", kind, host)
            try:
                while await reader.read(4096):
                    pass
            except (ConnectionError, OSError):
                pass
            finally:
                log.info("%s report client from %s left", kind, host)
                self.clients[kind].discard(writer)
                with contextlib.suppress(OSError):
                    out.sock.shutdown(socket.SHUT_RDWR)  # the connection ends now, not when the sender closes
                sender.remove(stream, out)
                with contextlib.suppress(Exception):
                    writer.close()

        return serve

    def transports(self) -> list[asyncio.BaseTransport]:
        """The transports of every report client."""
        return [w.transport for group in self.clients.values() for w in group]
