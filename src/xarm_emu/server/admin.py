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
                                                                 a Robotiq, 11/12 for the BIO G2
                                                                 and G1, an error byte for the
                                                                 Inspire hand
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
scene              scene {"plane": [...], "box": [...], ...}     the whole scene (replaced; objects
                                                                 and cell elements too, the engine
                                                                 rebuilt)
scene-add          tables {"object": [...], "feeder": [...]}     elements added to the running scene
scene-remove       name                                          an element taken out of it
status             -                                             time, error, warning, delays,
                                                                 why saves or the trace fail
step               seconds (controller time)                     lockstep (--stepped) only: run them
checkpoint-save    name                                          keep the emulator's whole state
checkpoint-restore name                                          back to a kept state
checkpoint-list    -                                             the kept names
=================  ===========================================  ===============================

Checkpoints are an emulator feature (no real control box has them): they live in the server's
memory only, named, until the process ends. A refused request changes nothing; one carried out
that changes something (:data:`TRACED`) is written to the command trace (``serve --trace``).

This module is request checking and preparation only: it works on any :class:`AdminTarget` (the
running server satisfies it structurally), and the socket side is :mod:`.admin_port`. Each command
is one row of :data:`TABLE`: its declared arguments (:mod:`.admin_args`, checked in that order
before anything changes) and a small function that turns them into the action.
"""

from __future__ import annotations

import functools
import json
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol, cast

from ..controller.core.interface import CommandWarning
from ..controller.devices import ft_sensor as ft
from ..controller.devices.linear_track import TRACK_ERRORS
from ..controller.emulator import Emulator
from ..protocol import codes
from ..protocol.admin import COMMANDS, INPUT_KINDS, WRENCH_FRAMES
from . import admin_args as t
from .admin_args import AdminError, Arg, parse_duration

__all__ = ["SCHEDULABLE", "TABLE", "TRACED", "AdminError", "AdminTarget", "Command", "arguments", "execute",
           "parse_duration", "prepare"]


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


#: What a checked request does when run: its message back. It does not refuse.
Action = Callable[[], str]
#: The checked arguments of a request, by name.
Args = dict[str, Any]


@dataclass(frozen=True)
class Command:
    """One admin command: what it needs of the server, its arguments, and its function."""

    #: Carries the command out with its checked arguments; returns the message back, never refuses.
    run: Callable[[AdminTarget, Args], str]
    args: tuple[Arg, ...] = ()
    #: Checked first: refuses (AdminError) when the server cannot carry the command out at all.
    needs: Callable[[AdminTarget], None] | None = None
    #: Checked after the arguments: what depends on several of them or on the server's state
    #: (AdminError); it may add to the arguments what it found (a checkpoint's saved state).
    check: Callable[[AdminTarget, Args], None] | None = None
    #: A command whose arguments depend on one of them (set-input's kind): that argument's name
    #: and the command for each of its values, ``None`` for every other value.
    forms: tuple[str, dict[str | None, Command]] | None = None

    def prepare(self, server: AdminTarget, request: dict[str, Any]) -> Action:
        """Check ``request`` against this command (AdminError) and return its action."""
        if self.needs is not None:
            self.needs(server)
        values = t.checked(self.args, request, server.emulator)
        if self.forms is not None:
            key, forms = self.forms
            return forms.get(values[key], forms[None]).prepare(server, request)
        if self.check is not None:
            self.check(server, values)
        return functools.partial(self.run, server, values)

    def names(self) -> tuple[str, ...]:
        """Every argument it may take, its forms' too, in declared order."""
        out = [a.name for a in self.args]
        for form in (self.forms[1].values() if self.forms else ()):
            out += [n for n in form.names() if n not in out]
        return tuple(out)


def execute(server: AdminTarget, request: dict[str, Any]) -> str:
    """Run one admin request in the server's loop thread; returns a message or raises AdminError.

    Every argument is checked before anything changes, so a refused request changes nothing.
    """
    return prepare(server, request)()


