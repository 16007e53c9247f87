"""Admin channel: fault injection and sensor play from outside the emulator (issue 5, item 5).

Off unless ``xarm-emu serve --admin`` (``ServerConfig.admin``). It listens on the loopback
interface only: on ``--host`` when that is a loopback address (127.0.0.2, so that arms on their
own loopback addresses each have one on the same port), else on 127.0.0.1; it refuses any peer
that is not a loopback address.

Port: ``--admin-port`` if given, else the command port + :data:`ADMIN_PORT_OFFSET` (502 -> 10502).
The ``inject``/``clear``/``set-input`` CLI commands derive it the same way from ``--port``.

Protocol: line-based JSON over TCP. Each request is one JSON object on one line, with ``cmd`` and
the command's arguments; each answer is one JSON object on one line::

    -> {"cmd": "error", "code": "C31"}
    <- {"ok": true, "message": "injected C31 Collision caused abnormal current"}
    -> {"cmd": "servo-error", "joint": 9, "code": "S23"}
    <- {"ok": false, "error": "joint 9 out of range 1..6"}

Commands (the codes are the manual's labels, chapter 3, parsed with ``codes.parse_label``):

=================  ===========================================  ===============================
cmd                arguments                                     effect
=================  ===========================================  ===============================
estop              -                                             emergency stop, error C1
error              code "C31" (or 31)                            control box error (3.2.1)
warning            code 11 (or "W11")                            warning (3.2.2)
servo-error        joint 1..dof, code "S23"                      servo error, error C10+joint
gripper-error      code "G11"                                    gripper error (3.3)
end-module-lost    -                                             error C28
collision          joint 1..dof, torque (N m)                    external torque: C31 when the
                                                                 collision sensitivity detects it
report-pause       seconds (wall)                                no report frames for that long
reply-delay        seconds (wall, 0 switches it off)             each command reply delayed
drop-clients       -                                             close every client connection
clear              -                                             clear all faults and delays
set-input          kind cgpio/tgpio/analog/tool-analog,          a sensor input
                   index, value
status             -                                             time, error, warning, delays
step               seconds (controller time)                     lockstep (--stepped) only: run them
=================  ===========================================  ===============================

A refused request changes nothing.
"""

from __future__ import annotations

import asyncio
import json
import logging
import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from ..controller.base import CommandWarning
from ..protocol import codes
from ..protocol.admin import (  # noqa: F401 - re-exported for the server's users
    ADMIN_PORT_OFFSET,
    COMMANDS,
    INPUT_KINDS,
    MAX_LINE,
    MAX_SECONDS,
    admin_host,
    derive_admin_port,
    is_loopback,
)

if TYPE_CHECKING:
    from .app import EmulatorServer

log = logging.getLogger("xarm_emu.admin")


class AdminError(ValueError):
    """A refused admin request (its message goes back to the client)."""


def _label(value: Any, prefix: str) -> codes.Code:
    """Parse a code given as a label ('C31') or a bare number (31) for the table ``prefix``."""
    if isinstance(value, bool) or not isinstance(value, (str, int)):
        raise AdminError(f"code must be a label like {prefix}11, got {value!r}")
    text = str(value).strip()
    if text.isdigit():
        text = prefix + text
    try:
        entry = codes.parse_label(text)
    except ValueError as exc:
        raise AdminError(str(exc)) from None
    if entry.prefix != prefix:
        raise AdminError(f"{entry.label} is not a {_KIND[prefix]} code ({prefix}<n>)")
    return entry


_KIND = {"C": "control box error", "W": "warning", "S": "servo error", "G": "gripper error"}


def _seconds(value: Any) -> float:
    if isinstance(value, str):
        value = parse_duration(value)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise AdminError(f"seconds must be a number, got {value!r}")
    if not 0.0 <= value <= MAX_SECONDS:
        raise AdminError(f"seconds {value} out of range 0..{MAX_SECONDS:g}")
    return float(value)


