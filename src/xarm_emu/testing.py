"""Helpers for testing programs that use the official SDK against the emulator, in one process and
without root: the emulator on free loopback ports, and the SDK pointed at them.

The SDK has no port argument (port 502 and the report ports are constants of its configuration),
and it picks its report structure by the standard report port numbers. :func:`sdk_pointed_at`
patches both for the duration of a ``with`` block::

    from xarm.wrapper import XArmAPI
    from xarm_emu.testing import running_emulator, sdk_pointed_at

    with running_emulator(model=6, speed=5.0) as st, sdk_pointed_at(st):
        arm = XArmAPI("127.0.0.1")
        ...
        arm.disconnect()

``st.emulator`` is the in-process :class:`~xarm_emu.controller.emulator.Emulator` (fault injection,
inputs); run calls on it through ``st.call(...)`` while the server runs.
"""

from __future__ import annotations

import contextlib
import socket
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from .controller.emulator import Emulator
from .controller.scene import contact
from .model.calibration import Calibration
from .model.calibration import load as load_calibration
from .model.robots import RobotModel, get_model, with_calibration
from .protocol.firmware import DEFAULT_VERSION
from .server.app import ServerConfig, ServerThread
from .viewer.app import attach_viewer

#: SDK configuration attribute of each report port, and the standard port its parser expects.
_SDK_REPORT_PORTS = {"normal": ("TCP_REPORT_NORM_PORT", 30001), "rich": ("TCP_REPORT_RICH_PORT", 30002),
                     "develop": ("TCP_REPORT_REAL_PORT", 30003)}


@contextlib.contextmanager
def running_emulator(model: int | str | RobotModel = 6, *, config_dir: Path | None = None,
                     vacuum: bool = False, firmware: str = DEFAULT_VERSION, linear_track: int | None = None,
                     ft_sensor: bool = False, ft_noise: bool = True, scene: Any = None, gripper: str = "xarm",
                     calibration: Calibration | str | Path | None = None,
                     **config: Any) -> Iterator[ServerThread]:
    """An emulator server on free loopback ports (``ServerConfig`` fields as keywords, e.g.
    ``speed=5.0``, ``admin=True``), stopped at the end of the block. Saved configuration goes to a
    temporary directory unless ``config_dir`` is given; ``vacuum`` attaches the xArm Vacuum Gripper
    (as ``serve --vacuum``); ``gripper`` the gripper on the tool RS-485 (as ``serve --gripper``:
    xarm, robotiq-2f85, robotiq-2f140, bio, bio-g1 or inspire-rh56); ``firmware`` is the version the
    box claims (as ``serve --firmware``);
    ``linear_track`` attaches a linear track that many mm long (as ``serve --linear-track``);
    ``ft_sensor`` mounts the six-axis F/T sensor (as ``serve --ft-sensor``; ``ft_noise=False`` for
    deterministic readings); a part the ``firmware`` cannot drive (protocol/firmware.py ``PARTS``: the
    default ``DEFAULT_VERSION`` drives neither the track nor the sensor; ``SERVE_VERSION`` does) raises
    ``FirmwareRefusal``, as ``serve`` refuses it; and ``scene`` sets a contact scene (a TOML file path, a
    :class:`~xarm_emu.controller.scene.contact.Scene` or its tables, as ``serve --scene``).
    ``calibration`` replaces the emulator's estimated constants (a TOML file path or a
    :class:`~xarm_emu.model.calibration.Calibration`, as ``serve --calibration``).
    A ``faults`` schedule is checked and scheduled, ``view=True`` attaches
    the 3D view, as ``xarm-emu serve`` does."""
    with contextlib.ExitStack() as stack:
        if config_dir is None:
            config_dir = Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="xarm-emu-")))
        cfg = ServerConfig(**{"host": "127.0.0.1", "port": 0, "normal_port": 0, "rich_port": 0,
                              "develop_port": 0, **config})
        if isinstance(scene, (str, Path)):
            scene = contact.load_scene(scene)
        elif isinstance(scene, dict):
            scene = contact.parse_scene(scene)
        if calibration is not None:
            cal = calibration if isinstance(calibration, Calibration) else load_calibration(calibration)
            model = with_calibration(model if isinstance(model, RobotModel) else get_model(model), cal)
        emu = Emulator(model, config_dir=config_dir, vacuum=vacuum, firmware=firmware,
                       linear_track=linear_track, ft_sensor=ft_sensor,
                       ft_noise=ft_noise, scene=scene, gripper=gripper)
        st = ServerThread(emu, cfg,
                          compose=(attach_viewer,)).start()
        try:
            yield st
        finally:
            st.stop()


