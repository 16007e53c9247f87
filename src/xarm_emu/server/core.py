"""The server core: one arm's ports and the control loop that keeps its clock (:class:`EmulatorServer`).

- Command port (502), :mod:`.command_port`: frames of manual section 2.1.2.
- Report ports (30001-30003, and 30000 with ``FirmwareProfile.realtime_report``), :mod:`.report_ports`:
  section 2.1.6.
- Feedback frames (firmware with ``FirmwareProfile.feedback``): the controller's feedback events
  (:mod:`xarm_emu.controller.core.feedback`), drained after every command and every catch-up and written
  to the command connection each belongs to (:meth:`EmulatorServer.deliver_feedback`).
- The admin channel (fault injection, :mod:`.admin` over :mod:`.admin_port`) listens on loopback
  only, and only when ``ServerConfig.admin`` is set.
- The control loop steps the controller on its period in real or scaled time; commands, report
  frames and admin requests first run the periods that are due (:meth:`EmulatorServer.catch_up`).

Extras beside the server (the 3D view) are attached by the code that composes it
(:meth:`EmulatorServer.attach`); nothing here imports them.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextlib
import errno
import io
import logging
import math
import os
import socket
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

from ..controller import modbus_map
from ..controller.applications import identification
from ..controller.core.config import ConfigStore, load_or_create_admin_token
from ..controller.core.feedback import FeedbackQueue, feedback_queue
from ..controller.core.interface import PERIOD, WARN_PARAMETER
from ..controller.devices import ft_sensor
from ..controller.emulator import Emulator
from ..protocol import reports
from ..protocol.admin import admin_host, derive_admin_port
from ..protocol.frame import COMMAND_PORT, encode_reply
from .admin_port import AdminProtocol
from .clock import ScaledClock
from .command_port import PURE_READS, CommandProtocol, ReadCache
from .disk import DiskWorker
from .fairness import BurstLog, CommandScheduler, Limits
from .logs import CodeWatch
from .report_ports import ALL_KIND_PORTS, REALTIME_KIND, ReportStreams
from .report_sender import Wake
from .trace import CommandTrace

log = logging.getLogger("xarm_emu.server")


@dataclass
class ServerConfig:
    host: str = "127.0.0.1"
    port: int = COMMAND_PORT
    normal_port: int = reports.NORMAL_PORT
    rich_port: int = reports.RICH_PORT
    develop_port: int = reports.DEVELOP_PORT
    #: The real-time report (``FirmwareProfile.realtime_report``; 0: a free port; a 1.x box has none).
    #: ``None``: two below the rich port, as the standard ports are (30000 beside 30002; free when that is 0).
    realtime_port: int | None = None

    def realtime_port_number(self) -> int:
        """The port the real-time report listens on (see :attr:`realtime_port`)."""
        if self.realtime_port is not None:
            return self.realtime_port
        return self.rich_port - (reports.RICH_PORT - reports.REALTIME_PORT) if self.rich_port > 2 else 0
    speed: float = 1.0  # controller seconds per wall second
    admin: bool = False  # fault-injection channel (server/admin.py), off by default
    admin_port: int | None = None  # None: command port + admin.ADMIN_PORT_OFFSET (0 if port is 0)
    #: Lockstep: controller time advances only by the admin channel's ``step`` command (an outside
    #: harness drives the clock); needs ``admin``.
    stepped: bool = False
    view: bool = False  # the 3D view in the browser, attached by its composer (xarm-emu serve)
    view_host: str = "127.0.0.1"
    view_port: int = 8080
    #: Append every command-port request and reply to this JSON-lines file (server/trace.py).
    trace: Path | None = None
    #: Rotate the trace to ``<file>.1`` when it reaches this many bytes (0: never).
    trace_max_bytes: int = 0
    #: The admin channel's token; ``None``: the per-user token file's (created when missing,
    #: controller/core/config.py ``load_or_create_admin_token``).
    admin_token: str | None = None
    #: Faults and inputs at given controller times, from this TOML file (server/faults.py); read by
    #: the code that composes the server (faults.schedule_file), not by the server.
    faults: Path | None = None
    report_rates: dict[str, float] = field(default_factory=lambda: {
        "develop": reports.DEVELOP_RATE, "normal": reports.NORMAL_RATE, "rich": reports.RICH_RATE,
        REALTIME_KIND: reports.REALTIME_RATE})
    #: Connection caps, the partial-frame timeout and the listen backlog (server/fairness.py).
    limits: Limits = field(default_factory=Limits)
    #: Real-time (SCHED_FIFO) priority of the process's report sender thread, 1-99 (Linux, needs the
    #: privilege); 0 (the default of a server made in a library user's process): normal scheduling;
    #: None (``serve``'s default): ``report_sender.DEFAULT_PRIORITY`` where the system allows it,
    #: else normal scheduling without a warning.
    report_priority: int | None = 0


class Attachment(Protocol):
    """Something served beside the arm (the 3D view): started in the server's loop, stopped with it."""

    port: int

    def start(self) -> None: ...

    def stop(self) -> None: ...