def prepare(server: AdminTarget, request: dict[str, Any], source: str = "admin") -> Action:
    """Check one admin request now and return the action that carries it out (a message back).

    Raises AdminError for a bad request; the action it returns does not refuse. A command of
    :data:`TRACED` writes itself to the server's command trace when it is carried out (``source``:
    who asked, "admin" or "schedule"; server/trace.py), so ``xarm-emu replay`` can do the same.
    """
    cmd = request.get("cmd")
    command = TABLE.get(cmd) if isinstance(cmd, str) else None
    if command is None:
        raise AdminError(f"unknown command {cmd!r}; known: {', '.join(COMMANDS)}")
    action = command.prepare(server, request)
    if cmd not in TRACED:
        return action
    given = {k: v for k, v in request.items() if k != "token"}
    return functools.partial(_traced, server, source, given, action)


def _traced(server: AdminTarget, source: str, request: dict[str, Any], action: Action) -> str:
    """Run ``action`` and write it to the server's trace, if it keeps one, at the period it acted
    after. A partial of this module-level function, so a checkpoint can write a scheduled one."""
    message = action()
    trace = getattr(server, "trace", None)
    if trace is not None:
        ctl = server.emulator.controller
        trace.outside(ctl.time, ctl.data.steps, source, request, message)
    return message


# -- faults ----------------------------------------------------------------------------------------

def _estop(server: AdminTarget, a: Args) -> str:
    server.emulator.inject_estop()
    return "emergency stop: C1"


def _error(server: AdminTarget, a: Args) -> str:
    entry: codes.Code = a["code"]
    server.emulator.inject_error(entry.code)
    return f"injected {entry.label} {entry.name}"


def _warning(server: AdminTarget, a: Args) -> str:
    entry: codes.Code = a["code"]
    server.emulator.inject_warning(entry.code)
    return f"injected warning {entry.code} {entry.name}"


def _gripper_error(server: AdminTarget, a: Args) -> str:
    entry: codes.Code = a["code"]
    server.emulator.inject_gripper_error(entry.code)
    return f"injected gripper {entry.label} {entry.name}"


def _track_error(server: AdminTarget, a: Args) -> str:
    server.emulator.inject_track_error(a["code"])
    return f"injected linear track error {a['code']} {TRACK_ERRORS[a['code']]}"


def _servo_error(server: AdminTarget, a: Args) -> str:
    joint, servo = a["joint"], a["code"]
    server.emulator.inject_servo_error(joint, servo.code)
    return f"injected {servo.label} {servo.name} on joint {joint} (C{10 + joint})"


def _end_module_lost(server: AdminTarget, a: Args) -> str:
    server.emulator.inject_end_module_lost()
    return "end module lost: C28"


def _collision(server: AdminTarget, a: Args) -> str:
    joint, torque, emu = a["joint"], a["torque"], server.emulator
    ctl = emu.controller
    level = ctl.settings.collision_sensitivity
    active, enabled = ctl.error_code, all(ctl.enabled)  # detection needs no error, enabled joints
    if emu.inject_collision(joint, torque):
        return f"collision of {torque:g} N m on joint {joint} detected at sensitivity {level}: C31"
    why = (f"error {codes.describe_error(active)} is already active" if active else
           "the joints are not enabled" if not enabled else f"sensitivity {level}")
    return f"collision of {torque:g} N m on joint {joint} not detected ({why})"


# -- the server's knobs ----------------------------------------------------------------------------

def _report_pause(server: AdminTarget, a: Args) -> str:
    server.pause_reports(a["seconds"])
    return f"reports paused for {a['seconds']:g} s"


def _reply_delay(server: AdminTarget, a: Args) -> str:
    delay = a["seconds"]
    server.set_reply_delay(delay)
    return f"reply delay {delay * 1e3:g} ms" if delay else "reply delay off"


