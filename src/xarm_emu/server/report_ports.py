"""The report ports (30001 normal 5 Hz, 30002 rich 5 Hz, 30003 develop 100 Hz), manual section 2.1.6,
and for firmware >= 2.1.0 the real-time report (30000, 250 Hz).

Before each frame's deadline the server's loop encodes it with the encoder of the box's firmware
(``reports.encoders_for``: the manual's 87/145/433-byte frames for 1.x, 135/145/587 bytes for 2.x);
the process's report sender (:mod:`.report_sender`) writes it at the deadline to every client whose
socket is keeping up; a slow reader skips frames instead of slowing anyone down. Clients never
write on report ports; a connection is read here only until EOF.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
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
from . import report_sender
from .command_port import set_nodelay
from .report_sender import SendStream

log = logging.getLogger("xarm_emu.server")

#: Kernel send buffer of a report socket. Small, so that a reader that stalls gets recent frames
#: when it resumes instead of megabytes of old ones (about 4 s of develop frames).
REPORT_SNDBUF = 32 * 1024

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
    """The report streams of one server: their clients and counters; the frames go out from the
    process's report sender (:mod:`.report_sender`) on an absolute schedule.

    ``snapshot`` gives the state to report (after the server has caught up on due control periods);
    ``paused`` says whether an injected report pause is on; ``revision``, when given, the box's
    revision after catching up (``Emulator.revision``): a frame that carries no clock
    (``reports.CLOCKED_PORTS``) is encoded once per revision and sent again while the box stays as
    it was, as an arm at rest does.
    """

    def __init__(self, snapshot: Callable[[], reports.ReportSnapshot], paused: Callable[[], bool],
                 rates: dict[str, float], profile: FirmwareProfile = DEFAULT_PROFILE,
                 revision: Callable[[], int] | None = None, *,
                 current_revision: Callable[[], int] | None = None,
                 horizon: Callable[[], float] | None = None) -> None:
        self.snapshot = snapshot
        self.paused = paused
        self.revision = revision
        self.rates = rates
        #: Report kind -> standard port of the streams this box serves (its firmware's).
        self.kinds = kinds_for(profile)
        self.encoders = encoders_by_kind(profile)
        self.clients: dict[str, set[asyncio.StreamWriter]] = {k: set() for k in self.kinds}
        #: Report kind -> the stream the sender writes.
        self.streams = {k: SendStream(k, 1.0 / rates[k], self._preparer(k), *(
            (current_revision, horizon) if ALL_KIND_PORTS[k] not in reports.CLOCKED_PORTS else ()))
            for k in self.kinds}
        self.client_tasks: set[asyncio.Task[None]] = set()
        #: Whether a new client of a kind may stay (the server's per-port cap); ``None``: always.
        self.admit: Callable[[str], bool] | None = None
        self._sender: report_sender.ReportSender | None = None
        self._frame_times: dict[str, list[float]] | None = None
        self._closing = False

    def _preparer(self, kind: str) -> Callable[[], bytes | None]:
        encode = self.encoders[kind]
        revision = self.revision
        if revision is None or ALL_KIND_PORTS[kind] in reports.CLOCKED_PORTS:
            def prepare() -> bytes | None:
                return None if self._closing or self.paused() else encode(self.snapshot())

            return prepare
        last: list[Any] = [None, b""]  # the revision of the last frame encoded, the frame

        def prepare_once() -> bytes | None:
            if self._closing or self.paused():
                return None
            now = revision()
            if now != last[0]:
                last[1] = encode(self.snapshot())
                last[0] = now
            return last[1]  # type: ignore[no-any-return]

        return prepare_once

    def refresh(self) -> None:
        """Prepare again every frame already prepared for a deadline not yet reached: a command
        answered since then changed the box, and no frame sent after its reply may show the state
        from before it (a client that reads its reply and then the report must never see the
        command undone)."""
        now = time.perf_counter()
        for stream in self.streams.values():
            if not stream.readers:
                continue
            with stream.sending:  # the sender takes a frame as standing for a deadline under it
                # prepared for the coming deadline, or asked for by now (a loop that is late)
                pending = (stream.frame_deadline == stream.deadline
                           or stream.deadline - now <= report_sender.LEAD)
            if pending:
                stream.publish(stream.deadline)
                with stream.sending:  # a send that took the old frame has finished writing it
                    pass

    def invalidate(self) -> None:
        """No published frame stands for a later deadline (reports paused: nothing the box's
        revision shows)."""
        for stream in self.streams.values():
            stream.invalidate()

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
        """Due frames never sent because the sender fell more than ``report_sender.LATE_FRAMES``
        periods behind (the process was suspended or starved of CPU); counted, not sent late."""
        return {k: s.frames_missed for k, s in self.streams.items()}

    @property
    def frames_stale(self) -> dict[str, int]:
        """Frames sent on time with the previous state because the loop had not published (blocked)."""
        return {k: s.frames_stale for k, s in self.streams.items()}

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

    def quiesce(self) -> None:
        """Prepare no more frames (the server is closing): with many arms in one process, the
        frames of those still closing would otherwise keep the event loop busy and delay every
        close behind them."""
        self._closing = True
        self.invalidate()

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
            sender.add(stream, out, asyncio.get_running_loop())
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