@contextlib.contextmanager
def sdk_pointed_at(server: ServerThread) -> Iterator[None]:
    """Point the official SDK (``xarm-python-sdk``) at ``server``'s ports for the block; restores the
    SDK's configuration and the process-wide default socket timeout it sets."""
    from xarm.core.config.x_config import XCONF
    from xarm.x3.report import ReportDataStructure

    conf = XCONF.SocketConf
    ports = server.ports
    saved = {"TCP_CONTROL_PORT": conf.TCP_CONTROL_PORT}
    saved.update({attr: getattr(conf, attr) for attr, _ in _SDK_REPORT_PORTS.values()})
    original = ReportDataStructure.__dict__["create"]
    mapping = {ports[kind]: standard for kind, (_, standard) in _SDK_REPORT_PORTS.items()}
    create = original.__func__

    def create_for(cls: type, sock_port: int, **kw: Any) -> Any:
        return create(cls, mapping.get(sock_port, sock_port), **kw)

    previous_timeout = socket.getdefaulttimeout()
    conf.TCP_CONTROL_PORT = ports["command"]
    for kind, (attr, _) in _SDK_REPORT_PORTS.items():
        setattr(conf, attr, ports[kind])
    ReportDataStructure.create = classmethod(create_for)  # type: ignore[method-assign, assignment]
    try:
        yield
    finally:
        ReportDataStructure.create = original  # type: ignore[method-assign]
        for attr, value in saved.items():
            setattr(conf, attr, value)
        socket.setdefaulttimeout(previous_timeout)


#: Seconds the SDK's report thread sleeps between looks at its socket's queue while a frame of the
#: stepped clock is on its way (its own poll is 1 ms, which every handshake would wait).
HANDSHAKE_POLL = 0.0001
#: The report port the SDK reads for each of its ``report_type`` values ("real" is the develop port).
_SDK_REPORT_KIND = {"rich": "rich", "normal": "normal", "real": "develop"}


class _SteppedSdkClock:
    """The clock of :func:`sdk_on_stepped_clock`: ``sleep`` and ``monotonic`` for the program's
    thread (``me``) and the SDK's report thread, the real ones for every other thread."""

    def __init__(self, server: ServerThread, arm: Any) -> None:
        import threading
        import time

        self.me = threading.current_thread()
        self.real_sleep, self.real_monotonic = time.sleep, time.monotonic
        self.base = self.real_monotonic() - server.emulator.time
        self.server = server
        inner = getattr(arm, "_arm", arm)
        self.sdk_kind = (_SDK_REPORT_KIND.get(getattr(inner, "_report_type", "rich"))
                         if getattr(inner, "_enable_report", True) else None)
        self.reporter = getattr(inner, "_report_thread", None)
        self.handled = threading.Semaphore(0)
        self.took = threading.Event()
        self.awaiting = threading.Event()  # a frame of the SDK's port is out and not handled yet
        self.kick = threading.Event()  # ends the report thread's sleep: a frame is out

    def on_report(self, _: Any) -> None:
        self.took.set()  # the frame's report fields are in; it is handled when the thread polls again

    def sleep(self, seconds: float) -> None:
        import threading

        from .controller.core.interface import PERIOD

        current = threading.current_thread()
        if current is not self.me:
            if current is self.reporter:
                self._report_thread_sleep(seconds)
            else:
                self.real_sleep(seconds)
            return
        left = max(1, round(float(seconds) / PERIOD))
        while left > 0:
            n, sent = self.server.server.advance_to_report(left)  # under the arm's lock, not the loop
            left -= n
            if self.sdk_kind in sent:
                self.awaiting.set()
                self.kick.set()
                if not self.handled.acquire(timeout=10.0):
                    raise TimeoutError("the SDK's report thread handled no report frame within 10 s")
                self.awaiting.clear()

    def _report_thread_sleep(self, seconds: float) -> None:
        if self.took.is_set():
            self.took.clear()
            self.handled.release()
        elif self.awaiting.is_set():  # look at the socket's queue again soon, not after its 1 ms
            seconds = min(seconds, HANDSHAKE_POLL)
        if self.kick.wait(seconds):
            self.kick.clear()

    def monotonic(self) -> float:
        import threading

        current = threading.current_thread()
        if current is not self.me and current is not self.reporter:
            return self.real_monotonic()
        return self.base + self.server.emulator.time  # changes only in this thread's sleeps

    def quiet(self) -> None:
        """Let the frames sent on the wall clock before the block be handled, and forget them."""
        while self.handled.acquire(timeout=0.05):
            pass