def _drop_clients(server: AdminTarget, a: Args) -> str:
    return f"dropped {server.drop_clients()} client connections"


def _clear(server: AdminTarget, a: Args) -> str:
    server.emulator.clear_faults()
    server.clear_delays()
    return "faults, reply delay and report pause cleared"


def _stepped(server: AdminTarget) -> None:
    if not server.stepped:
        raise AdminError("step needs lockstep time: start the emulator with --stepped")


def _step(server: AdminTarget, a: Args) -> str:
    n = server.advance(a["seconds"])
    return f"advanced {n} control periods to t = {server.emulator.time:.3f} s"


def _status(server: AdminTarget, a: Args) -> str:
    emu = server.emulator
    ctl = emu.controller
    out = {"time": ctl.time, "error": ctl.error_code, "warning": ctl.warning_code,
           "servo_errors": list(ctl.servo_errors), "reply_delay": server.reply_delay,
           "reports_paused": server.reports_paused(), "gripper": emu.gripper_status()}
    if emu.has_ft_sensor:
        out["ft_sensor"] = ft.status(ctl)
    health = getattr(server, "health", None)  # disk and trace state, where the server has it
    if callable(health):
        out.update(health())
    return json.dumps(out)


# -- inputs ----------------------------------------------------------------------------------------

def _set_wrench(server: AdminTarget, a: Args) -> str:
    """``set-input`` kind ``ft``: the external wrench played on the TCP (replacing the last one)."""
    wrench, frame, ramp, duration = a["wrench"], a["frame"], a["ramp"], a["for"]
    server.emulator.clear_wrench()
    server.emulator.apply_wrench(wrench, frame, ramp, duration)
    text = " ".join(f"{x:g}" for x in wrench)
    how = (f", ramp {ramp:g} s" if ramp else "") + (f", for {duration:g} s" if duration else "")
    return f"external wrench ({text}) in the {frame} frame{how}"


def _input_in_range(server: AdminTarget, a: Args) -> None:
    """A digital input is 0 or 1, an object's width >= 0, and the IO module takes the index."""
    kind, index, value = a["kind"], a["index"], a["value"]
    if kind in ("cgpio", "tgpio", "vacuum-object") and value not in (0, 1):
        raise AdminError(f"digital input value must be 0 or 1, got {value!r}")
    if kind == "gripper-object" and value < 0:
        raise AdminError(f"object width is mm >= 0 (0 takes the object away), got {value!r}")
    try:
        server.emulator.check_input(kind, index, value)
    except (ValueError, CommandWarning) as exc:  # the IO module's own range checks
        raise AdminError(f"{kind} input {index}: {exc}") from None


def _set_input(server: AdminTarget, a: Args) -> str:
    """``set-input`` of a digital or analog input, or an object at the vacuum gripper or the fingers."""
    kind, index, value = a["kind"], a["index"], a["value"]
    server.emulator.set_input(kind, index, value)
    if kind == "gripper-object":
        return (f"gripper object {'removed' if value == 0 else f'{value:g} mm wide'}"
                f"{' around the fingers' if index == 1 else ''}")
    return f"{kind} input {index} = {value:g}"


# -- the F/T sensor and what it touches ------------------------------------------------------------

def _ft_error(server: AdminTarget, a: Args) -> str:
    server.emulator.inject_ft_error(a["code"])
    return f"F/T sensor error {a['code']}" if a["code"] else "F/T sensor error cleared"


def _ft_noise(server: AdminTarget, a: Args) -> str:
    server.emulator.set_ft_noise(a["on"])
    return f"F/T noise and drift {'on' if a['on'] else 'off'}"


def _mass_in_range(server: AdminTarget, a: Args) -> None:
    if a["mass"] < 0:
        raise AdminError(f"mass must be >= 0 kg, got {a['mass']:g}")


def _payload(server: AdminTarget, a: Args) -> str:
    mass, com = a["mass"], a["com"]
    server.emulator.set_payload(mass, com)
    return f"payload {mass:g} kg at ({com[0]:g}, {com[1]:g}, {com[2]:g}) mm"