#: The control loop runs the due control periods at least this often (wall seconds); commands,
#: report frames and admin actions run them before they act (EmulatorServer.catch_up).
IDLE_WAKE = 0.02
#: With nobody connected and nothing moving, the control loop runs the due periods only this often
#: (wall seconds; sooner when a scheduled action falls due, and at most 0.8 * MAX_CATCH_UP periods
#: of controller time apart): nothing observes the arm in between, and the first command, report
#: frame or admin request of a new connection runs the due periods first (catch_up).
UNOBSERVED_WAKE = 0.8
#: Most control periods one catch-up runs (1 s of controller time): beyond it the rest stays due for
#: the next one, so at a --speed the machine cannot sustain the emulator runs slower, not stalled.
#: A report frame whose deadline one catch-up cannot reach is not sent (counted missed), never one
#: of an earlier period (:meth:`EmulatorServer.report_instant`): while the controller lags that far
#: behind its clock, its reports pause.
MAX_CATCH_UP = 250




class ListenSocket(socket.socket):
    """A listening socket that keeps one spare file descriptor for running out of them.

    When ``accept`` fails with EMFILE or ENFILE, the spare is closed, every connection waiting in the
    accept queue is accepted and closed at once (its client sees the connection end, as beyond the
    cap) and the spare is opened again: the queue never fills with clients nobody will serve, nothing
    waits on a timer, and the next client is served as soon as any descriptor is free again (a client
    leaving frees one). The loop's exception handler hears of each such failure (one log line per
    burst, :meth:`EmulatorServer._quiet_accept_errors`).

    Without a spare (another thread took the descriptor it freed, or ENOBUFS/ENOMEM), the error goes
    to asyncio, which stops reading the socket and tries again after its retry delay (1 s); the
    accepts of that same loop tick then end at once (:class:`BlockingIOError`) instead of each
    scheduling another retry. The spare is taken again by the first ``accept`` that can."""

    _paused_until = 0.0
    _spare: io.FileIO | None = None

    def accept(self) -> tuple[socket.socket, Any]:
        if time.monotonic() < self._paused_until:
            raise BlockingIOError(errno.EAGAIN, "accepting paused: out of file descriptors")
        if self._spare is None:
            self.take_spare()
        try:
            return super().accept()
        except OSError as exc:
            if exc.errno not in OUT_OF_FDS:
                raise
            if exc.errno in SPARE_HELPS and self._shed(exc):
                raise BlockingIOError(errno.EAGAIN, "out of file descriptors: waiting clients refused") \
                    from exc
            self._paused_until = time.monotonic() + ACCEPT_PAUSE
            raise

    def take_spare(self) -> bool:
        """Open the spare descriptor if it is not held; whether it is held now."""
        if self._spare is None:
            try:
                self._spare = open(os.devnull, "rb", buffering=0)  # noqa: SIM115  # held, closed by close()
            except OSError:
                return False
        return True

    def _shed(self, exc: OSError) -> bool:
        """Out of descriptors: with the spare's descriptor, accept and close what waits in the queue
        (at most a backlog's worth at a time), then take the spare again. Whether there was a spare."""
        spare = self._spare
        if spare is None:
            return False
        self._spare = None
        spare.close()
        try:
            for _ in range(SHED_BATCH):
                try:
                    fd, _addr = self._accept()  # type: ignore[attr-defined]  # socket.socket's own
                except OSError:  # the queue is empty, or the descriptor went to another thread
                    break
                os.close(fd)
        finally:
            self.take_spare()
        with contextlib.suppress(RuntimeError):  # outside a running loop: nobody to tell
            asyncio.get_running_loop().call_exception_handler({
                "message": "socket.accept() out of file descriptors: waiting clients refused",
                "exception": exc, "socket": self})
        return True

    def close(self) -> None:
        spare, self._spare = self._spare, None
        if spare is not None:
            spare.close()
        super().close()


#: accept() errors that mean the process (or system) is out of descriptors or buffers.
OUT_OF_FDS = frozenset({errno.EMFILE, errno.ENFILE, errno.ENOBUFS, errno.ENOMEM})
#: Of those, the ones a spare descriptor helps with.
SPARE_HELPS = frozenset({errno.EMFILE, errno.ENFILE})
#: Waiting connections a listening socket refuses per accept call while out of descriptors.
SHED_BATCH = 1024
#: Seconds accept stays paused after running out of descriptors without a spare (asyncio retries
#: after 1 s).
ACCEPT_PAUSE = 0.5


