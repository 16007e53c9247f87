"""The report ports (30001 normal 5 Hz, 30002 rich 5 Hz, 30003 develop 100 Hz), manual section 2.1.6,
and for firmware >= 2.1.0 the real-time report (30000, 250 Hz).

Each tick encodes one frame with the encoder of the box's firmware (``reports.encoders_for``: the
manual's 87/145/433-byte frames for 1.x, 135/145/587 bytes for 2.x) and writes it to every client
whose socket is keeping up; a slow reader skips frames instead of slowing anyone down. Clients never
write on report ports; a connection is read only until EOF.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import socket
import time
from collections.abc import Awaitable, Callable
from typing import Any

from ..controller.handlers.extras import extra_state
from ..controller.reduced import reduced_of
from ..model import rotations as rot
from ..protocol import reports
from ..protocol.firmware import DEFAULT_PROFILE, FirmwareProfile
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
#: The real-time report of firmware >= 2.1.0 (port 30000), beside :data:`KIND_PORTS`.
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


def firmware2_fields(emu: Any, snap: reports.ReportSnapshot) -> reports.ReportSnapshot:
    """Fill what the firmware 2.x frames carry beyond the manual's (rich bytes 284-287 and 433-586,
    the real-time report) from the controller, for a box of a 2.x profile.

    Bytes 284-287 carry the counter of registers 74/75 (``user_counter``), which both SDKs read there.
    The reduced-mode block and the motion flags are the values registers 53, 66 and 80 answer.
    """
    ctl = emu.controller
    s = ctl.settings
    snap.counter = int(ctl.user_counter) & 0xFFFFFFFF
    roll, pitch, yaw = snap.pose[3:6]
    if all(math.isfinite(x) for x in (roll, pitch, yaw)):
        snap.pose_aa = tuple(float(x) for x in rot.rpy_to_axis_angle(roll, pitch, yaw))
    snap.report_current = bool(s.report_current)
    extra = extra_state(ctl)
    snap.approx_motion = bool(extra.approx_motion)
    snap.cart_continuous = bool(extra.cartesian_velocity_continuous)
    reduced = reduced_of(ctl)  # registers 47-50, 58 and 60, as register 53 reports them
    snap.reduced_mode = bool(reduced.on)
    snap.reduced_tcp_boundary = tuple(int(x) for x in s.boundary)
    snap.fence = bool(s.boundary_on)
    snap.reduced_max_tcp_speed = float(reduced.tcp_speed)
    snap.reduced_max_joint_speed = float(reduced.joint_speed)
    if reduced.joint_ranges:
        snap.reduced_joint_ranges = tuple(float(x) for x in reduced.joint_ranges)
    snap.collision_rebound = bool(reduced.rebound)
    snap.timestamp_us = int(round(ctl.time * 1e6))
    snap.joint_accelerations = tuple(float(x) for x in ctl.qdd) + (0.0,) * (7 - ctl.dof)
    return snap


class ReportStreams:
    """The three report streams of one server: their clients, tick loops and counters.

    ``snapshot`` gives the state to report (after the server has caught up on due control periods);
    ``paused`` says whether an injected report pause is on.
    """

    def __init__(self, snapshot: Callable[[], reports.ReportSnapshot], paused: Callable[[], bool],
                 rates: dict[str, float], profile: FirmwareProfile = DEFAULT_PROFILE) -> None:
        self.snapshot = snapshot
        self.paused = paused
        self.rates = rates
        #: Report kind -> standard port of the streams this box serves (its firmware's).
        self.kinds = kinds_for(profile)
        self.encoders = encoders_by_kind(profile)
        self.clients: dict[str, set[asyncio.StreamWriter]] = {k: set() for k in self.kinds}
        #: Set while a stream has clients; its loop sleeps without waking up otherwise.
        self._has_clients: dict[str, asyncio.Event] = {k: asyncio.Event() for k in self.kinds}
        self.frames_sent: dict[str, int] = {k: 0 for k in self.kinds}
        self.frames_skipped: dict[str, int] = {k: 0 for k in self.kinds}  # per slow client and frame
        #: Due frames never sent because the stream fell more than LATE_FRAMES periods behind (the
        #: process was suspended or starved of CPU); counted, not sent late.
        self.frames_missed: dict[str, int] = {k: 0 for k in self.kinds}
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
        encode = self.encoders[kind]
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
