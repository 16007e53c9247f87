"""Admin channel: fault injection, sensor play and checkpoints from outside the emulator.

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
gripper-error      code "G11" (or 11)                            an error of the attached gripper:
                                                                 3.3 for the xArm gripper, gFLT for
                                                                 a Robotiq, 11/12 for the BIO
track-error        code 12                                       linear track drive error
end-module-lost    -                                             error C28
collision          joint 1..dof, torque (N m)                    external torque: C31 when the
                                                                 collision sensitivity detects it
report-pause       seconds (wall)                                no report frames for that long
reply-delay        seconds (wall, 0 switches it off)             each command reply delayed
drop-clients       -                                             close every client connection
clear              -                                             clear all faults and delays
set-input          kind cgpio/tgpio/analog/tool-analog/          a sensor input; gripper-object:
                   vacuum-object/gripper-object, index, value    an object of value mm between the
                                                                 fingers (index 0) or around them
                                                                 (1, Robotiq); 0 removes it
set-input          kind ft, wrench [6], frame tool/base,         external wrench on the TCP
                   ramp (s), for (s)                             (replaces the one played before)
ft-error           code 0..255 (0 clears)                        the F/T sensor's error
ft-noise           on true/false                                 F/T noise and drift on/off
payload            mass (kg), com [3] (mm, flange frame)         the physical payload
scene              scene {"plane": [...], "box": [...]}          the contact scene (replaced)
status             -                                             time, error, warning, delays,
                                                                 why saves or the trace fail
step               seconds (controller time)                     lockstep (--stepped) only: run them
checkpoint-save    name                                          keep the emulator's whole state
checkpoint-restore name                                          back to a kept state
checkpoint-list    -                                             the kept names
=================  ===========================================  ===============================

Checkpoints are an emulator feature (no real control box has them): they live in the server's
memory only, named, until the process ends. A refused request changes nothing.

This module is request checking and preparation only: it works on any :class:`AdminTarget` (the
running server satisfies it structurally), and the socket side is :mod:`.admin_port`.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from typing import Any, Protocol, cast

from ..controller.core.interface import CommandWarning
from ..controller.devices.linear_track import TRACK_ERRORS
from ..controller.emulator import Emulator
from ..controller.scene import contact
from ..protocol import codes
from ..protocol.admin import COMMANDS, INPUT_KINDS, MAX_SECONDS, WRENCH_FRAMES, checkpoint_name
from . import scene_admin


class Checkpointing(Protocol):
    """The emulator's checkpoint pair: an opaque copy of its whole state, and back to one."""

    def checkpoint(self) -> object: ...

    def restore(self, saved: object) -> None: ...


class AdminTarget(Protocol):
    """What an admin request needs of a server: its emulator, its clock and its fault knobs."""

    emulator: Emulator
    #: Named checkpoints (``checkpoint-save``), opaque objects of ``Emulator.checkpoint()``.
    checkpoints: dict[str, object]

    @property
    def stepped(self) -> bool:
        """Lockstep time: controller time advances only by :meth:`advance`."""
        ...

    def advance(self, seconds: float) -> int: ...

    def pause_reports(self, seconds: float) -> None: ...

    def reports_paused(self) -> bool: ...

    def set_reply_delay(self, seconds: float) -> None: ...

    @property
    def reply_delay(self) -> float: ...

    def clear_delays(self) -> None:
        """No reply delay and no report pause."""
        ...

    def drop_clients(self) -> int: ...


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


def _gripper_code(value: Any, gripper: str) -> codes.Code:
    """A code of the attached gripper's table (codes.GRIPPER_TABLES), as "G14", 14 or "0x0E"."""
    if isinstance(value, bool) or not isinstance(value, (str, int)):
        raise AdminError(f"code must be a gripper code like G11 or 11, got {value!r}")
    text = str(value).strip().upper().removeprefix("G")
    try:
        number = int(text, 0)
    except ValueError:
        raise AdminError(f"not a gripper error code: {value!r} (examples: G11, 11, 0x0E)") from None
    table = codes.GRIPPER_TABLES.get(gripper, codes.GRIPPER_ERRORS)
    entry = table.get(number)
    if entry is None:
        raise AdminError(f"{number} is not an error code of the {gripper} gripper; known: "
                         + ", ".join(str(c) for c in sorted(table)))
    return entry


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


def execute(server: AdminTarget, request: dict[str, Any]) -> str:
    """Run one admin request in the server's loop thread; returns a message or raises AdminError.

    Every argument is checked before anything changes, so a refused request changes nothing.
    """
    return prepare(server, request)()


#: Admin commands a fault schedule may hold (server/faults.py): the faults and inputs, not the
#: queries, the lockstep clock or the checkpoints.
SCHEDULABLE = frozenset(COMMANDS) - {"status", "step", "checkpoint-save", "checkpoint-restore",
                                     "checkpoint-list", "scene-objects"}


