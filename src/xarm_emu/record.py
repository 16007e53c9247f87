"""Sessions recorded to a Rerun recording (``xarm-emu record``, ``xarm-emu serve --record``).

A recording holds, against the ``time`` timeline (seconds since the recording began):

- ``joints/j1`` .. ``joints/jN``: joint angles in degrees (develop report, manual 2.1.6, 100 Hz);
- ``tcp/x``, ``tcp/y``, ``tcp/z`` in mm and ``tcp/roll``, ``tcp/pitch``, ``tcp/yaw`` in degrees;
- ``tcp/speed``: the TCP speed in mm/s, from successive poses;
- ``torques/j1`` .. ``torques/jN``: joint torques in N m;
- ``state``, ``mode``, ``cmdnum``, ``error``, ``warning`` (the last two from the rich report, 5 Hz);
- ``io/cgpio_in``, ``io/cgpio_out``: the control box digital inputs and outputs as bit fields;
- ``events``: a text log of state, mode, error, warning and IO changes (errors and warnings with
  the manual's chapter 3 name), and, under ``serve --record``, client connections;
- ``commands``: under ``serve --record``, every command-port request and its reply state byte, with
  the controller time on a second timeline, ``controller``;
- ``arm/links``: the arm's joint origins as a line strip (forward kinematics of the model), and
  ``arm/tcp_path`` the TCP positions so far, ten times a second;
- ``objects/<name>``: under ``serve --record`` with a scene of ``[[object]]`` tables, each object as
  the physics world has it, ten times a second: a box (``Boxes3D``), a cylinder (``Cylinders3D``) or a
  sphere (``Ellipsoids3D``) at its centre (mm, base frame) and orientation, and ``objects/<name>/held``
  (1 while both fingers or the vacuum cup hold it); a feeder's parts appear as it places them;
- ``cell/belts/<name>`` and ``cell/sensors/<name>``: under ``serve --record`` with a cell, ten times a
  second, each belt as its box (``Boxes3D``, green while it runs, grey stopped) with
  ``cell/belts/<name>/running`` (1 while it runs), and each sensor's beam as a line
  (``LineStrips3D``) or its region as a box, red while an object interrupts it, with
  ``cell/sensors/<name>/interrupted`` (1 while interrupted).

Open it with Rerun's viewer: ``rerun session.rrd`` (the native viewer, ``pip install rerun-sdk``),
or ``rerun --web-viewer session.rrd`` in the browser. Needs the ``record`` extra
(``pip install 'xarm-emu[record]'``).
"""

from __future__ import annotations

import logging
import math
import selectors
import socket
import threading
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .client import ReportStream
from .controller.core.state_machine import MODE_NAMES, STATE_NAMES
from .protocol import codes
from .protocol.registers import REGISTERS as MANUAL_REGISTERS
from .protocol.registers import Register
from .protocol.reports import DEVELOP_PORT, RICH_PORT, ReportSnapshot

if TYPE_CHECKING:
    from .model.robots import RobotModel
    from .server.core import EmulatorServer

log = logging.getLogger("xarm_emu.record")

#: Seconds between two arm geometry entries (``arm/links``, ``arm/tcp_path``).
GEOMETRY_PERIOD = 0.1
#: Seconds over which ``tcp/speed`` is taken from successive poses.
SPEED_WINDOW = 0.05
#: Reply state byte bits (manual 2.1.2): 0x40 an error is active, 0x20 a warning.
ERROR_BIT, WARNING_BIT = 0x40, 0x20

_AXES = ("x", "y", "z", "roll", "pitch", "yaw")


class RecordError(RuntimeError):
    """The recording cannot be made (rerun-sdk missing, file not writable)."""


def _rerun() -> Any:
    try:
        import rerun as rr
    except ImportError:
        raise RecordError("recording needs rerun-sdk: pip install 'xarm-emu[record]'") from None
    return rr