@contextlib.contextmanager
def sdk_on_stepped_clock(server: ServerThread, arm: Any) -> Iterator[None]:
    """Run the SDK calls of this thread on ``server``'s controller time (a server started with
    ``stepped=True``; ``arm`` the SDK's ``XArmAPI`` connected to it): for the block,
    ``time.sleep(s)`` in this thread runs ``s`` of controller time (at least one control period)
    instead of waiting, and ``time.monotonic()`` reads controller time (from where the wall clock
    stood when the block began), in this thread and in the SDK's report thread. Every wait of the
    SDK and of the program (its polls, its timeouts) then counts control periods, so a program runs
    as fast as the emulator steps, and the same program gives the same result to the last bit.
    Other threads keep the real clock.

    The report frames go out at their deadlines in controller time, not on the wall clock: a sleep
    steps to each deadline that falls in it and writes the frame of every report port with
    readers from the state of that period. For the port the SDK reads, the sleep then waits until
    the SDK's report thread has handled the frame (its report callback ran and it went back to
    polling its socket), so ``arm.angles``, ``arm.position``, ``arm.state`` and the rest of what the
    SDK takes from reports are, after each sleep, those of the last frame due by then, as on a real
    box at that instant."""
    import time

    clock = _SteppedSdkClock(server, arm)
    srv = server.server
    server.call(lambda: setattr(srv, "reports_stepped", True))
    arm.register_report_callback(clock.on_report)
    time.sleep, time.monotonic = clock.sleep, clock.monotonic  # type: ignore[assignment]
    try:
        clock.quiet()
        yield
    finally:
        time.sleep, time.monotonic = clock.real_sleep, clock.real_monotonic  # type: ignore[assignment]
        arm.release_report_callback(clock.on_report)
        server.call(lambda: setattr(srv, "reports_stepped", False))


class RunningProxy:
    """A proxy (``xarm-emu proxy``) on a thread of its own; ``ports`` by kind, as a server's."""

    def __init__(self, proxy: Any, loop: Any, thread: Any) -> None:
        self.proxy, self._loop, self._thread = proxy, loop, thread
        kinds = {502: "command", 30000: "realtime", 30001: "normal", 30002: "rich", 30003: "develop"}
        self.ports = {kinds[std]: port for std, port in proxy.ports.items()}


@contextlib.contextmanager
def running_proxy(server: ServerThread, record: Path | None = None) -> Iterator[RunningProxy]:
    """The recording proxy in front of ``server`` on free loopback ports, recording to ``record``
    (a ``.xrec`` file) when given; point the SDK at it with :func:`sdk_pointed_at`."""
    import asyncio
    import threading

    from .server.proxy import Proxy, ProxyConfig
    from .server.xrec import RecordWriter

    kinds = {"command": 502, "realtime": 30000, "normal": 30001, "rich": 30002, "develop": 30003}
    to = {kinds[k]: p for k, p in server.ports.items() if k in kinds}
    writer = RecordWriter(record, "127.0.0.1", to) if record is not None else None
    px = Proxy(ProxyConfig("127.0.0.1", "127.0.0.1", {std: 0 for std in to}, to), writer)
    loop = asyncio.new_event_loop()
    started = threading.Event()

    def run() -> None:
        asyncio.set_event_loop(loop)
        loop.run_until_complete(px.start())
        started.set()
        loop.run_forever()

    thread = threading.Thread(target=run, name="xarm-emu-proxy", daemon=True)
    thread.start()
    started.wait(10.0)
    try:
        yield RunningProxy(px, loop, thread)
    finally:
        asyncio.run_coroutine_threadsafe(px.close(), loop).result(10.0)
        loop.call_soon_threadsafe(loop.stop)
        thread.join(10.0)
        loop.close()
        if writer is not None:
            writer.stats(px.latency(), {"to_box": px.bytes[0], "to_program": px.bytes[1]})
            writer.close()


@contextlib.contextmanager
def reading_reports(server: ServerThread | RunningProxy,
                    kinds: tuple[str, ...] = ("realtime",)) -> Iterator[None]:
    """Readers of ``server``'s report ports of ``kinds`` for the block, each on a thread that reads
    and drops the frames (through a proxy, so that they are recorded: ``compare`` needs the real-time
    report, which the SDK does not open)."""
    import threading

    stop = threading.Event()

    def read(port: int) -> None:
        with socket.create_connection(("127.0.0.1", port)) as s:
            s.settimeout(0.2)
            while not stop.is_set():
                with contextlib.suppress(OSError):
                    s.recv(1 << 16)

    threads = [threading.Thread(target=read, args=(server.ports[k],), daemon=True) for k in kinds]
    for t in threads:
        t.start()
    try:
        yield
    finally:
        stop.set()
        for t in threads:
            t.join(5.0)