def prepare(server: AdminTarget, request: dict[str, Any]) -> Callable[[], str]:
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
        entry = (_gripper_code(request.get("code"), emu.gripper_kind) if cmd == "gripper-error"
                 else _label(request.get("code"), prefix))

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
    if cmd == "track-error":
        code = _int(request.get("code"), "code")
        if emu.linear_track is None:
            raise AdminError("no linear track is attached (serve --linear-track)")
        if code not in TRACK_ERRORS:
            raise AdminError(f"linear track error {code}: one of {', '.join(map(str, TRACK_ERRORS))}")

        def inject_track() -> str:
            emu.inject_track_error(code)
            return f"injected linear track error {code} {TRACK_ERRORS[code]}"

        return inject_track
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
            ctl = emu.controller
            level = ctl.settings.collision_sensitivity
            active, enabled = ctl.error_code, all(ctl.enabled)  # detection needs no error, enabled joints
            if emu.inject_collision(joint, torque):
                return f"collision of {torque:g} N m on joint {joint} detected at sensitivity {level}: C31"
            why = (f"error {codes.describe_error(active)} is already active" if active else
                   "the joints are not enabled" if not enabled else f"sensitivity {level}")
            return f"collision of {torque:g} N m on joint {joint} not detected ({why})"

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
            server.set_reply_delay(delay)
            return f"reply delay {delay * 1e3:g} ms" if delay else "reply delay off"

        return set_delay
    if cmd == "drop-clients":
        return lambda: f"dropped {server.drop_clients()} client connections"
    if cmd == "clear":

        def clear() -> str:
            emu.clear_faults()
            server.clear_delays()
            return "faults, reply delay and report pause cleared"

        return clear
    if cmd == "set-input":
        return _set_input(server, request)
    if cmd == "step":
        if not server.stepped:
            raise AdminError("step needs lockstep time: start the emulator with --stepped")
        secs = _seconds(request.get("seconds"))

        def advance() -> str:
            n = server.advance(secs)
            return f"advanced {n} control periods to t = {emu.time:.3f} s"

        return advance
    if cmd == "status":

        def status() -> str:
            ctl = emu.controller
            out = {"time": ctl.time, "error": ctl.error_code, "warning": ctl.warning_code,
                   "servo_errors": list(ctl.servo_errors), "reply_delay": server.reply_delay,
                   "reports_paused": server.reports_paused(), "gripper": emu.gripper_status()}
            if emu.has_ft_sensor:
                out["ft_sensor"] = _ft_status(emu)
            health = getattr(server, "health", None)  # disk and trace state, where the server has it
            if callable(health):
                out.update(health())
            return json.dumps(out)

        return status
    if cmd in ("checkpoint-save", "checkpoint-restore", "checkpoint-list"):
        return _checkpoint(server, cmd, request)
    if cmd in ("ft-error", "ft-noise", "payload", "scene"):
        return _ft(server, cmd, request)
    if cmd in scene_admin.COMMANDS:
        try:
            return scene_admin.prepare(emu, cmd, request)
        except ValueError as exc:
            raise AdminError(str(exc)) from None
    raise AdminError(f"unknown command {cmd!r}; known: {', '.join(COMMANDS)}")


def _name(value: Any) -> str:
    try:
        return checkpoint_name(value)
    except ValueError as exc:
        raise AdminError(str(exc)) from None


def _checkpoint(server: AdminTarget, cmd: str, request: dict[str, Any]) -> Callable[[], str]:
    """``checkpoint-save``/``-restore``/``-list``: the emulator's whole state kept under a name."""
    kept = server.checkpoints
    if cmd == "checkpoint-list":
        return lambda: json.dumps(sorted(kept))
    name = _name(request.get("name"))
    emu = server.emulator
    if not (callable(getattr(emu, "checkpoint", None)) and callable(getattr(emu, "restore", None))):
        raise AdminError("this emulator keeps no checkpoints")
    keeper = cast(Checkpointing, emu)  # Emulator.checkpoint() and Emulator.restore()
    if cmd == "checkpoint-save":

        def save() -> str:
            kept[name] = keeper.checkpoint()
            return f"checkpoint {name!r} saved at t = {emu.time:.3f} s"

        return save
    if name not in kept:
        known = ", ".join(repr(k) for k in sorted(kept)) or "none"
        raise AdminError(f"no checkpoint {name!r}; saved: {known}")
    saved = kept[name]

    def restore() -> str:
        keeper.restore(saved)
        return f"checkpoint {name!r} restored: t = {emu.time:.3f} s"

    return restore


