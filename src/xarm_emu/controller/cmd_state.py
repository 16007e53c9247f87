"""Registers of the common port section and the system state (manual 2.1.3, registers 1-19 and 106):
version, serial numbers, enable, state, mode, errors and warnings."""

from __future__ import annotations

from typing import Any

from ..protocol import codes
from .base import (
    Handler,
    ParameterError,
    Values,
)
from .core import (
    MODE_JOINT_TEACH,
    MODE_POSITION,
    MODE_SERVO,
    ControllerCore,
)
from .mode_steps import extra_modes
from .states import STATE_MOVING, STATE_SLEEP, STATE_STOP, STATE_SUSPEND, Event, fire


def needs_power_on(code: int) -> bool:
    """Whether clearing error ``code`` leaves the joints disabled until enabled again: the errors the
    manual answers with "power on again" or "enable the robot" (section 3.2.1), and unlisted codes."""
    if code == 0:
        return False
    entry = codes.controller_error(code)
    return entry.restart if entry is not None else True


class StateCommands(ControllerCore):
    """Registers 1, 2, 10-19 and 106."""

    def register_handlers(self) -> dict[int, Handler]:
        h = super().register_handlers()
        h.update({
            1: self._h_version,
            2: self._h_robot_sn,
            10: self._h_shutdown,
            11: self._h_motion_enable,
            12: self._h_set_state,
            13: lambda v: {"state": self.motion_state},
            14: lambda v: {"cmdnum": self.executor.cmdnum},
            15: lambda v: {"error": self.error_code, "warning": self.warning_code},
            16: self._h_clean_error,
            17: self._h_clean_warning,
            18: self._h_brake,
            19: self._h_set_mode,
            106: self._h_servo_debug,
        })
        return h

    def _h_version(self, v: Values) -> dict[str, Any]:
        return {"version": self.version_string()}

    def _h_robot_sn(self, v: Values) -> dict[str, Any]:
        return {"serials": f"{self.robot_sn}\0{self.box_sn}\0".encode("ascii").ljust(40, b"\0")[:40]}


    def _h_shutdown(self, v: Values) -> dict[str, Any]:
        """Register 10, remote shutdown of the control box OS: acknowledged, the emulator keeps
        running (documented in the README)."""
        return {"cmdnum": self.executor.cmdnum}

    # state machine
    def _joint_ids(self, joint: int) -> list[int]:
        if joint == 8:
            return list(range(self.dof))
        if 1 <= joint <= self.dof:
            return [joint - 1]
        raise ParameterError(f"joint {joint} out of range")

    def _h_motion_enable(self, v: Values) -> None:
        ids = self._joint_ids(v["joint"])
        if v["enable"] not in (0, 1):
            raise ParameterError("enable must be 0 or 1")
        for i in ids:
            self.enabled[i] = bool(v["enable"])
            if v["enable"]:
                self.brakes[i] = True
        self.system_reset()
        return None

    def _h_brake(self, v: Values) -> None:
        ids = self._joint_ids(v["joint"])
        for i in ids:
            self.brakes[i] = not bool(v["enable"])
        self.system_reset()
        return None

    def _h_set_state(self, v: Values) -> None:
        """Register 12: 0 run (resume a suspend, leave stop), 3 suspend, 4 stop (section 2.1.3)."""
        s = v["state"]
        ex = self.executor
        if s == 0:
            if self.error_code:
                return None  # stays in stop; the reply carries 0x40
            if self.motion_state == STATE_SUSPEND:
                ex.resume(self._limits())
                if fire(self, Event.SET_RUN) == STATE_MOVING and not ex.active:
                    fire(self, Event.IDLE)
            elif not ex.stopping:  # a stop ramp still running keeps state 4
                fire(self, Event.SET_RUN)
            return None
        if s == STATE_SUSPEND:
            if self.motion_state in (STATE_MOVING, STATE_SLEEP):
                ex.suspend(self._limits())
                fire(self, Event.SET_SUSPEND)
            return None
        if s == STATE_STOP:
            if self.mode == MODE_POSITION and ex.running:
                ex.stop_smoothly(self._limits())
            else:
                ex.discard()
            self.servo_target = None
            fire(self, Event.SET_STOP)
            self._enter_stop()
            return None
        raise ParameterError(f"state {s} cannot be set")

    def _h_clean_error(self, v: Values) -> None:
        if needs_power_on(self.error_code):
            self.enabled = [False] * self.dof
        self.error_code = 0
        self.servo_errors = [0] * self.dof
        self.system_reset()
        return None

    def _h_clean_warning(self, v: Values) -> None:
        self.warning_code = 0
        return None

    def _h_set_mode(self, v: Values) -> None:
        mode = v["mode"]
        if mode not in (MODE_POSITION, MODE_SERVO, MODE_JOINT_TEACH) + extra_modes(self):
            raise ParameterError(f"mode {mode} not available")
        self.mode = mode
        self.system_reset()
        return None


    def _h_servo_debug(self, v: Values) -> dict[str, Any]:
        """Register 106: (state, error code) of joints 1-7, then of the end tool (gripper)."""
        servos = [0] * 16
        for i in range(self.dof):
            servos[2 * i] = 1 if self.servo_errors[i] else 0
            servos[2 * i + 1] = self.servo_errors[i] & 0xFF
        tool = self.hooks.tool_error()
        servos[14], servos[15] = (1 if tool else 0), tool & 0xFF
        return {"servos": tuple(servos)}