def parse_duration(text: str) -> float:
    """'2s', '50ms', '1.5' (seconds), '250us' -> seconds."""
    t = text.strip().lower()
    for suffix, scale in (("ms", 1e-3), ("us", 1e-6), ("s", 1.0), ("", 1.0)):
        if suffix and not t.endswith(suffix):
            continue
        number = t[: len(t) - len(suffix)] if suffix else t
        try:
            value = float(number) * scale
        except ValueError:
            break
        if not math.isfinite(value) or value < 0:
            break
        return value
    raise AdminError(f"not a duration: {text!r} (examples: 2s, 50ms, 0.5)")


def _int(value: Any, name: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        if isinstance(value, str) and value.strip().lstrip("-").isdigit():
            return int(value)
        raise AdminError(f"{name} must be an integer, got {value!r}")
    return value


def _joint(request: dict[str, Any], dof: int) -> int:
    joint = _int(request.get("joint"), "joint")
    if not 1 <= joint <= dof:
        raise AdminError(f"joint {joint} out of range 1..{dof}")
    return joint


def _float(value: Any, name: str) -> float:
    if isinstance(value, bool):
        raise AdminError(f"{name} must be a number, got {value!r}")
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise AdminError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(x):
        raise AdminError(f"{name} must be finite, got {value!r}")
    return x


def execute(server: EmulatorServer, request: dict[str, Any]) -> str:
    """Run one admin request in the server's loop thread; returns a message or raises AdminError.

    Every argument is checked before anything changes, so a refused request changes nothing.
    """
    return prepare(server, request)()


#: Admin commands a fault schedule may hold (server/faults.py): the faults and inputs, not the
#: queries or the lockstep clock.
SCHEDULABLE = frozenset(COMMANDS) - {"status", "step"}


def prepare(server: EmulatorServer, request: dict[str, Any]) -> Callable[[], str]:
    """Check one admin request now and return the action that carries it out (a message back).

    Raises AdminError for a bad request; the action it returns does not refuse.
    """
    emu = server.emulator
    cmd = request.get("cmd")
    if cmd == "estop":

        def estop() -> str:
            emu.inject_estop()
            return "emergency stop: C1"

        return estop
    if cmd in ("error", "warning", "gripper-error"):
        prefix = {"error": "C", "warning": "W", "gripper-error": "G"}[cmd]
        entry = _label(request.get("code"), prefix)

        def inject() -> str:
            if cmd == "error":
                emu.inject_error(entry.code)
                return f"injected {entry.label} {entry.name}"
            if cmd == "warning":
                emu.inject_warning(entry.code)
                return f"injected warning {entry.code} {entry.name}"
            emu.inject_gripper_error(entry.code)
            return f"injected gripper {entry.label} {entry.name}"

        return inject
    if cmd == "servo-error":
        joint = _joint(request, emu.model.dof)
        servo = _label(request.get("code"), "S")

        def inject_servo() -> str:
            emu.inject_servo_error(joint, servo.code)
            return f"injected {servo.label} {servo.name} on joint {joint} (C{10 + joint})"

        return inject_servo
    if cmd == "end-module-lost":

        def lose_end_module() -> str:
            emu.inject_end_module_lost()
            return "end module lost: C28"

        return lose_end_module
    if cmd == "collision":
        joint = _joint(request, emu.model.dof)
        torque = _float(request.get("torque"), "torque")

        def push() -> str:
            level = emu.controller.settings.collision_sensitivity
            if emu.inject_collision(joint, torque):
                return f"collision of {torque:g} N m on joint {joint} detected at sensitivity {level}: C31"
            return f"collision of {torque:g} N m on joint {joint} not detected (sensitivity {level})"

        return push
    if cmd == "report-pause":
        pause = _seconds(request.get("seconds"))

        def pause_reports() -> str:
            server.pause_reports(pause)
            return f"reports paused for {pause:g} s"

        return pause_reports
    if cmd == "reply-delay":
        delay = _seconds(request.get("seconds"))

        def set_delay() -> str:
            server.reply_delay = delay
            return f"reply delay {delay * 1e3:g} ms" if delay else "reply delay off"

        return set_delay
    if cmd == "drop-clients":
        return lambda: f"dropped {server.drop_clients()} client connections"
    if cmd == "clear":

        def clear() -> str:
            emu.clear_faults()
            server.reply_delay = 0.0
            server.report_pause_until = 0.0
            return "faults, reply delay and report pause cleared"

        return clear
    if cmd == "set-input":
        return _set_input(server, request)
    if cmd == "step":
        if not server.config.stepped:
            raise AdminError("step needs lockstep time: start the emulator with --stepped")
        secs = _seconds(request.get("seconds"))

        def advance() -> str:
            n = server.advance(secs)
            return f"advanced {n} control periods to t = {emu.time:.3f} s"

        return advance
    if cmd == "status":

        def status() -> str:
            ctl = emu.controller
            return json.dumps({"time": ctl.time, "error": ctl.error_code, "warning": ctl.warning_code,
                               "servo_errors": list(ctl.servo_errors), "reply_delay": server.reply_delay,
                               "reports_paused": server.reports_paused()})

        return status
    raise AdminError(f"unknown command {cmd!r}; known: {', '.join(COMMANDS)}")


def _set_input(server: EmulatorServer, request: dict[str, Any]) -> Callable[[], str]:
    kind = request.get("kind")
    if kind not in INPUT_KINDS:
        raise AdminError(f"unknown input kind {kind!r}; known: {', '.join(INPUT_KINDS)}")
    index = _int(request.get("index"), "index")
    value = _float(request.get("value"), "value")
    if kind in ("cgpio", "tgpio", "vacuum-object") and value not in (0, 1):
        raise AdminError(f"digital input value must be 0 or 1, got {value!r}")
    try:
        server.emulator.check_input(kind, index)
    except (ValueError, CommandWarning) as exc:  # the IO module's own range checks
        raise AdminError(f"{kind} input {index}: {exc}") from None

    def play() -> str:
        server.emulator.set_input(kind, index, value)
        return f"{kind} input {index} = {value:g}"

    return play


class AdminProtocol(asyncio.Protocol):
    """One admin connection: JSON lines in, JSON lines out."""

    def __init__(self, server: EmulatorServer) -> None:
        self.server = server
        self.transport: asyncio.Transport | None = None
        self._buf = bytearray()

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        self.transport = transport  # type: ignore[assignment]  # uvloop's transports are not subclasses
        peer = transport.get_extra_info("peername")
        host = str(peer[0]) if peer else ""
        if not is_loopback(host):
            log.warning("admin: refused non-loopback peer %s", host)
            self._answer({"ok": False, "error": f"refused: the admin channel accepts loopback peers only, "
                                                f"not {host or 'unknown'}"})
            transport.close()
            self.transport = None
            return
        self.server.admin_clients.add(self)

    def data_received(self, data: bytes) -> None:
        if self.transport is None:
            return
        self._buf += data
        while self.transport is not None and b"\n" in self._buf:
            line, _, rest = bytes(self._buf).partition(b"\n")
            self._buf = bytearray(rest)
            if line.strip():
                self._answer(self.handle_line(line))
        if self.transport is not None and len(self._buf) > MAX_LINE:
            self._answer({"ok": False, "error": f"request line longer than {MAX_LINE} bytes"})
            self.transport.close()
            self.transport = None

    def handle_line(self, line: bytes) -> dict[str, Any]:
        try:
            request = json.loads(line)
        except (ValueError, UnicodeDecodeError):
            return {"ok": False, "error": "not a JSON object line"}
        if not isinstance(request, dict):
            return {"ok": False, "error": "not a JSON object line"}
        self.server.catch_up()  # the fault lands after every control period that has elapsed
        try:
            message = execute(self.server, request)
        except AdminError as exc:
            return {"ok": False, "error": str(exc)}
        log.info("admin: %s", message)
        return {"ok": True, "message": message}

    def _answer(self, obj: dict[str, Any]) -> None:
        if self.transport is not None and not self.transport.is_closing():
            self.transport.write(json.dumps(obj).encode() + b"\n")

    def connection_lost(self, exc: Exception | None) -> None:
        self.transport = None
        self.server.admin_clients.discard(self)
