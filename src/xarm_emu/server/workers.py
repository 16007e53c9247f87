"""A fleet in worker processes (``xarm-emu serve --fleet FILE --workers N``), supervised by the parent.

The fleet file's arms (:mod:`.fleet`) are split into ``N`` contiguous groups of nearly equal size
(:func:`assign`); each group runs in a worker process of its own, one asyncio loop (uvloop when
asked) hosting its arms' :class:`~.core.EmulatorServer` s, so a fleet uses every core. Workers start
from a ``forkserver`` (a clean single-threaded process with the emulator already imported; ``spawn``
where there is none), never by forking a process that has threads.

The parent (:class:`Supervisor`) starts the workers, waits until every arm listens, and watches them:

- a worker that dies (a signal, a crash) is logged with its arms and its exit code or signal, and is
  started again at once with the same arms: they load their saved configuration (the arm's file in
  the configuration directory) and listen on the same addresses (ports 0 keep the port the first
  start got). A restarted worker that dies again within :data:`STABLE` seconds waits before its next
  start, twice as long each time (from :data:`FIRST_BACKOFF` up to :data:`MAX_BACKOFF`).
- :meth:`Supervisor.stop` (SIGTERM or Ctrl-C to the parent) asks every worker to stop on its pipe and
  sends it SIGTERM; each closes its servers (pending saves are written, manual 2.1.3 register 39),
  tells the parent its report counts (:class:`ReportCounts`; logged, a warning when its frames were
  often late: it had more arms than its core could serve) and exits 0; a worker still running
  after the grace period is killed.
- A worker whose parent is gone (its pipe to the parent ends) stops the same way.

Other workers never notice a restart: they share nothing with it but the listening addresses of
their own arms.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import multiprocessing
import multiprocessing.connection
import os
import signal
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from .core import EmulatorServer
from .fairness import Limits
from .fleet import ArmSpec

log = logging.getLogger("xarm_emu.server.workers")

#: A worker that ran at least this long (s) before it died is restarted at once.
STABLE = 10.0
#: The first wait (s) before restarting a worker that died sooner than :data:`STABLE`.
FIRST_BACKOFF = 0.5
#: The longest wait (s) between restarts of a worker in a crash loop.
MAX_BACKOFF = 30.0
#: Seconds a worker has to start its arms (import, build, bind) before it counts as failed.
START_TIMEOUT = 60.0
#: Seconds :meth:`Supervisor.stop` waits for workers to close before killing them.
STOP_GRACE = 10.0


#: Share of a worker's report frames sent more than a control period after their deadline above
#: which its stop logs a warning that it was saturated.
STALE_WARN = 0.05


@dataclass(frozen=True)
class ReportCounts:
    """A worker's report frames over its run, every arm and stream summed (``ReportStreams``):
    sent, sent more than a control period after their deadline (``stale``: the process was too
    busy to make them in time), and never sent (``missed``: the process was starved)."""

    sent: int = 0
    stale: int = 0
    missed: int = 0

    @classmethod
    def of(cls, servers: Sequence[EmulatorServer]) -> ReportCounts:
        return cls(sum(sum(s.reports.frames_sent.values()) for s in servers),
                   sum(sum(s.reports.frames_late.values()) for s in servers),
                   sum(sum(s.reports.frames_missed.values()) for s in servers))

    @property
    def stale_share(self) -> float:
        return self.stale / self.sent if self.sent else 0.0


def report_counts_message(index: int, arms: str, counts: ReportCounts) -> tuple[int, str]:
    """The log level and line of a stopped worker's report counts: a warning when more than
    :data:`STALE_WARN` of its frames were stale or any was missed (the worker had more arms than
    its core could serve)."""
    text = (f"fleet worker {index} (arms {arms}): {counts.sent} report frames sent, "
            f"{100 * counts.stale_share:.1f} % late by over a control period, {counts.missed} missed")
    if counts.stale_share > STALE_WARN or counts.missed:
        return logging.WARNING, text + "; it was saturated: run more workers or fewer arms each"
    return logging.INFO, text


class WorkersError(ValueError):
    """A bad worker count (the message says why)."""


def default_workers() -> int:
    """One worker per CPU this process may run on (``os.sched_getaffinity``)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


