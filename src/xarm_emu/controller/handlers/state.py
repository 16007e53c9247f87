"""Registers of the common port section and the system state (manual section 2.1.3, registers 1-19
and 106): version, serial numbers, enable, state, mode, errors and warnings."""

from __future__ import annotations

from typing import Any

from ...protocol import codes
from ..applications.modes import extra_modes
from ..core.controller_protocol import Controller
from ..core.interface import Binding, ParameterError, Values
from ..core.state_machine import (
    MODE_JOINT_TEACH,
    MODE_POSITION,
    MODE_SERVO,
    STATE_MOVING,
    STATE_SLEEP,
    STATE_STOP,
    STATE_SUSPEND,
    Event,
    ModeEvent,
    fire,
    fire_mode,
)


def needs_power_on(code: int) -> bool:
    """Whether clearing error ``code`` leaves the joints disabled until enabled again: the errors the
    manual answers with "power on again" or "enable the robot" (section 3.2.1), and unlisted codes."""
    if code == 0:
        return False
    entry = codes.controller_error(code)
    return entry.restart if entry is not None else True


def version(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 1: the version string."""
    return {"version": ctl.version_string()}


def robot_sn(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 2: robot and control box serial numbers, NUL separated, 40 bytes."""
    return {"serials": f"{ctl.robot_sn}\0{ctl.box_sn}\0".encode("ascii").ljust(40, b"\0")[:40]}


def shutdown(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 10, remote shutdown of the control box OS: acknowledged, the emulator keeps
    running (documented in docs/emulated.md)."""
    return {"cmdnum": ctl.executor.cmdnum}


def joint_ids(ctl: Controller, joint: int) -> list[int]:
    """Registers 11 and 18: joint 1..dof, or 8 for all joints."""
    if joint == 8:
        return list(range(ctl.dof))
    if 1 <= joint <= ctl.dof:
        return [joint - 1]
    raise ParameterError(f"joint {joint} out of range")


def motion_enable(ctl: Controller, v: Values) -> None:
    """Register 11: enable (brakes released) or disable joints; a system reset."""
    ids = joint_ids(ctl, v["joint"])
    if v["enable"] not in (0, 1):
        raise ParameterError("enable must be 0 or 1")
    for i in ids:
        ctl.enabled[i] = bool(v["enable"])
        if v["enable"]:
            ctl.brakes[i] = True
    ctl.system_reset()
    return None


def brake(ctl: Controller, v: Values) -> None:
    """Register 18: brake switches of one or all joints; a system reset."""
    for i in joint_ids(ctl, v["joint"]):
        ctl.brakes[i] = not bool(v["enable"])
    ctl.system_reset()
    return None


def set_state(ctl: Controller, v: Values) -> None:
    """Register 12: 0 run (resume a suspend, leave stop), 3 suspend, 4 stop (section 2.1.3)."""
    s = v["state"]
    ex = ctl.executor
    if s == 0:
        if ctl.error_code:
            return None  # stays in stop; the reply carries 0x40
        if ctl.state == STATE_SUSPEND:
            ex.resume(ctl.limits())
            if fire(ctl, Event.SET_RUN) == STATE_MOVING and not ex.active:
                fire(ctl, Event.IDLE)
        elif not ex.stopping:  # a stop ramp still running keeps state 4
            fire(ctl, Event.SET_RUN)
        return None
    if s == STATE_SUSPEND:
        if ctl.state in (STATE_MOVING, STATE_SLEEP):
            ex.suspend(ctl.limits())
            fire(ctl, Event.SET_SUSPEND)
        return None
    if s == STATE_STOP:
        if ctl.mode == MODE_POSITION and ex.running:
            ex.stop_smoothly(ctl.limits())
        else:
            ex.discard()
        ctl.servo_target = None
        fire(ctl, Event.SET_STOP)
        ctl.enter_stop()
        return None
    raise ParameterError(f"state {s} cannot be set")


def clean_error(ctl: Controller, v: Values) -> None:
    """Register 16: clear the error (joints stay disabled after errors that need a power-on)."""
    if needs_power_on(ctl.error_code):
        ctl.enabled = [False] * ctl.dof
    ctl.error_code = 0
    ctl.servo_errors = [0] * ctl.dof
    ctl.system_reset()
    return None


def clean_warning(ctl: Controller, v: Values) -> None:
    """Register 17: clear the warning."""
    ctl.warning_code = 0
    return None


def set_mode(ctl: Controller, v: Values) -> None:
    """Register 19: motion mode 0, 1 or 2 (3, Cartesian teaching, is not available), and the modes
    4-7 of the firmware (:func:`~xarm_emu.controller.applications.modes.extra_modes`); a system reset.
    The detection parameter byte SDKs append for newer firmware (register 19's row of the register
    table) is accepted and has no effect."""
    mode = v["mode"]
    if mode not in (MODE_POSITION, MODE_SERVO, MODE_JOINT_TEACH) + extra_modes(ctl):
        raise ParameterError(f"mode {mode} not available")
    fire_mode(ctl, ModeEvent.SELECT, mode)
    ctl.system_reset()
    return None


def servo_debug(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 106: (state, error code) of joints 1-7, then of the end tool (gripper)."""
    servos = [0] * 16
    errors = ctl.servo_errors
    for i in range(ctl.dof):
        servos[2 * i] = 1 if errors[i] else 0
        servos[2 * i + 1] = errors[i] & 0xFF
    tool = ctl.hooks.tool_error()
    servos[14], servos[15] = (1 if tool else 0), tool & 0xFF
    return {"servos": tuple(servos)}


def get_state(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 13: the motion state."""
    return {"state": ctl.state}


def get_cmdnum(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 14: the number of commands in the buffer."""
    return {"cmdnum": ctl.executor.cmdnum}


def get_err_warn(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 15: the error and warning codes."""
    return {"error": ctl.error_code, "warning": ctl.warning_code}


#: The registers of this module, bound (:class:`~xarm_emu.controller.core.interface.Binding`).
BINDINGS: tuple[Binding, ...] = (
    Binding(1, version),
    Binding(2, robot_sn),
    Binding(10, shutdown),
    Binding(11, motion_enable),
    Binding(12, set_state),
    Binding(13, get_state),
    Binding(14, get_cmdnum),
    Binding(15, get_err_warn),
    Binding(16, clean_error),
    Binding(17, clean_warning),
    Binding(18, brake),
    Binding(19, set_mode),
    Binding(106, servo_debug),
)
