"""Fair service of the command port (manual 2.1.2) and bounds on every port.

- :class:`CommandScheduler`: requests that arrive faster than they are answered wait in a bounded
  queue per connection; the queues are served round-robin in bounded batches, each round short, so
  the control loop and the report streams (2.1.6) keep their schedule whatever the command load.
- :class:`Limits`: the per-port connection cap, the partial-frame timeout and the accept backlog
  (``xarm-emu serve --max-connections/--frame-timeout/--backlog``).
- :class:`BurstLog`: one log line for a burst of identical events (refused connections, out of file
  descriptors), then a count.
"""

from __future__ import annotations

import asyncio
import logging
import resource
import time
from collections import deque
from dataclasses import dataclass
from typing import Any, Protocol

log = logging.getLogger("xarm_emu.server")

#: Request bytes one connection may have waiting; beyond it the server stops reading from it.
MAX_INBOX = 64 * 1024
#: Request bytes decoded at a time (a few dozen frames at most), so no read holds the loop long.
DECODE_SLICE = 256
#: Kernel send buffer of a command socket: fixed (no autotuning to megabytes), so a peer that
#: reads nothing holds at most this much of its replies in the kernel before reading stops.
COMMAND_SNDBUF = 64 * 1024
#: Requests of one connection answered per turn (one write carries their replies): a few, so a
#: client that pipelines and reads its replies takes a short turn and another client's request,
#: answered as soon as the loop reads it, waits behind little.
BATCH = 4
#: Longest round of command service (seconds) before the loop polls its sockets and runs its other
#: callbacks (report ticks, control-loop wake-ups): about one turn of a pipelining client.
ROUND_TIME = 0.00005
#: Unsent reply bytes of a connection beyond which the server stops reading from it until the peer
#: has read them (transport write-buffer high-water mark).
WRITE_HIGH_WATER = 64 * 1024
#: File descriptors kept for the log, the trace, saves and the listening sockets.
RESERVED_FDS = 64
#: Ports a server accepts clients on, each with its own cap (command and the three report ports).
CAPPED_PORTS = 4


#: The largest per-port cap the default gives, whatever the open-file limit.
MAX_DEFAULT_CONNECTIONS = 1000


def raise_file_limit() -> tuple[int, int]:
    """Raise the soft open-file limit (``RLIMIT_NOFILE``) to the hard one, as servers do at start,
    with one log line; returns the (old, new) soft limit (equal when nothing could be raised)."""
    try:
        soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    except (OSError, ValueError):
        return 0, 0
    if hard == resource.RLIM_INFINITY:
        hard = max(soft, 1 << 20) if soft != resource.RLIM_INFINITY else soft
    if soft == resource.RLIM_INFINITY or soft >= hard:
        return soft, soft
    try:
        resource.setrlimit(resource.RLIMIT_NOFILE, (hard, resource.getrlimit(resource.RLIMIT_NOFILE)[1]))
    except (OSError, ValueError) as exc:
        log.warning("open-file limit stays %d (cannot raise it to %d: %s)", soft, hard, exc)
        return soft, soft
    log.info("open-file limit raised from %d to %d: %d connections per port", soft, hard,
             default_max_connections())
    return soft, hard


def default_max_connections() -> int:
    """Connections per port that fit the process's open-file limit (soft ``RLIMIT_NOFILE``) with
    :data:`RESERVED_FDS` to spare, shared by the :data:`CAPPED_PORTS` ports, at most
    :data:`MAX_DEFAULT_CONNECTIONS` (``serve`` first raises the soft limit, :func:`raise_file_limit`)."""
    try:
        soft, _ = resource.getrlimit(resource.RLIMIT_NOFILE)
    except (OSError, ValueError):
        soft = 1024
    if soft == resource.RLIM_INFINITY or soft <= 0:
        soft = 1 << 16
    return max(8, min(MAX_DEFAULT_CONNECTIONS, (soft - RESERVED_FDS) // CAPPED_PORTS))


@dataclass
class Limits:
    """Bounds on the clients of one server (``ServerConfig.limits``)."""

    #: Connections accepted per port (command and each report port); 0: :func:`default_max_connections`.
    max_connections: int = 0
    #: A command connection whose partial frame (or whose first frame) is older than this many
    #: seconds is closed; 0: never.
    frame_timeout: float = 60.0
    #: Listen backlog of every port (the kernel caps it at ``net.core.somaxconn``).
    backlog: int = 4096

    def cap(self) -> int:
        return self.max_connections if self.max_connections > 0 else default_max_connections()


class BurstLog:
    """Logs the first of a burst of like events, then at most one line per ``window`` seconds with
    the number of events since the last line."""

    def __init__(self, logger: logging.Logger, window: float = 10.0) -> None:
        self.logger = logger
        self.window = window
        self._last: dict[str, float] = {}
        self._count: dict[str, int] = {}

    def event(self, key: str, message: str, *args: Any, level: int = logging.WARNING) -> bool:
        """Count one event; log it when its key has been quiet for ``window`` seconds (with the
        number of events held back meanwhile). Returns whether a line was written."""
        now = time.monotonic()
        last = self._last.get(key)
        if last is not None and now - last < self.window:
            self._count[key] = self._count.get(key, 0) + 1
            return False
        held = self._count.pop(key, 0)
        self._last[key] = now
        if held:
            self.logger.log(level, message + " (%d more like it in the last %.0f s)", *args, held,
                            now - (last or now))
        else:
            self.logger.log(level, message, *args)
        return True


class Served(Protocol):
    """A connection the scheduler serves (:class:`~xarm_emu.server.command_port.CommandProtocol`)."""

    queued: bool

    def serve(self, batch: int) -> int: ...

    def has_work(self) -> bool: ...


class CommandScheduler:
    """Round-robin service of the command connections that have requests waiting.

    Each turn answers at most :data:`BATCH` requests of one connection; a round stops after
    :data:`ROUND_TIME` and the rest waits for the next round, scheduled behind the loop's other
    callbacks (report ticks, control-loop wake-ups, I/O)."""

    def __init__(self, batch: int = BATCH, round_time: float = ROUND_TIME) -> None:
        self.batch = batch
        self.round_time = round_time
        self.ready: deque[Served] = deque()
        self._scheduled = False
        #: Rounds run and rounds that stopped on their time limit (diagnostics).
        self.rounds = 0
        self.cut_short = 0

    @property
    def idle(self) -> bool:
        return not self.ready

    def wake(self, conn: Served) -> None:
        """``conn`` has requests waiting: serve it in a coming round."""
        if not conn.queued:
            conn.queued = True
            self.ready.append(conn)
        if not self._scheduled:
            self._scheduled = True
            asyncio.get_running_loop().call_soon(self._round)

    def _round(self) -> None:
        self._scheduled = False
        self.rounds += 1
        ready = self.ready
        deadline = time.perf_counter() + self.round_time
        while ready:
            conn = ready.popleft()
            conn.queued = False
            conn.serve(self.batch)
            if conn.has_work():
                conn.queued = True
                ready.append(conn)
            if time.perf_counter() >= deadline:
                self.cut_short += 1
                break
        if ready and not self._scheduled:
            self._scheduled = True
            asyncio.get_running_loop().call_soon(self._round)