def check_workers(value: int) -> int:
    """``value`` if it is a usable worker count (0: the arms in the parent process, no workers;
    1 or more: that many worker processes, even one), else :class:`WorkersError`."""
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise WorkersError(f"--workers: a number of worker processes, 1 or more (0: every arm in this "
                           f"process), got {value!r}")
    return value


def assign(n_arms: int, workers: int) -> list[tuple[int, ...]]:
    """Arm indexes (0-based) of each worker: contiguous groups whose sizes differ by at most one; no
    more groups than arms."""
    groups = max(1, min(workers, n_arms))
    base, extra = divmod(n_arms, groups)
    out, start = [], 0
    for g in range(groups):
        size = base + (1 if g < extra else 0)
        out.append(tuple(range(start, start + size)))
        start += size
    return out


@dataclass(frozen=True)
class LogSettings:
    """How a worker logs (``serve --log-level/--log-file/--log-json``); a worker appends to the
    parent's log file without rotating it."""

    level: str = "INFO"
    file: Path | None = None
    json_lines: bool = False


@dataclass(frozen=True)
class WorkerPlan:
    """What one worker runs: arms ``numbers`` (1-based, as the fleet file counts them) with ``specs``."""

    index: int
    numbers: tuple[int, ...]
    specs: tuple[ArmSpec, ...]
    config_dir: Path
    limits: Limits = field(default_factory=Limits)
    logging: LogSettings = field(default_factory=LogSettings)
    uvloop: bool = False
    report_priority: int | None = None  # serve --report-priority: the worker's report sender


@dataclass(frozen=True)
class ArmReady:
    """One started arm, as its worker reports it to the parent."""

    number: int
    host: str
    ports: dict[str, int]
    model: str
    version: str
    pid: int  # the worker's
    config_message: str | None = None


def plans(specs: Sequence[ArmSpec], workers: int, config_dir: Path, limits: Limits,
          logging_: LogSettings, uvloop: bool = False,
          report_priority: int | None = None) -> list[WorkerPlan]:
    """The worker plans of a fleet's arms over ``workers`` processes (:func:`assign`)."""
    return [WorkerPlan(i, tuple(a + 1 for a in group), tuple(specs[a] for a in group), config_dir,
                       limits, logging_, uvloop, report_priority)
            for i, group in enumerate(assign(len(specs), workers), start=1)]


# -- the worker process --------------------------------------------------------------------------------