class SessionRecorder:
    """Writes reports, commands and events to a Rerun ``.rrd`` file (module docstring)."""

    def __init__(self, path: Path | str, model: RobotModel | None = None) -> None:
        rr = _rerun()
        self._rr = rr
        self.path = Path(path)
        self.model = model
        self._lock = threading.Lock()
        self._rec = rr.RecordingStream("xarm-emu")
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._rec.save(str(self.path))
        except Exception as exc:  # rerun raises its own error types for a bad path
            raise RecordError(f"cannot write the recording {self.path}: {exc}") from None
        self._t0 = time.monotonic()
        self._last: ReportSnapshot | None = None
        self._last_rich: ReportSnapshot | None = None
        self._last_pose: tuple[float, list[float]] | None = None
        self._last_geometry = -math.inf
        self._path: list[list[float]] = []
        self.reports = 0
        self.commands = 0
        self._closed = False
        #: Under ``serve --record`` with objects: returns each object's declared shape and size and
        #: its pose now, ``(name, shape, size mm, Emulator.scene_objects() entry)``.
        self.objects: Callable[[], list[tuple[str, str, tuple[float, ...], Mapping[str, Any]]]] | None = None
        self._last_objects = -math.inf
        #: Under ``serve --record`` with a cell: returns the cell as the scene declares it
        #: (``controller/scene/cell.py``) and its elements' state (``xarm-emu scene --json``).
        self.cell: Callable[[], tuple[Any, Mapping[str, Any]] | None] | None = None

    def now(self) -> float:
        """Seconds since the recording began (the ``time`` timeline)."""
        return time.monotonic() - self._t0

    def _at(self, t: float | None) -> float:
        t = self.now() if t is None else t
        self._rec.set_time("time", duration=t)
        return t

    def _scalar(self, entity: str, value: float) -> None:
        self._rec.log(entity, self._rr.Scalars([float(value)]))

    def event(self, text: str, level: str = "INFO", t: float | None = None) -> None:
        """One line of the ``events`` log."""
        with self._lock:
            if self._closed:
                return
            self._at(t)
            self._rec.log("events", self._rr.TextLog(text, level=level))

    def report(self, snap: ReportSnapshot, rich: bool = False, t: float | None = None) -> None:
        """One decoded report: the develop report's motion state and joints, or (``rich``) the rich
        report's error, warning and IO."""
        # the objects are read before the recorder's lock is taken (reading them takes the server's,
        # which the server holds while it passes a command to the recorder)
        t = self.now() if t is None else t
        objects = None
        cell = None
        if not rich and self.objects is not None and t - self._last_objects >= GEOMETRY_PERIOD:
            self._last_objects = t
            objects = self.objects()
            cell = self.cell() if self.cell is not None else None
        with self._lock:
            if self._closed:
                return
            t = self._at(t)
            self.reports += 1
            if objects:
                self._objects(objects)
            if cell is not None:
                self._cell(*cell)
            if rich:
                self._rich(snap)
                return
            n = self.model.dof if self.model is not None else 7
            for i, q in enumerate(snap.joints[:n], start=1):
                self._scalar(f"joints/j{i}", math.degrees(q))
            for i, tau in enumerate(snap.torques[:n], start=1):
                self._scalar(f"torques/j{i}", tau)
            pose = [*snap.pose[:3], *(math.degrees(a) for a in snap.pose[3:6])]
            for name, v in zip(_AXES, pose, strict=True):
                self._scalar(f"tcp/{name}", v)
            if self._last_pose is None:
                self._last_pose = (t, pose)
            elif t - self._last_pose[0] >= SPEED_WINDOW:  # frames arrive in bursts: not per frame
                dt = t - self._last_pose[0]
                self._scalar("tcp/speed", math.dist(pose[:3], self._last_pose[1][:3]) / dt)
                self._last_pose = (t, pose)
            for name in ("state", "mode", "cmdnum"):
                self._scalar(name, getattr(snap, name))
            prev = self._last
            if prev is None or prev.state != snap.state:
                self._log_event(f"state {snap.state} ({STATE_NAMES.get(snap.state, '?')})", "INFO")
            if prev is None or prev.mode != snap.mode:
                self._log_event(f"mode {snap.mode} ({MODE_NAMES.get(snap.mode, '?')})", "INFO")
            self._last = snap
            if t - self._last_geometry >= GEOMETRY_PERIOD:
                self._last_geometry = t
                self._geometry(snap)

    def _log_event(self, text: str, level: str) -> None:
        self._rec.log("events", self._rr.TextLog(text, level=level))

    def _rich(self, snap: ReportSnapshot) -> None:
        prev = self._last_rich
        self._scalar("error", snap.error)
        self._scalar("warning", snap.warning)
        self._scalar("io/cgpio_in", snap.cgpio_input_config)
        self._scalar("io/cgpio_out", snap.cgpio_output_config)
        if prev is None or prev.error != snap.error:
            self._log_event(f"error {codes.describe_error(snap.error)}", "ERROR" if snap.error else "INFO")
        if prev is None or prev.warning != snap.warning:
            self._log_event(f"warning {codes.describe_warning(snap.warning)}",
                            "WARN" if snap.warning else "INFO")
        if prev is not None and prev.cgpio_input_config != snap.cgpio_input_config:
            self._log_event(f"control box inputs 0x{snap.cgpio_input_config:04x}", "INFO")
        if prev is not None and prev.cgpio_output_config != snap.cgpio_output_config:
            self._log_event(f"control box outputs 0x{snap.cgpio_output_config:04x}", "INFO")
        self._last_rich = snap

    def _geometry(self, snap: ReportSnapshot) -> None:
        rr = self._rr
        self._path.append([float(v) for v in snap.pose[:3]])
        self._rec.log("arm/tcp_path", rr.Points3D(self._path[-2000:], radii=1.5))
        if self.model is None:
            return
        from .model.kinematics import joint_frames

        frames = joint_frames(self.model, list(snap.joints[:self.model.dof]))
        points = [[float(v) for v in f[:3, 3]] for f in frames]
        self._rec.log("arm/links", rr.LineStrips3D([[[0.0, 0.0, 0.0], *points]], radii=8.0))

    def _objects(self, objects: list[tuple[str, str, tuple[float, ...], Mapping[str, Any]]]) -> None:
        """Each object's shape at its pose (``objects/<name>``) and whether it is held."""
        from .model.rotations import quat_from_matrix, rpy_to_matrix

        rr = self._rr
        for name, shape, size, pose in objects:
            w, x, y, z = quat_from_matrix(rpy_to_matrix(*(math.radians(a) for a in pose["rpy"])))
            centre = [[float(v) for v in pose["position"]]]
            turn = [rr.Quaternion(xyzw=[float(x), float(y), float(z), float(w)])]
            if shape == "box":
                item = rr.Boxes3D(centers=centre, half_sizes=[[v / 2 for v in size]], quaternions=turn)
            elif shape == "cylinder":
                item = rr.Cylinders3D(centers=centre, lengths=[size[1]], radii=[size[0] / 2],
                                      quaternions=turn)
            else:
                item = rr.Ellipsoids3D(centers=centre, half_sizes=[[size[0] / 2] * 3], quaternions=turn)
            self._rec.log(f"objects/{name}", item)
            self._scalar(f"objects/{name}/held", 1.0 if pose["held"] else 0.0)

    def _cell(self, cell: Any, status: Mapping[str, Any]) -> None:
        """Each belt as its box and each sensor's beam or region, coloured by their state."""
        from .viewer.scene import BEAM_CLEAR, BEAM_CUT, BELT_RUNNING, BELT_STOPPED

        rr = self._rr
        for c, st in zip(cell.conveyors, status.get("conveyors", []), strict=False):
            running = bool(st["running"])
            self._rec.log(f"cell/belts/{c.name}", rr.Boxes3D(
                mins=[list(c.min)], sizes=[[hi - lo for lo, hi in zip(c.min, c.max, strict=True)]],
                colors=[BELT_RUNNING if running else BELT_STOPPED]))
            self._scalar(f"cell/belts/{c.name}/running", 1.0 if running else 0.0)
        for sensor, st in zip(cell.sensors, status.get("sensors", []), strict=False):
            cut = bool(st["interrupted"])
            tint = [BEAM_CUT if cut else BEAM_CLEAR]
            if sensor.beam is not None:
                item = rr.LineStrips3D([[list(sensor.beam[0]), list(sensor.beam[1])]], radii=2.0, colors=tint)
            else:
                lo, hi = sensor.region
                item = rr.Boxes3D(mins=[list(lo)], sizes=[[b - a for a, b in zip(lo, hi, strict=True)]],
                                  colors=tint)
            self._rec.log(f"cell/sensors/{sensor.name}", item)
            self._scalar(f"cell/sensors/{sensor.name}/interrupted", 1.0 if cut else 0.0)

    def command(self, controller_time: float, peer: str, register: int, name: str | None,
                state: int | None, t: float | None = None) -> None:
        """One command-port request and its reply state byte (manual 2.1.2)."""
        with self._lock:
            if self._closed:
                return
            self._at(t)
            self._rec.set_time("controller", duration=controller_time)
            self.commands += 1
            flags = state or 0
            level = "ERROR" if flags & ERROR_BIT else "WARN" if flags & WARNING_BIT else "DEBUG"
            self._rec.log("commands", self._rr.TextLog(
                f"{register} {name or '?'} from {peer}: state 0x{flags:02x}", level=level))
            self._rec.reset_time()

    def close(self) -> None:
        with self._lock:
            if self._closed:
                return
            self._closed = True
            self._rec.flush()
            self._rec.disconnect()