def listen_args(host: str, port: int, backlog: int) -> dict[str, Any]:
    """Keyword arguments of ``create_server``/``start_server`` for one port: a :class:`ListenSocket`
    bound to ``host`` when that is one address. ``::`` (or ``[::]``) is dual stack: one IPv6 socket
    with ``IPV6_V6ONLY`` off, so IPv4 clients reach it too (asyncio alone would listen on IPv6
    only). A name with several addresses is left to asyncio (one socket per address)."""
    bare = host.strip("[]")
    try:
        infos = socket.getaddrinfo(bare or None, port, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE)
    except socket.gaierror:
        infos = []
    dual = bare == "::" and socket.has_ipv6
    if not dual and len({(i[0], i[4][:2]) for i in infos}) != 1:
        return {"host": host, "port": port, "reuse_address": True, "backlog": backlog}
    family, addr = (socket.AF_INET6, ("::", port)) if dual else (infos[0][0], infos[0][4])
    sock = ListenSocket(family, socket.SOCK_STREAM)
    try:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        if family == socket.AF_INET6:
            with contextlib.suppress(OSError, AttributeError):
                sock.setsockopt(socket.IPPROTO_IPV6, socket.IPV6_V6ONLY, 0 if dual else 1)
        sock.bind(addr)
    except OSError:
        sock.close()
        raise
    sock.setblocking(False)
    sock.take_spare()
    return {"sock": sock, "backlog": backlog}