def worker_main(plan: WorkerPlan, conn: multiprocessing.connection.Connection) -> None:
    """Entry point of a worker process: serve ``plan``'s arms until SIGTERM or the parent is gone.
    Sends the parent ``("ready", [ArmReady, ...])`` once every arm listens, or ``("error", exc)``."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C reaches the whole group: the parent decides
    from .logs import configure

    configure(plan.logging.level, plan.logging.file, 0, json_lines=plan.logging.json_lines)
    from .report_sender import tune_process

    tune_process()  # a process that only serves arms (serve --fleet): the sender's interpreter settings
    runner: Callable[[Any], Any] = asyncio.run
    if plan.uvloop:
        with contextlib.suppress(ImportError):
            import uvloop  # type: ignore[import-not-found]

            runner = uvloop.run
    try:
        runner(_serve(plan, conn))
    except BaseException as exc:  # noqa: BLE001 - told to the parent, then the worker ends
        _send(conn, ("error", _portable(exc)))
        raise SystemExit(3) from None
    raise SystemExit(0)


def _portable(exc: BaseException) -> BaseException:
    """``exc`` if it survives pickling (OSError keeps its errno), else a RuntimeError with its text."""
    import pickle

    try:
        pickle.loads(pickle.dumps(exc))
    except Exception:  # noqa: BLE001
        return RuntimeError(str(exc))
    return exc


def _send(conn: multiprocessing.connection.Connection, message: object) -> None:
    with contextlib.suppress(OSError, ValueError):
        conn.send(message)


def build_servers(plan: WorkerPlan) -> list[EmulatorServer]:
    """The arms' servers: each emulator claims and loads its saved configuration in
    ``plan.config_dir`` (controller/core/config.py), its fault schedule scheduled."""
    from .faults import schedule_file

    servers = []
    for spec in plan.specs:
        emu = spec.emulator(plan.config_dir)
        store = getattr(emu, "_store", None)
        if store is not None:  # one running box per saved configuration
            store.lock()
        cfg = replace(spec.server, limits=plan.limits, report_priority=plan.report_priority)
        srv = EmulatorServer(emu, cfg)
        schedule_file(srv, cfg.faults)
        servers.append(srv)
    return servers


async def _serve(plan: WorkerPlan, conn: multiprocessing.connection.Connection) -> None:
    servers = build_servers(plan)
    started: list[EmulatorServer] = []
    try:
        for srv in servers:
            await srv.start()
            started.append(srv)
    except BaseException:
        for srv in started:
            with contextlib.suppress(Exception):
                await srv.close()
        raise
    ready = [ArmReady(n, srv.config.host, dict(srv.ports), srv.emulator.model.name,
                      srv.emulator.controller.version_string(), os.getpid(),
                      srv.emulator.config_message or None)
             for n, srv in zip(plan.numbers, servers, strict=True)]
    _send(conn, ("ready", ready))
    loop = asyncio.get_running_loop()
    stop = asyncio.Event()
    # A plain Python handler, not loop.add_signal_handler: the loop learns of those signals through the
    # bytes of its wake-up pipe, which the report sender thread also writes to (call_soon_threadsafe)
    # and which a saturated worker can let fill up, so that SIGTERM's byte is lost and the worker never
    # stops. A Python handler always runs in the main thread and hands the stop to the loop.
    signal.signal(signal.SIGTERM, lambda _sig, _frame: loop.call_soon_threadsafe(stop.set))

    def parent_message() -> None:  # EOF: the parent is gone; "stop": asked to stop
        try:
            message = conn.recv()
        except (EOFError, OSError):
            message = "stop"
        if message == "stop":
            loop.remove_reader(conn.fileno())
            stop.set()

    loop.add_reader(conn.fileno(), parent_message)
    await stop.wait()
    await asyncio.gather(*(srv.close() for srv in servers), return_exceptions=True)
    _send(conn, ("stopped", ReportCounts.of(servers)))


# -- the parent --------------------------------------------------------------------------------------

def _context() -> Any:
    """``forkserver`` with this module preloaded (fast restarts), else ``spawn``."""
    if "forkserver" in multiprocessing.get_all_start_methods():
        ctx = multiprocessing.get_context("forkserver")
        ctx.set_forkserver_preload([__name__])
        return ctx
    return multiprocessing.get_context("spawn")


def describe_exit(code: int | None) -> str:
    """A worker's exit status in words: ``exit code 3`` or ``killed by signal SIGKILL``."""
    if code is None:
        return "still running"
    if code < 0:
        try:
            name = signal.Signals(-code).name
        except ValueError:
            name = str(-code)
        return f"killed by signal {name}"
    return f"exit code {code}"


@dataclass
class _Worker:
    plan: WorkerPlan
    process: Any = None  # multiprocessing.Process of the running start
    conn: multiprocessing.connection.Connection | None = None
    started_at: float = 0.0
    backoff: float = 0.0
    restart_at: float | None = None  # monotonic time of the next start, while waiting
    starts: int = 0
    ready: list[ArmReady] = field(default_factory=list)