def record_reports(recorder: SessionRecorder, host: str, develop_port: int = DEVELOP_PORT,
                   rich_port: int = RICH_PORT, duration: float | None = None,
                   stop: threading.Event | None = None, timeout: float = 5.0) -> int:
    """Read the develop and rich reports of the box at ``host`` into ``recorder`` until ``duration``
    seconds have passed, ``stop`` is set or the box closes a report port; returns the frames read.
    Raises OSError when a report port cannot be reached."""
    streams = {"develop": ReportStream("develop"), "rich": ReportStream("rich")}
    socks = {"develop": socket.create_connection((host, develop_port), timeout=timeout),
             "rich": socket.create_connection((host, rich_port), timeout=timeout)}
    sel = selectors.DefaultSelector()
    for kind, sock in socks.items():
        sel.register(sock, selectors.EVENT_READ, kind)
    end = math.inf if duration is None else time.monotonic() + duration
    frames = 0
    try:
        while time.monotonic() < end and not (stop is not None and stop.is_set()):
            for key, _ in sel.select(timeout=min(0.1, max(0.0, end - time.monotonic()))):
                kind = key.data
                data = socks[kind].recv(65536)
                streams[kind].receive_data(data)
                if not data:
                    return frames
                while (snap := streams[kind].next_report()) is not None:
                    recorder.report(snap, rich=kind == "rich")
                    frames += 1
    finally:
        sel.close()
        for sock in socks.values():
            sock.close()
    return frames