def _scene(server: AdminTarget, a: Args) -> str:
    try:
        server.emulator.set_scene(a["scene"])
    except ValueError as exc:
        raise AdminError(f"scene: {exc}") from None
    return f"contact scene of {len(a['scene'].shapes)} shapes"


# -- the objects of the physics world (no real control box has these) -----------------------------

def _physics(server: AdminTarget) -> None:
    if server.emulator.physics is None:
        raise AdminError("the scene has no objects (serve --scene with [[object]] tables)")


def _scene_objects(server: AdminTarget, a: Args) -> str:
    """The objects, and the cell's conveyors, sensors and feeders with their state, if any."""
    emu = server.emulator
    out: dict[str, Any] = {"time": emu.time, "objects": emu.scene_objects()}
    cell = None if emu.physics is None else emu.physics.cell
    if cell is not None:
        out.update(cell.status())
    return json.dumps(out)


def _scene_edit(server: AdminTarget, a: Args) -> str:
    """The scene with elements added or removed: the physics world rebuilt, what stays going on."""
    scene = a["tables"] if "tables" in a else a["name"]
    try:
        server.emulator.set_scene(scene)
    except ValueError as exc:
        raise AdminError(f"scene: {exc}") from None
    return (f"scene of {len(scene.shapes)} shapes, {len(scene.objects)} objects, "
            f"{len(scene.cell.conveyors)} conveyors, {len(scene.cell.sensors)} sensors, "
            f"{len(scene.cell.feeders)} feeders")


def _scene_reset(server: AdminTarget, a: Args) -> str:
    server.emulator.reset_objects()
    return "every object back where the scene puts it"


def _scene_place(server: AdminTarget, a: Args) -> str:
    name, position, rpy = a["name"], a["position"], a["rpy"]
    server.emulator.place_object(name, position, rpy)
    return f"{name} at ({position[0]:g}, {position[1]:g}, {position[2]:g}) mm"


# -- checkpoints (an emulator feature: they live in the server's memory until the process ends) --

def _keeper(server: AdminTarget, a: Args) -> None:
    """The emulator keeps checkpoints (Emulator.checkpoint() and Emulator.restore())."""
    emu = server.emulator
    if not (callable(getattr(emu, "checkpoint", None)) and callable(getattr(emu, "restore", None))):
        raise AdminError("this emulator keeps no checkpoints")


def _saved(server: AdminTarget, a: Args) -> None:
    """The emulator keeps checkpoints and one is saved under the name: taken now."""
    _keeper(server, a)
    if a["name"] not in server.checkpoints:
        known = ", ".join(repr(k) for k in sorted(server.checkpoints)) or "none"
        raise AdminError(f"no checkpoint {a['name']!r}; saved: {known}")
    a["saved"] = server.checkpoints[a["name"]]


def _checkpoint_list(server: AdminTarget, a: Args) -> str:
    return json.dumps(sorted(server.checkpoints))


def _checkpoint_save(server: AdminTarget, a: Args) -> str:
    try:
        saved = cast(Checkpointing, server.emulator).checkpoint()
    except ValueError as exc:  # a value with no written form (a lambda scheduled in process)
        raise AdminError(f"the state cannot be saved: {exc}") from None
    server.checkpoints[a["name"]] = saved
    return f"checkpoint {a['name']!r} saved at t = {server.emulator.time:.3f} s"


def _checkpoint_restore(server: AdminTarget, a: Args) -> str:
    cast(Checkpointing, server.emulator).restore(a["saved"])
    return f"checkpoint {a['name']!r} restored: t = {server.emulator.time:.3f} s"


# -- the table -------------------------------------------------------------------------------------

_JOINT = Arg("joint", t.joint)
_SECONDS = Arg("seconds", t.seconds)
_KIND = Arg("kind", t.choice(INPUT_KINDS, "unknown input kind {value}; known: {known}"))
_CHECKPOINT = Arg("name", t.checkpoint)