class Supervisor:
    """Starts the fleet's worker processes and keeps them running (module docstring).

    ``on_ready(worker_index, arms)`` is called after every start of a worker (the first and each
    restart) with its :class:`ArmReady` list; the parent's output goes there."""

    def __init__(self, plans_: Sequence[WorkerPlan],
                 on_ready: Callable[[WorkerPlan, int, list[ArmReady]], None] | None = None) -> None:
        self.workers = [_Worker(p) for p in plans_]
        self.on_ready = on_ready
        self._ctx = _context()
        self._stopping = False
        self._wake_r, self._wake_w = os.pipe()
        os.set_blocking(self._wake_w, False)
        #: (worker index, exit description) of every death seen, oldest first.
        self.deaths: list[tuple[int, str]] = []
        #: Worker index -> its report counts, sent by each worker that stopped cleanly.
        self.report_counts: dict[int, ReportCounts] = {}

    # -- starting --------------------------------------------------------------------------------------
    def start(self) -> None:
        """Start every worker and wait until each listens. Raises the first worker's start error
        (an OSError of a port, a ConfigLocked, ...) after stopping the others."""
        for w in self.workers:
            self._launch(w)
        try:
            for w in self.workers:
                self._await_ready(w)
        except BaseException:
            self.stop()
            raise

    def _launch(self, w: _Worker) -> None:
        parent, child = self._ctx.Pipe()
        proc = self._ctx.Process(target=worker_main, args=(w.plan, child), daemon=False,
                                 name=f"xarm-emu-worker-{w.plan.index}")
        proc.start()
        child.close()
        w.process, w.conn, w.started_at, w.restart_at = proc, parent, time.monotonic(), None
        w.starts += 1

    def _await_ready(self, w: _Worker) -> None:
        assert w.conn is not None and w.process is not None
        deadline = time.monotonic() + START_TIMEOUT
        while True:
            if w.conn.poll(0.05):
                try:
                    kind, value = w.conn.recv()
                except (EOFError, OSError):
                    w.process.join(1)
                    raise RuntimeError(f"fleet worker {w.plan.index} ended while starting "
                                       f"({describe_exit(w.process.exitcode)})") from None
                if kind == "error":
                    w.process.join(5)
                    raise value
                self._ready(w, value)
                return
            if not w.process.is_alive():
                raise RuntimeError(f"fleet worker {w.plan.index} ended while starting "
                                   f"({describe_exit(w.process.exitcode)})")
            if self._stopping and w.restart_at is None and w.starts > 1:  # SIGTERM during a restart
                raise RuntimeError(f"fleet worker {w.plan.index}: stopping")
            if time.monotonic() > deadline:
                raise RuntimeError(f"fleet worker {w.plan.index} did not start its arms within "
                                   f"{START_TIMEOUT:g} s")

    def _ready(self, w: _Worker, arms: list[ArmReady]) -> None:
        w.ready = arms
        # Port 0 took any free port: later starts listen on the same ones.
        specs = tuple(_pinned(spec, r.ports) for spec, r in zip(w.plan.specs, arms, strict=True))
        w.plan = replace(w.plan, specs=specs)
        if self.on_ready is not None:
            self.on_ready(w.plan, w.starts, arms)

    # -- watching --------------------------------------------------------------------------------------
    def request_stop(self) -> None:
        """Ask :meth:`run` to return (safe from a signal handler)."""
        self._stopping = True
        with contextlib.suppress(OSError):
            os.write(self._wake_w, b"x")

    def run(self) -> None:
        """Watch the workers until :meth:`request_stop`; restart those that die."""
        while not self._stopping:
            now = time.monotonic()
            waits = [w.restart_at - now for w in self.workers if w.restart_at is not None]
            timeout = max(0.0, min(waits)) if waits else None
            live = [w.process.sentinel for w in self.workers if w.restart_at is None and w.process]
            ready = multiprocessing.connection.wait([*live, self._wake_r], timeout)
            if self._wake_r in ready:
                with contextlib.suppress(OSError):
                    os.read(self._wake_r, 64)
            if self._stopping:
                break
            for w in self.workers:
                self._check(w)

    def _check(self, w: _Worker) -> None:
        now = time.monotonic()
        if w.restart_at is not None:
            if now >= w.restart_at:
                self._restart(w)
            return
        if w.process is None or w.process.is_alive():
            return
        w.process.join()
        how = describe_exit(w.process.exitcode)
        self.deaths.append((w.plan.index, how))
        self._close_conn(w)
        ran = now - w.started_at
        crash_loop = ran < STABLE and w.starts > 1  # the first death, or after a stable run: at once
        w.backoff = min(MAX_BACKOFF, max(FIRST_BACKOFF, 2 * w.backoff)) if crash_loop else 0.0
        when = "at once" if w.backoff == 0 else f"in {w.backoff:g} s"
        log.warning("fleet worker %d (pid %s; arms %s) died: %s after %.1f s; restarting %s",
                    w.plan.index, w.process.pid, _arms_text(w.plan), how, ran, when)
        w.restart_at = now + w.backoff
        if w.backoff == 0:
            self._restart(w)

    def _restart(self, w: _Worker) -> None:
        self._launch(w)
        try:
            self._await_ready(w)
        except Exception as exc:  # noqa: BLE001 - logged; the next death check backs off
            log.log(logging.INFO if self._stopping else logging.ERROR,
                    "fleet worker %d (arms %s) could not start again: %s", w.plan.index,
                    _arms_text(w.plan), exc)
            if w.process is not None and w.process.is_alive():
                w.process.kill()
            if w.process is not None:
                w.process.join()
            self._close_conn(w)
            w.backoff = min(MAX_BACKOFF, max(FIRST_BACKOFF, 2 * w.backoff))
            w.restart_at = time.monotonic() + w.backoff
            return
        log.info("fleet worker %d (pid %s; arms %s) started again", w.plan.index, w.process.pid,
                 _arms_text(w.plan))

    def _take_counts(self, w: _Worker) -> None:
        """Read what a stopped worker left on its pipe: its report counts, logged."""
        if w.conn is None:
            return
        with contextlib.suppress(EOFError, OSError):
            while w.conn.poll(0):
                kind, value = w.conn.recv()
                if kind == "stopped" and isinstance(value, ReportCounts):
                    self.report_counts[w.plan.index] = value
                    log.log(*report_counts_message(w.plan.index, _arms_text(w.plan), value))

    @staticmethod
    def _close_conn(w: _Worker) -> None:
        if w.conn is not None:
            with contextlib.suppress(OSError):
                w.conn.close()
            w.conn = None

    # -- stopping ----------------------------------------------------------------------------------------
    def stop(self, grace: float = STOP_GRACE) -> None:
        """Ask every worker to stop (its pipe, then SIGTERM) and wait up to ``grace`` s for them to
        close; kill the rest."""
        self._stopping = True
        procs = [w.process for w in self.workers if w.process is not None and w.process.is_alive()]
        for w in self.workers:  # asked on the pipe first (each worker reads it), then SIGTERM
            if w.conn is not None and w.process is not None and w.process.is_alive():
                with contextlib.suppress(OSError, ValueError):
                    w.conn.send("stop")
        for p in procs:
            with contextlib.suppress(OSError):
                p.terminate()
        deadline = time.monotonic() + grace
        for p in procs:
            p.join(max(0.0, deadline - time.monotonic()))
        for p in procs:
            if p.is_alive():
                log.warning("fleet worker pid %s did not stop within %g s; killing it", p.pid, grace)
                p.kill()
                p.join(5)
        for w in self.workers:
            self._take_counts(w)
            self._close_conn(w)
        for fd in (self._wake_r, self._wake_w):
            with contextlib.suppress(OSError):
                os.close(fd)
        self._wake_r = self._wake_w = -1

    def pids(self) -> dict[int, int | None]:
        """Worker index -> the pid of its running process (``None`` while waiting to restart)."""
        return {w.plan.index: (w.process.pid if w.process is not None and w.restart_at is None else None)
                for w in self.workers}


def _pinned(spec: ArmSpec, ports: dict[str, int]) -> ArmSpec:
    """``spec`` with its port-0 listeners fixed to the ports the arm got."""
    cfg = spec.server
    changes: dict[str, Any] = {}
    for key, kind in (("port", "command"), ("normal_port", "normal"), ("rich_port", "rich"),
                      ("develop_port", "develop"), ("realtime_port", "realtime"), ("admin_port", "admin")):
        current = getattr(cfg, key)
        if kind in ports and (current == 0 or (current is None and kind == "admin" and cfg.port == 0)
                              or (key == "realtime_port" and cfg.realtime_port_number() == 0)):
            changes[key] = ports[kind]
    return spec if not changes else replace(spec, server=replace(cfg, **changes))


def _arms_text(plan: WorkerPlan) -> str:
    return ", ".join(str(n) for n in plan.numbers)