def model_of(version: str) -> RobotModel | None:
    """The arm model a GET_VERSION answer names (its first field is the axis count), if known."""
    from .model.robots import get_model

    head = version.split(",")[0].strip()
    try:
        return get_model(int(head))
    except ValueError:
        return None


class RecordingTrace:
    """Stands in for the server's command trace (server/trace.py) under ``serve --record``: passes
    each connection and request to the recorder, and to the file trace when there is one."""

    def __init__(self, recorder: SessionRecorder, inner: Any | None = None) -> None:
        self.recorder = recorder
        self.inner = inner

    def event(self, t: float, peer: str, what: str) -> None:
        if self.inner is not None:
            self.inner.event(t, peer, what)
        self.recorder.event(f"client {peer}: {what}")

    def start(self, t: float, box: Mapping[str, Any]) -> None:
        """The box that started (the file trace's start line)."""
        if self.inner is not None:
            self.inner.start(t, box)

    def outside(self, t: float, period: int, source: str, request: dict[str, Any], message: str) -> None:
        """A change made from outside the protocol: the file trace's line, and an event of the
        recording."""
        if self.inner is not None:
            self.inner.outside(t, period, source, request, message)
        self.recorder.event(f"{source} {request.get('cmd', '?')}: {message}")

    def command(self, t: float, peer: str, tid: int, protocol: int, register: int, params: bytes,
                frame: bytes, table: Mapping[int, Register] | None = None,
                asked: float | None = None) -> None:
        """One request and its reply, named with ``table``, the registers the box answers (default:
        the manual's), as the file trace names it."""
        if self.inner is not None:
            self.inner.command(t, peer, tid, protocol, register, params, frame, table, asked)
        reg = (table or MANUAL_REGISTERS).get(register)
        self.recorder.command(t, peer, register, reg.name if reg is not None else None,
                              frame[7] if len(frame) >= 8 else None)

    def modbus(self, t: float, peer: str, tid: int, unit: int, pdu: bytes, frame: bytes) -> None:
        """One standard Modbus request and its reply (the file trace's line; the recording shows
        the register map's values in its own streams)."""
        if self.inner is not None:
            self.inner.modbus(t, peer, tid, unit, pdu, frame)

    def flush(self) -> None:
        if self.inner is not None:
            self.inner.flush()

    def close(self) -> None:
        if self.inner is not None:
            self.inner.close()


