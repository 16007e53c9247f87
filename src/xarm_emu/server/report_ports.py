"""The report ports (30001 normal 5 Hz, 30002 rich 5 Hz, 30003 develop 100 Hz), manual section 2.1.6.

Each tick encodes one frame (``protocol.reports.ENCODERS``) and writes it to every client whose
socket is keeping up; a slow reader skips frames instead of slowing anyone down. Clients never
write on report ports; a connection is read only until EOF.
"""

from __future__ import annotations

import asyncio
import contextlib
import socket
import time
from collections.abc import Awaitable, Callable

from ..protocol import reports
from .clock import Ticker
from .command_port import set_nodelay

#: A report client whose unsent data (beyond the kernel's buffer) exceeds this many bytes skips frames.
SLOW_READER_BYTES = 16 * 1024
#: Kernel send buffer of a report socket. Small, so that a reader that stalls gets recent frames
#: when it resumes instead of megabytes of old ones (about 4 s of develop frames).
REPORT_SNDBUF = 32 * 1024

#: A stream this many periods behind its schedule or less sends the due frames at once; further
#: behind, it re-anchors and counts the frames it missed (``ReportStreams.frames_missed``).
LATE_FRAMES = 10

#: Report kind -> its standard port, the key of ``reports.ENCODERS`` (section 2.1.6).
KIND_PORTS = {"normal": reports.NORMAL_PORT, "rich": reports.RICH_PORT, "develop": reports.DEVELOP_PORT}


class ReportStreams:
    """The three report streams of one server: their clients, tick loops and counters.

    ``snapshot`` gives the state to report (after the server has caught up on due control periods);
    ``paused`` says whether an injected report pause is on.
    """

    def __init__(self, snapshot: Callable[[], reports.ReportSnapshot], paused: Callable[[], bool],
                 rates: dict[str, float]) -> None:
        self.snapshot = snapshot
        self.paused = paused
        self.rates = rates
        self.clients: dict[str, set[asyncio.StreamWriter]] = {k: set() for k in KIND_PORTS}
        #: Set while a stream has clients; its loop sleeps without waking up otherwise.
        self._has_clients: dict[str, asyncio.Event] = {k: asyncio.Event() for k in KIND_PORTS}
        self.frames_sent: dict[str, int] = {k: 0 for k in KIND_PORTS}
        self.frames_skipped: dict[str, int] = {k: 0 for k in KIND_PORTS}  # per slow client and frame
        #: Due frames never sent because the stream fell more than LATE_FRAMES periods behind (the
        #: process was suspended or starved of CPU); counted, not sent late.
        self.frames_missed: dict[str, int] = {k: 0 for k in KIND_PORTS}
        # Set to a dict to record each report frame's send time (time.perf_counter(); benchmarks).
        self.frame_times: dict[str, list[float]] | None = None
        self.client_tasks: set[asyncio.Task[None]] = set()
        #: Whether a new client of a kind may stay (the server's per-port cap); ``None``: always.
        self.admit: Callable[[str], bool] | None = None

    def on_client(self, kind: str) -> Callable[[asyncio.StreamReader, asyncio.StreamWriter], Awaitable[None]]:
        """The ``asyncio.start_server`` callback of the ``kind`` port."""
        async def serve(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
            if self.admit is not None and not self.admit(kind):
                writer.close()
                return
            set_nodelay(writer)
            sock = writer.get_extra_info("socket")
            if sock is not None:
                with contextlib.suppress(OSError):
                    sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, REPORT_SNDBUF)
            task = asyncio.current_task()
            if task is not None:
                self.client_tasks.add(task)
                task.add_done_callback(self.client_tasks.discard)
            self.clients[kind].add(writer)
            self._has_clients[kind].set()
            try:
                while await reader.read(4096):
                    pass
            except (ConnectionError, OSError):
                pass
            finally:
                self.clients[kind].discard(writer)
                with contextlib.suppress(Exception):
                    writer.close()

        return serve

    async def run(self, kind: str, ticker: Ticker | None) -> None:
        """Send the ``kind`` stream at its rate until cancelled."""
        interval = 1.0 / self.rates[kind]
        encode = reports.ENCODERS[KIND_PORTS[kind]]
        clients = self.clients[kind]
        next_t = time.perf_counter()
        has_clients = self._has_clients[kind]
        while True:
            if not clients:
                has_clients.clear()
                await has_clients.wait()  # no reader: no wake-ups at all
                next_t = time.perf_counter()
            next_t += interval
            now = time.perf_counter()
            if next_t < now - LATE_FRAMES * interval:  # fell far behind (suspended process): re-anchor
                missed = int((now - next_t) / interval)
                self.frames_missed[kind] += missed
                next_t = now + interval
            # A tick that is late by fewer than LATE_FRAMES periods is sent at once: every due frame
            # goes out, the late ones back to back.
            if ticker is not None:
                await ticker.wait_until(next_t)
            else:
                await asyncio.sleep(max(0.0, next_t - time.perf_counter()))
            if not clients or self.paused():
                continue
            frame = encode(self.snapshot())
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

    def transports(self) -> list[asyncio.BaseTransport]:
        """The transports of every report client."""
        return [w.transport for group in self.clients.values() for w in group]
