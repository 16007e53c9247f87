"""Modes of register 19 beyond the manual's (velocity control 4/5, online planning 6/7): which
firmware answers them and what the core runs for them each control period. The registers they take
over while active are the mode routes of the binding table
(:class:`~xarm_emu.controller.core.interface.Binding`)."""

from __future__ import annotations

from collections.abc import Callable, Container
from typing import Any

from ...protocol.firmware import FirmwareProfile
from ..core.controller_protocol import Controller
from . import online, reduced, trajectory, velocity

#: What the core runs each control period while the controller is in one of these modes.
MODE_STEPS: dict[int, Callable[[Any, float], None]] = {
    velocity.MODE_JOINT_VELOCITY: velocity.step,
    velocity.MODE_CARTESIAN_VELOCITY: velocity.step,
    online.MODE_JOINT_ONLINE: online.step,
    online.MODE_CARTESIAN_ONLINE: online.step,
    trajectory.MODE_PLAYBACK: trajectory.playback_step,
}

#: What the core runs every control period, whatever the mode (after the motion of the period).
EVERY_STEP: tuple[Callable[[Any, float], None], ...] = (trajectory.record_step,)

#: For a hook of :data:`EVERY_STEP`: whether running it now would change nothing (the jump over
#: idle periods, controller/emulator.py); a hook without an entry is never idle.
EVERY_STEP_IDLE: dict[Callable[[Any, float], None], Callable[[Any], bool]] = {
    trajectory.record_step: trajectory.record_idle,
}

def extra_modes(ctl: Controller) -> tuple[int, ...]:
    """Modes 4-7 that ``ctl``'s firmware answers (:func:`extra_modes_of`)."""
    return extra_modes_of(ctl.firmware, ctl.registers)


def extra_modes_of(firmware: FirmwareProfile, registers: Container[int]) -> tuple[int, ...]:
    """Modes 4-7 that a box of ``firmware`` with register table ``registers`` answers: 4/5 where
    its table has registers 81/82, 6/7 where the firmware has the online modes."""
    out = tuple(m for m, code in velocity.MODE_REGISTERS.items() if code in registers)
    if firmware.online_modes:
        out += (online.MODE_JOINT_ONLINE, online.MODE_CARTESIAN_ONLINE)
    return out


def create_state(ctl: Controller) -> None:
    """Create the state behind modes 4-7 and 11, trajectories and reduced mode at construction, in
    their declared fields of ``ctl.data`` (the :class:`~..core.controller_state.ControllerState`), so that a
    checkpoint (a copy of that state) always holds it."""
    velocity.control_of(ctl)
    online.planner_of(ctl)
    trajectory.store_of(ctl)
    reduced.reduced_of(ctl)