def _ft_status(emu: Emulator) -> dict[str, Any]:
    """The F/T sensor in ``status``: switched on, its error, the compensated and raw readings."""
    from ..controller.devices import ft_sensor as ft

    ctl = emu.controller
    return {"enabled": ft.enabled(ctl), "error": ft.state_of(ctl).error,
            "reading": [round(float(x), 4) for x in ft.reading(ctl)],
            "raw": [round(float(x), 4) for x in ft.raw_reading(ctl)],
            "external": [round(float(x), 4) for x in ft.external_wrench(ctl)]}


def _vector(value: Any, n: int, name: str) -> list[float]:
    if not isinstance(value, (list, tuple)) or len(value) != n:
        raise AdminError(f"{name} must be a list of {n} numbers, got {value!r}")
    return [_float(x, name) for x in value]


def _ft(server: AdminTarget, cmd: str, request: dict[str, Any]) -> Callable[[], str]:
    """``ft-error``, ``ft-noise``, ``payload`` and ``scene``: the F/T sensor and what it touches."""
    emu = server.emulator
    if cmd == "ft-error":
        if not emu.has_ft_sensor:
            raise AdminError("no F/T sensor is attached: start the emulator with --ft-sensor")
        code = _int(request.get("code"), "code")
        if not 0 <= code <= 255 or code == 27:
            raise AdminError(f"F/T sensor error code {code} out of range 0..255 (27 means no error)")

        def ft_error() -> str:
            emu.inject_ft_error(code)
            return f"F/T sensor error {code}" if code else "F/T sensor error cleared"

        return ft_error
    if cmd == "ft-noise":
        on = request.get("on")
        if not isinstance(on, bool):
            raise AdminError(f"on must be true or false, got {on!r}")

        def noise() -> str:
            emu.set_ft_noise(on)
            return f"F/T noise and drift {'on' if on else 'off'}"

        return noise
    if cmd == "payload":
        mass = _float(request.get("mass"), "mass")
        com = _vector(request.get("com", [0.0, 0.0, 0.0]), 3, "com")
        if mass < 0:
            raise AdminError(f"mass must be >= 0 kg, got {mass:g}")

        def payload() -> str:
            emu.set_payload(mass, com)
            return f"payload {mass:g} kg at ({com[0]:g}, {com[1]:g}, {com[2]:g}) mm"

        return payload
    try:
        scene = contact.parse_scene(request.get("scene", {}))
    except ValueError as exc:
        raise AdminError(f"scene: {exc}") from None

    def set_scene() -> str:
        emu.set_scene(scene)
        return f"contact scene of {len(scene.shapes)} shapes"

    return set_scene


def _set_wrench(server: AdminTarget, request: dict[str, Any]) -> Callable[[], str]:
    """``set-input`` kind ``ft``: the external wrench played on the TCP (replacing the last one)."""
    wrench = _vector(request.get("wrench", request.get("value")), 6, "wrench")
    frame = request.get("frame", "tool")
    if frame not in WRENCH_FRAMES:
        raise AdminError(f"frame must be one of {', '.join(WRENCH_FRAMES)}, got {frame!r}")
    ramp = _seconds(request.get("ramp", 0.0))
    hold = request.get("for")
    duration = None if hold is None else _seconds(hold)
    if duration == 0:
        raise AdminError("for must be a time > 0 s (leave it out to hold the wrench)")
    emu = server.emulator

    def play() -> str:
        emu.clear_wrench()
        emu.apply_wrench(wrench, frame, ramp, duration)
        text = " ".join(f"{x:g}" for x in wrench)
        how = (f", ramp {ramp:g} s" if ramp else "") + (f", for {duration:g} s" if duration else "")
        return f"external wrench ({text}) in the {frame} frame{how}"

    return play


def _set_input(server: AdminTarget, request: dict[str, Any]) -> Callable[[], str]:
    kind = request.get("kind")
    if kind not in INPUT_KINDS:
        raise AdminError(f"unknown input kind {kind!r}; known: {', '.join(INPUT_KINDS)}")
    if kind == "ft":
        return _set_wrench(server, request)
    index = _int(request.get("index"), "index")
    value = _float(request.get("value"), "value")
    if kind in ("cgpio", "tgpio", "vacuum-object") and value not in (0, 1):
        raise AdminError(f"digital input value must be 0 or 1, got {value!r}")
    if kind == "gripper-object" and value < 0:
        raise AdminError(f"object width is mm >= 0 (0 takes the object away), got {value!r}")
    try:
        server.emulator.check_input(kind, index, value)
    except (ValueError, CommandWarning) as exc:  # the IO module's own range checks
        raise AdminError(f"{kind} input {index}: {exc}") from None

    def play() -> str:
        server.emulator.set_input(kind, index, value)
        if kind == "gripper-object":
            return (f"gripper object {'removed' if value == 0 else f'{value:g} mm wide'}"
                    f"{' around the fingers' if index == 1 else ''}")
        return f"{kind} input {index} = {value:g}"

    return play