#: Every admin command (protocol.admin.COMMANDS): its function, its arguments and what it needs.
TABLE: dict[str, Command] = {
    "estop": Command(_estop),
    "error": Command(_error, (Arg("code", t.label("C")),)),
    "warning": Command(_warning, (Arg("code", t.label("W")),)),
    "servo-error": Command(_servo_error, (_JOINT, Arg("code", t.label("S")))),
    "gripper-error": Command(_gripper_error, (Arg("code", t.gripper_code),)),
    "track-error": Command(_track_error, (Arg("code", t.track_code),)),
    "end-module-lost": Command(_end_module_lost),
    "collision": Command(_collision, (_JOINT, Arg("torque", t.number("torque")))),
    "report-pause": Command(_report_pause, (_SECONDS,)),
    "reply-delay": Command(_reply_delay, (_SECONDS,)),
    "drop-clients": Command(_drop_clients),
    "clear": Command(_clear),
    "set-input": Command(_set_input, (_KIND,), forms=("kind", {
        "ft": Command(_set_wrench, (
            Arg("wrench", t.vector(6, "wrench"), alias="value"),
            Arg("frame", t.choice(WRENCH_FRAMES, "frame must be one of {known}, got {value}"), "tool"),
            Arg("ramp", t.seconds, 0.0), Arg("for", t.hold))),
        None: Command(_set_input, (_KIND, Arg("index", t.integer("index")), Arg("value", t.number("value"))),
                      check=_input_in_range),
    })),
    "status": Command(_status),
    "step": Command(_step, (_SECONDS,), needs=_stepped),
    "ft-error": Command(_ft_error, (Arg("code", t.ft_code),)),
    "ft-noise": Command(_ft_noise, (Arg("on", t.flag("on")),)),
    "payload": Command(_payload, (Arg("mass", t.number("mass")),
                                  Arg("com", t.vector(3, "com"), [0.0, 0.0, 0.0])), check=_mass_in_range),
    "scene": Command(_scene, (Arg("scene", t.scene, {}),)),
    "checkpoint-save": Command(_checkpoint_save, (_CHECKPOINT,), check=_keeper),
    "checkpoint-restore": Command(_checkpoint_restore, (_CHECKPOINT,), check=_saved),
    "checkpoint-list": Command(_checkpoint_list),
    "scene-objects": Command(_scene_objects, needs=_physics),
    "scene-place": Command(_scene_place, (
        Arg("name", t.scene_object), Arg("position", t.place("position")),
        Arg("rpy", t.place("rpy"), [0.0, 0.0, 0.0])), needs=_physics),
    "scene-reset": Command(_scene_reset, needs=_physics),
    "scene-add": Command(_scene_edit, (Arg("tables", t.scene_added),)),
    "scene-remove": Command(_scene_edit, (Arg("name", t.scene_without),)),
}
if tuple(TABLE) != COMMANDS:
    raise RuntimeError("the admin table and protocol.admin.COMMANDS list different commands")

#: Admin commands a fault schedule may hold (server/faults.py): the faults and inputs, not the
#: queries, the lockstep clock or the checkpoints.
SCHEDULABLE = frozenset(COMMANDS) - {"status", "step", "checkpoint-save", "checkpoint-restore",
                                     "checkpoint-list", "scene-objects"}
#: Admin commands the command trace records as they are carried out (server/trace.py, replayed by
#: ``xarm-emu replay``): the faults, inputs and changes a schedule may hold and the checkpoints; not
#: the queries or the lockstep clock (the trace's times show it).
TRACED = SCHEDULABLE | {"checkpoint-save", "checkpoint-restore"}


def arguments(cmd: str) -> tuple[str, ...]:
    """The names of the arguments ``cmd`` takes (a fault schedule refuses any other key)."""
    return TABLE[cmd].names()