class EmulatorServer:
    """Runs one emulator on its ports (an :class:`~xarm_emu.server.admin.AdminTarget`)."""

    def __init__(self, emulator: Emulator, config: ServerConfig | None = None) -> None:
        self.emulator = emulator
        self.config = config or ServerConfig()
        self.clock = ScaledClock(PERIOD, self.config.speed)
        self.command_clients: set[CommandProtocol] = set()
        profile = emulator.firmware
        defaults = reports.rates_for(profile)
        rates = {kind: defaults[port] for kind, port in ALL_KIND_PORTS.items() if port in defaults}
        rates.update(self.config.report_rates)
        #: The arm's lock: whoever advances, commands or reads the emulator holds it (the event
        #: loop for commands, admin requests and its catch-ups; the report sender for each frame).
        self.lock = threading.RLock()
        self.reports = ReportStreams(lambda: emulator.snapshot(), self.reports_paused, rates, profile,
                                     (emulator.mark, emulator.unchanged), instant=self.report_instant,
                                     lock=self.lock)
        #: The controller's feedback events (``FirmwareProfile.feedback``), else ``None``.
        self.feedback: FeedbackQueue | None = (feedback_queue(emulator.controller) if profile.feedback
                                               else None)
        #: Feedback frames dropped because their connection was gone or not reading.
        self.feedback_dropped = 0
        self.feedback_sent = 0
        self._feedback_soon = False
        self._servers: list[asyncio.AbstractServer] = []
        self._tasks: list[asyncio.Task[None]] = []
        self.ports: dict[str, int] = {}
        #: Seconds each command reply waits (fault injection ``reply-delay``; 0: none).
        self.reply_delay = 0.0
        self._report_pause_until = 0.0  # fault injection: monotonic time until which reports pause
        self._loop_thread = 0  # the event loop's thread (start())
        self._stopped = asyncio.Event()
        self._read_cache = ReadCache()
        #: Replies held until a motion is over (register 204): (future, tid, protocol, register,
        #: (peer, params, time asked) for the trace).
        self._later: list[tuple[asyncio.Future[bytes], int, int, int, tuple[str, bytes, float] | None]] = []
        self._held_trace: tuple[str, bytes, float] | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        #: name -> factory of what the composer attached; started by start() (:meth:`attach`).
        self._attach: dict[str, Callable[[], Attachment]] = {}
        self.attachments: dict[str, Attachment] = {}
        self.trace: CommandTrace | None = None  # opened by start() when ``config.trace`` is set
        self.admin_clients: set[AdminProtocol] = set()
        self.admin_token: str | None = None  # set by start() with the admin channel
        #: Named checkpoints of the emulator (admin ``checkpoint-save``), in memory only.
        self.checkpoints: dict[str, object] = {}
        self._init_bounds()
        self.disk: DiskWorker | None = None  # started by start(): saves and the trace write through it

    # -- bounds and fairness (server/fairness.py) ----------------------------------------------------
    def _init_bounds(self) -> None:
        self.scheduler = CommandScheduler()
        self.burst_log = BurstLog(log)
        self.reports.admit = self._admit_report
        self.code_watch = CodeWatch(log)

    @property
    def limits(self) -> Limits:
        return self.config.limits

    def _admit_report(self, kind: str) -> bool:
        """Whether a new ``kind`` report client may stay (under the per-port cap)."""
        cap = self.limits.cap()
        if len(self.reports.clients[kind]) < cap:
            return True
        self.burst_log.event(f"cap-{kind}", "%s report port: %d connections (the cap), refusing new ones "
                             "(serve --max-connections)", kind, cap)
        return False

    # -- disk work off the loop (server/disk.py) -----------------------------------------------------
    def _start_disk(self) -> None:
        """The disk worker; the trace and the saved configuration write through it."""
        if self.disk is None:
            self.disk = DiskWorker()
        store = self.config_store()
        if store is not None:
            store.writer = self.disk.submit

    def _stop_disk(self) -> None:
        store = self.config_store()
        if store is not None:
            store.writer = None
        if self.disk is not None:
            self.disk.close()
            self.disk = None

    def config_store(self) -> ConfigStore | None:
        """The emulator's saved-configuration store (registers 39/40), if it has one."""
        store = getattr(self.emulator, "_store", None)
        return store if isinstance(store, ConfigStore) else None

    def disk_job(self) -> concurrent.futures.Future[Any] | None:
        """The disk job the last command handed to the worker (a save or delete), taken."""
        store = self.config_store()
        if store is None or store.inflight is None:
            return None
        job, store.inflight = store.inflight, None
        return job

    def answer_after_disk(self, frame: bytes, job: concurrent.futures.Future[Any]) -> asyncio.Future[bytes]:
        """``frame`` once ``job`` is done; when the job failed, the reply a failed save gets
        (warning 12, manual 2.1.3 state byte) with the cause in the log and ``status``."""
        loop = asyncio.get_running_loop()
        fut: asyncio.Future[bytes] = loop.create_future()

        def landed(j: concurrent.futures.Future[Any]) -> None:  # on the worker thread
            with contextlib.suppress(RuntimeError):  # the loop closed meanwhile
                loop.call_soon_threadsafe(self._disk_answered, fut, frame, j)

        job.add_done_callback(landed)
        return fut

    def _disk_answered(self, fut: asyncio.Future[bytes], frame: bytes,
                       job: concurrent.futures.Future[Any]) -> None:
        if fut.done():
            return
        if job.exception() is not None and len(frame) > 7:
            with self.lock:
                self._run_due()
                ctl = self.emulator.controller
                ctl.raise_warning(WARN_PARAMETER)
                self.emulator.touch()
                frame = frame[:7] + bytes([ctl.status_byte()]) + frame[8:]
        fut.set_result(frame)

    def answer_later(self, tid: int, protocol: int, register: int) -> asyncio.Future[bytes] | None:
        """The reply to register 204 once the load identification it started is over (its result,
        controller/applications/identification.py); ``None`` when it is over already (the reply made
        stands)."""
        ctl = self.emulator.controller
        if register != identification.REGISTER or identification.finished(ctl):
            return None
        fut: asyncio.Future[bytes] = asyncio.get_running_loop().create_future()
        self._later.append((fut, tid, protocol, register, self._held_trace))
        self._held_trace = None
        return fut

    def _settle_later(self) -> None:
        """Replies held for a motion (:meth:`answer_later`) go out once it is over."""
        ctl = self.emulator.controller
        if not self._later or not identification.finished(ctl):
            return
        later, self._later = self._later, []
        for fut, tid, protocol, register, held in later:
            frame = self._held_frame(tid, protocol, register, held)
            if not fut.done():
                fut.set_result(frame)

    def _held_frame(self, tid: int, protocol: int, register: int,
                    held: tuple[str, bytes, float] | None) -> bytes:
        """The reply frame of a held request whose motion is over, traced now."""
        ctl = self.emulator.controller
        reply = ctl.registers[register].reply.encode(identification.reply(ctl))
        frame = encode_reply(tid, protocol, register, ctl.status_byte(), reply)
        if self.trace is not None and held is not None:
            self.trace.command(self.emulator.time, held[0], tid, protocol, register, held[1], frame,
                               ctl.registers, asked=held[2])
        return frame

    def finish_held(self, tid: int, protocol: int, register: int, limit: float = 600.0) -> bytes | None:
        """Lockstep (replay): when the request just answered is held (:meth:`answer_later`), run
        the controller until its motion is over (at most ``limit`` s) and return its reply frame;
        ``None`` when it is not held."""
        ctl = self.emulator.controller
        if register != identification.REGISTER or identification.finished(ctl):
            return None
        held, self._held_trace = self._held_trace, None
        end = self.emulator.time + limit
        while not identification.finished(ctl) and self.emulator.time < end:
            self.emulator.step(25)
        return self._held_frame(tid, protocol, register, held)

    def box(self) -> dict[str, Any]:
        """The box this server runs, as the trace's start line gives it (server/trace.py)."""
        emu = self.emulator
        track = getattr(emu, "linear_track", None)
        cal = emu.model.calibration
        return {"model": emu.model.key, "firmware": str(emu.firmware.version), "gripper": emu.gripper_kind,
                "vacuum": getattr(emu, "vacuum", None) is not None,
                "linear_track": None if track is None else int(track.length),
                "ft_sensor": bool(emu.has_ft_sensor),
                "ft_noise": bool(emu.has_ft_sensor and ft_sensor.state_of(emu.controller).noise),
                "robot_sn": emu.controller.robot_sn, "box_sn": emu.controller.box_sn,
                "saved": getattr(emu, "loaded_config", None),
                "calibration": None if cal is None or cal.empty else
                {"model": cal.model, **{k: list(v) for k, v in cal.values().items()}}}

    def health(self) -> dict[str, Any]:
        """What the admin ``status`` adds: why the last save failed and why the trace stopped
        (``None`` when they did not), the trace lines lost."""
        store = self.config_store()
        trace = self.trace
        return {"save_error": store.last_save_error if store is not None else None,
                "trace_stopped": trace.stopped if trace is not None else None,
                "trace_dropped": trace.dropped if trace is not None else 0,
                "report_frames_missed": dict(self.reports.frames_missed)}

    def _quiet_accept_errors(self, loop: asyncio.AbstractEventLoop) -> None:
        """Out of file descriptors, new clients are refused (:class:`ListenSocket`); say so once per
        burst, without a traceback per attempt (unless the loop already has a handler)."""
        if loop.get_exception_handler() is not None:
            return
        burst = self.burst_log

        def handler(lp: asyncio.AbstractEventLoop, context: dict[str, Any]) -> None:
            exc = context.get("exception")
            if isinstance(exc, OSError) and exc.errno in (errno.EMFILE, errno.ENFILE, errno.ENOBUFS,
                                                          errno.ENOMEM):
                burst.event("accept-fds", "cannot accept connections: %s; new clients are refused "
                            "until a descriptor is free (lower serve --max-connections or raise the "
                            "open-file limit)", exc.strerror or exc)
                return
            lp.default_exception_handler(context)

        loop.set_exception_handler(handler)

    # -- what the admin channel needs (server/admin.py AdminTarget) ---------------------------------
    @property
    def stepped(self) -> bool:
        """Lockstep time: controller time advances only by :meth:`advance` (admin ``step``)."""
        return self.config.stepped

    def set_reply_delay(self, seconds: float) -> None:
        self.reply_delay = float(seconds)

    @property
    def report_pause_until(self) -> float:
        """Monotonic time until which no report frame goes out (fault injection ``report-pause``)."""
        return self._report_pause_until

    def clear_delays(self) -> None:
        """No reply delay and no report pause (admin ``clear``)."""
        self.reply_delay = 0.0
        self._report_pause_until = 0.0

    # -- the report streams' state, as before the split ---------------------------------------------
    @property
    def report_clients(self) -> dict[str, set[asyncio.StreamWriter]]:
        return self.reports.clients

    @property
    def frames_sent(self) -> dict[str, int]:
        return self.reports.frames_sent

    @property
    def frames_skipped(self) -> dict[str, int]:
        return self.reports.frames_skipped

    @property
    def frame_times(self) -> dict[str, list[float]] | None:
        """Set to a dict to record each report frame's send time (benchmarks)."""
        return self.reports.frame_times

    @frame_times.setter
    def frame_times(self, value: dict[str, list[float]] | None) -> None:
        self.reports.frame_times = value

    @property
    def viewer(self) -> Any:
        """The attached 3D view, if any (``attach("view", ...)``)."""
        return self.attachments.get("view")

    def attach(self, name: str, factory: Callable[[], Attachment]) -> None:
        """Have :meth:`start` build ``factory()`` after the ports are open, start it, and record its
        port under ``name`` in :attr:`ports`; :meth:`close` stops it."""
        self._attach[name] = factory

    async def start(self) -> None:
        loop = asyncio.get_running_loop()
        cfg = self.config
        if cfg.stepped and not cfg.admin:
            raise ValueError("lockstep (stepped) time is driven through the admin channel: add --admin")
        self._start_disk()
        if cfg.trace is not None and self.trace is None:
            try:
                self.trace = CommandTrace(cfg.trace, self.disk, max_bytes=cfg.trace_max_bytes)
            except OSError as exc:
                raise ValueError(f"cannot open the trace file {cfg.trace}: {exc.strerror or exc}") from None
            self.trace.start(self.emulator.time, self.box())
        self._quiet_accept_errors(loop)
        backlog = max(1, cfg.limits.backlog)
        srv = await loop.create_server(lambda: self._woken(CommandProtocol(self)),
                                       **listen_args(cfg.host, cfg.port, backlog))
        self._servers.append(srv)
        self.ports["command"] = srv.sockets[0].getsockname()[1]
        refused = self.reports.start(cfg.report_priority)  # the process's sender writes the frames
        if refused:
            log.warning("%s", refused)
        report_ports = (("normal", cfg.normal_port), ("rich", cfg.rich_port), ("develop", cfg.develop_port),
                        (REALTIME_KIND, cfg.realtime_port_number()))
        for kind, port in report_ports:
            if kind not in self.reports.kinds:
                continue
            s = await asyncio.start_server(self._watching(self.reports.on_client(kind)),
                                           **listen_args(cfg.host, port, backlog))
            self._servers.append(s)
            self.ports[kind] = s.sockets[0].getsockname()[1]
        if cfg.admin:
            try:
                self.admin_token = cfg.admin_token or load_or_create_admin_token()
            except OSError as exc:
                raise ValueError(f"cannot create the admin token: {exc}") from None
            admin_port = cfg.admin_port
            if admin_port is None:
                admin_port = 0 if cfg.port == 0 else derive_admin_port(self.ports["command"])
            # Loopback only, whatever ``host`` is (the protocol also refuses non-loopback peers): the
            # arm's own address when that is a loopback one, else 127.0.0.1.
            a = await loop.create_server(lambda: self._woken(AdminProtocol(self)), admin_host(cfg.host),
                                         admin_port,
                                         reuse_address=True)
            self._servers.append(a)
            self.ports["admin"] = a.sockets[0].getsockname()[1]
        for name, factory in self._attach.items():
            extra = factory()
            self.attachments[name] = extra
            extra.start()
            self.ports[name] = extra.port
        self._loop = loop
        self._loop_thread = threading.get_ident()
        self.clock.start(time.monotonic())
        self._tasks.append(asyncio.create_task(self._control_loop()))

    def catch_up(self, until: float | None = None) -> int:
        """Run the control periods that are due by now (real or scaled time), or by monotonic time
        ``until`` when that is earlier.

        Returns the number of periods run. Called, under the arm's :attr:`lock`, before every
        command, report frame and admin action, so that whatever anyone observes is the state after
        every period that has elapsed: stepping in batches this way is indistinguishable from
        stepping on every period, and the control loop only has to wake up now and then
        (:data:`IDLE_WAKE`) when nobody is looking. The report sender calls it from its own thread
        (:meth:`report_instant`): the feedback frames it causes are handed to the loop.
        """
        if self._loop is None:
            return 0
        with self.lock:
            return self._run_due(until)

    def _run_due(self, until: float | None = None) -> int:
        """:meth:`catch_up` with the arm's :attr:`lock` held already (a command takes it once)."""
        now = time.monotonic()  # the clock's time base, the same in the loop and the sender
        if until is not None:
            now = min(now, until)
        if now < self.clock.quiet_until or self.config.stepped:  # the usual case: nothing due yet
            return 0
        loop = self._loop
        if loop is None:
            return 0
        n = self.clock.due(now, MAX_CATCH_UP)
        if n:
            self.emulator.step(n)
            self.code_watch.check(self.emulator.controller)
            if self.feedback is not None and self.feedback.pending:
                if threading.get_ident() == self._loop_thread:
                    self.deliver_feedback()
                else:
                    with contextlib.suppress(RuntimeError):  # the loop closed meanwhile
                        loop.call_soon_threadsafe(self.deliver_feedback)
            if self._later:  # replies held for a motion (register 204) resolve on the loop
                self.in_loop(self._settle_later)
        return n

    def in_loop(self, fn: Callable[[], object]) -> None:
        """Run ``fn`` now when called on the event loop's thread, else soon on the loop (an action
        scheduled on the emulator that touches connections may run while the report sender steps)."""
        loop = self._loop
        if loop is None or threading.get_ident() == self._loop_thread:
            fn()
            return
        with contextlib.suppress(RuntimeError):  # the loop closed meanwhile
            loop.call_soon_threadsafe(fn)

    def report_instant(self, deadline: float, interval: float) -> bool:
        """The report sender, under :attr:`lock`, before it encodes the frame due at ``deadline``
        (perf_counter seconds) of a stream of period ``interval``: run the control periods due by
        the deadline, so the frame shows the state of the deadline's own control period or of the
        one after it. ``False`` when the controller already runs a later period (the sender was
        late and a command or the loop ran on meanwhile) or the period of the stream's next
        deadline: the deadline's state is gone, so the frame is not sent rather than show a later
        state; a report never repeats a state for two deadlines. ``False`` too when the controller
        was held back so long that one catch-up (:data:`MAX_CATCH_UP` periods) does not bring it to
        the deadline's period: the frame is not sent rather than show an earlier state."""
        if self._loop is None or self.config.stepped:
            return True
        until = deadline + (time.monotonic() - time.perf_counter())
        self.catch_up(until)
        steps, own = self.clock.steps, self.clock.steps_at(until)
        return own <= steps <= own + 1 and steps < self.clock.steps_at(until + interval)

    def answer(self, tid: int, protocol: int, register: int, params: bytes, peer: str = "",
               client: int = 0) -> bytes:
        """The reply frame to one private-protocol request (manual 2.1.2) from command connection
        ``client`` (its :attr:`CommandProtocol.client_id`; 0: none)."""
        with self.lock:
            self._run_due()
            emu = self.emulator
            cached: bytes | None = None
            if not params and register in PURE_READS:
                # a hit: nothing has changed since this reply was made and the codes were watched
                cached = frame = self._read_cache.hit(emu, tid, protocol, register)
                if frame is None:
                    frame = self._read_cache.reply(emu, tid, protocol, register)
            elif self.feedback is not None:
                frame = self._answer_with_feedback(tid, protocol, register, params, client)
            else:
                state, reply = emu.handle(register, params)
                frame = encode_reply(tid, protocol, register, state, reply)
            if cached is None:
                self.code_watch.check(emu.controller)
            if self.trace is not None:  # under the lock: in order with the scheduled changes
                if register == identification.REGISTER and not identification.finished(emu.controller):
                    self._held_trace = (peer, params, emu.time)  # traced with its reply (answer_later)
                else:
                    self.trace.command(emu.time, peer, tid, protocol, register, params, frame,
                                       emu.controller.registers)
        return frame

    # -- feedback frames (FirmwareProfile.feedback) -----------------------------------------------
    def _answer_with_feedback(self, tid: int, protocol: int, register: int, params: bytes,
                              client: int) -> bytes:
        """Handle one request with its origin known to the feedback queue; the frames it causes go
        out after its reply (the next turn of the loop)."""
        fb = self.feedback
        assert fb is not None
        ctl = self.emulator.controller
        fb.begin(ctl, client, tid, protocol, register)
        state = 0
        try:
            state, reply = self.emulator.handle(register, params)
        finally:
            fb.end(ctl, state)
        if fb.pending and not self._feedback_soon and self._loop is not None:
            self._feedback_soon = True  # after the reply, also when an injected delay holds it back
            if self.reply_delay > 0.0:
                self._loop.call_later(self.reply_delay, self._deliver_soon)
            else:
                self._loop.call_soon(self._deliver_soon)
        return encode_reply(tid, protocol, register, state, reply)

    def _deliver_soon(self) -> None:
        self._feedback_soon = False
        self.deliver_feedback()

    def deliver_feedback(self) -> int:
        """Write the controller's pending feedback events as 0xFF frames, each to the command
        connection whose request it reports; returns the number written. A frame whose connection
        is gone, or whose reader is not keeping up (as report frames are skipped), is dropped and
        counted in :attr:`feedback_dropped`."""
        fb = self.feedback
        if fb is None or not fb.pending:
            return 0
        by_id = {c.client_id: c for c in self.command_clients}
        n = 0
        for ev in fb.drain():
            conn = by_id.get(ev.client)
            if conn is None or not conn.send_feedback(ev.encode()):
                self.feedback_dropped += 1
                continue
            n += 1
        self.feedback_sent += n
        return n

    def command_closed(self, client: int) -> None:
        """Command connection ``client`` closed: its feedback mask and pending reports go."""
        if self.feedback is not None:
            self.feedback.forget(client)

    def answer_modbus(self, tid: int, unit: int, pdu: bytes, peer: str = "") -> bytes:
        """The reply frame to one standard Modbus-TCP request (protocol id 0): the map of
        :mod:`xarm_emu.protocol.modbus` over the live emulator, after the due control periods."""
        with self.lock:
            self._run_due()
            frame = modbus_map.answer(self.emulator, tid, unit, pdu)
            if self.trace is not None:  # under the lock: in order with the scheduled changes
                self.trace.modbus(self.emulator.time, peer, tid, unit, pdu, frame)
        return frame

    def advance(self, seconds: float) -> int:
        """Lockstep: run ``seconds`` of controller time now (whole control periods); returns the
        number of periods run."""
        n = max(0, round(seconds / PERIOD))
        with self.lock:
            self.emulator.step(n)
        if self._later:
            self._settle_later()
        return n

    async def _control_loop(self) -> None:
        """Keep controller time up with the wall clock while nobody asks (see :meth:`catch_up`)."""
        while True:
            backlog = self.catch_up() == MAX_CATCH_UP  # more is due: yield to clients, then go on
            if self.trace is not None:
                self.trace.flush()
            if backlog:
                await asyncio.sleep(0)
            else:
                await self._nap(self._nap_seconds())

    # -- idle arms: the control loop naps while nobody can observe the arm ---------------------------
    _napping: asyncio.Future[None] | None = None
    _wake_pending = False

    def _nap_seconds(self) -> float:
        """How long the control loop may sleep: :data:`IDLE_WAKE` while someone may wait on it (a
        command or admin connection, the arm moving, the trace, an attachment); longer while a
        develop or real-time reader catches up 100 or 250 times a second anyway, or nobody is
        connected (:data:`UNOBSERVED_WAKE`, never past the next scheduled action)."""
        if self._wake_pending:  # just woken by a connection: look again once it is set up
            self._wake_pending = False
            return IDLE_WAKE
        if self.attachments or self.trace is not None:
            return IDLE_WAKE
        fast = not self.reports_paused() and any(
            clients and self.reports.rates.get(kind, 0.0) * IDLE_WAKE >= 1.0
            for kind, clients in self.reports.clients.items())
        if not fast and (self.command_clients or self.admin_clients or self.emulator.controller.is_moving):
            return IDLE_WAKE
        speed = self.config.speed
        nap = min(UNOBSERVED_WAKE, 0.8 * MAX_CATCH_UP * PERIOD / speed)
        scheduled = getattr(self.emulator, "_scheduled", None)
        if scheduled and not self.config.stepped:
            nap = min(nap, (scheduled[0][0] - self.emulator.time) / speed)
        return max(IDLE_WAKE, nap)

    async def _nap(self, seconds: float) -> None:
        """Sleep ``seconds`` unless :meth:`wake_control` ends it sooner.

        The process's report sender thread ends the nap (:meth:`ReportSender.wake_at`), not a timer
        of the event loop: while any timer is pending, every turn of the loop works out a timeout
        and the kernel arms one for its wait, which cost each command round trip about 0.5 us of
        the server's processor time (GET_STATE 74-76k -> 80-81k/s on the standard loop, 0.84-0.86
        -> 0.89-0.92 of the echo server, with the per-connection frame timer gone too;
        ``python -m bench roundtrip``). Its price is a second thread's wake-up per nap: ``serve``
        with the SDK connected and idle (50 naps a second) takes 2.6-2.9 % of a core instead of
        1.5-1.8 %; an arm nobody observes naps 0.8 s, 0.033 % of a core (``python -m bench fleet``)."""
        loop = asyncio.get_running_loop()
        fut: asyncio.Future[None] = loop.create_future()
        self._napping = fut
        sender = self.reports.sender
        if sender is not None:
            def due() -> None:  # on the sender thread
                with contextlib.suppress(RuntimeError):  # the loop closed meanwhile
                    loop.call_soon_threadsafe(_wake, fut)

            wake: Wake | asyncio.TimerHandle = sender.wake_at(time.perf_counter() + seconds, due)
        else:
            wake = loop.call_later(seconds, _wake, fut)
        try:
            await fut
        finally:
            wake.cancel()
            self._napping = None

    def wake_control(self) -> None:
        """A connection came or went: the control loop looks again at how long it may sleep."""
        self._wake_pending = True
        if self._napping is not None:
            _wake(self._napping)

    def _woken(self, protocol: Any) -> Any:
        """``protocol`` (a new connection's), after waking the control loop."""
        self.wake_control()
        return protocol

    def _watching(self, serve: Callable[[asyncio.StreamReader, asyncio.StreamWriter], Any]
                  ) -> Callable[[asyncio.StreamReader, asyncio.StreamWriter], Any]:
        """A report port's callback that wakes the control loop when a reader comes and goes."""
        async def watched(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
            self.wake_control()
            try:
                await serve(reader, writer)
            finally:
                self.wake_control()

        return watched

    def drop_clients(self, abort: bool = False) -> int:
        """Close every command and report connection (fault injection ``drop-clients``); returns
        how many were closed. Admin connections stay. ``abort`` discards unsent data."""
        n = 0
        transports: list[asyncio.BaseTransport] = [c.transport for c in self.command_clients
                                                   if c.transport is not None]
        transports += self.reports.transports()
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
        self._report_pause_until = time.monotonic() + seconds

    def reports_paused(self) -> bool:
        """Whether the sender's schedule sends no frame now: an injected report pause is on, or the
        frames go out at the stepped clock's deadlines (:attr:`reports_stepped`)."""
        return self.reports_stepped or time.monotonic() < self._report_pause_until

    #: Stepped clock: the report frames go out only when :meth:`advance_to_report` reaches their
    #: deadlines, not on the sender's wall-clock schedule (``testing.sdk_on_stepped_clock``).
    reports_stepped = False

    def advance_to_report(self, periods: int) -> tuple[int, tuple[str, ...]]:
        """Stepped clock: run control periods up to the next report deadline of a stream with
        readers (controller time, the multiples of the stream's interval; a deadline's period is
        the first that starts at or after it), at most ``periods``; at a deadline, write each due
        stream's frame from the state of that period to its readers at once (none while an injected
        report pause is on). Returns the periods run and the kinds whose frame every reader took.
        Safe from any thread (it takes the arm's :attr:`lock`; what touches connections runs on
        the loop)."""
        ctl = self.emulator.controller
        now = ctl.data.steps
        due: dict[str, int] = {}
        for kind, stream in self.reports.streams.items():
            if stream.readers:
                ratio = stream.interval / PERIOD  # control periods per frame
                k = math.floor(now / ratio + 1e-9) + 1
                due[kind] = math.ceil(k * ratio - 1e-9)
        n = min([periods, *(p - now for p in due.values())])
        with self.lock:
            self.emulator.step(n)
            self.code_watch.check(ctl)
            if self.feedback is not None and self.feedback.pending:
                self.in_loop(self.deliver_feedback)
            sent: tuple[str, ...] = ()
            if time.monotonic() >= self._report_pause_until:
                sent = tuple(kind for kind, p in due.items() if p == now + n and self.reports.push(kind))
        if self._later:
            self.in_loop(self._settle_later)
        return n, sent

    async def close(self) -> None:
        self.reports.quiesce()  # first, before any await: every arm of a worker stops encoding at once
        log.info("shutting down: closing the ports and every connection")
        for extra in self.attachments.values():
            extra.stop()
        self.attachments.clear()
        for t in self._tasks:
            t.cancel()
        for t in self._tasks:
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await t
        self._tasks.clear()
        for s in self._servers:
            s.close()
        self.drop_clients(abort=True)
        for a in tuple(self.admin_clients):
            if a.transport is not None:
                a.transport.abort()
        handlers = tuple(self.reports.client_tasks)
        if handlers:  # aborted transports end their handlers (EOF); cancel only stragglers
            _, late = await asyncio.wait(handlers, timeout=1.0)
            for t in late:
                t.cancel()
            await asyncio.gather(*late, return_exceptions=True)
        self.reports.stop()
        for s in self._servers:
            with contextlib.suppress(Exception):
                await s.wait_closed()
        self._servers.clear()
        for _ in range(3):  # let connection_lost callbacks close the sockets
            await asyncio.sleep(0)
        if self.trace is not None:
            self.trace.close()
            self.trace = None
        self._stop_disk()
        log.info("stopped")
        self._stopped.set()

    async def serve_forever(self) -> None:
        """Start (unless started) and serve until :meth:`close`."""
        if not self._servers:
            await self.start()
        await self._stopped.wait()


def _wake(fut: asyncio.Future[None]) -> None:
    if not fut.done():
        fut.set_result(None)