class RecordAttachment:
    """``serve --record``: a thread reading the server's own report ports into the recording."""

    port = 0

    def __init__(self, server: EmulatorServer, recorder: SessionRecorder) -> None:
        self.server = server
        self.recorder = recorder
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        if server.emulator.physics is not None:
            recorder.objects = self._objects
            recorder.cell = self._cell

    def _objects(self) -> list[tuple[str, str, tuple[float, ...], Mapping[str, Any]]]:
        """The scene's objects where the physics world has them now (under the server's lock)."""
        emu = self.server.emulator
        with self.server.lock:
            physics = emu.physics
            if physics is None:
                return []
            specs = physics.world.listed_specs()
            poses = emu.scene_objects()
        return [(o.name, o.shape, o.size, p) for o, p in zip(specs, poses, strict=True)]

    def _cell(self) -> tuple[Any, Mapping[str, Any]] | None:
        """The scene's cell and its elements' state now (under the server's lock); None: no cell."""
        with self.server.lock:
            physics = self.server.emulator.physics
            runner = None if physics is None else physics.cell
            return None if runner is None else (runner.cell, runner.status())

    def start(self) -> None:
        host = self.server.config.host
        ports = self.server.ports
        connect_host = "127.0.0.1" if host in ("0.0.0.0", "", "::") else host

        def run() -> None:
            try:
                record_reports(self.recorder, connect_host, ports["develop"], ports["rich"], stop=self._stop)
            except OSError as exc:
                log.error("recording %s stopped: %s", self.recorder.path, exc)

        self._thread = threading.Thread(target=run, name="xarm-emu-record", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
        self.recorder.close()
        log.info("recording %s: %d reports, %d commands", self.recorder.path, self.recorder.reports,
                 self.recorder.commands)


def attach_recorder(server: EmulatorServer, path: Path) -> Callable[[], RecordAttachment]:
    """Record ``server``'s session to ``path`` (``serve --record``): its commands through the trace
    hook and its reports through its own report ports once they are open. Call before start()."""
    from .server.trace import CommandTrace

    recorder = SessionRecorder(path, server.emulator.model)
    inner = None
    if server.config.trace is not None:
        try:
            inner = CommandTrace(server.config.trace)
        except OSError as exc:
            raise ValueError(f"cannot open the trace file {server.config.trace}: "
                             f"{exc.strerror or exc}") from None
    server.trace = RecordingTrace(recorder, inner)  # type: ignore[assignment]

    def factory() -> RecordAttachment:
        return RecordAttachment(server, recorder)

    server.attach("record", factory)
    return factory
