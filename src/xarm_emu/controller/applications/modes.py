"""Modes of register 19 beyond the manual's (velocity control 4/5, online planning 6/7): which
firmware answers them, what the core runs for them each control period, and which registers they
take over while active."""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any

from ..core.controller_protocol import Controller
from ..core.interface import Handler, Values
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

#: Registers whose meaning a mode changes: (mode, register) -> handler. In modes 6 and 7 a joint or
#: linear move is a new online target instead of a queued command.
MODE_ROUTES: dict[tuple[int, int], Callable[[Any, Values], dict[str, Any] | None]] = {
    (online.MODE_JOINT_ONLINE, 23): online.joint_target,
    (online.MODE_JOINT_ONLINE, 24): online.joint_target,
    (online.MODE_CARTESIAN_ONLINE, 21): online.cartesian_target,
}


def extra_modes(ctl: Controller) -> tuple[int, ...]:
    """Modes 4-7 that ``ctl``'s firmware answers: 4/5 where its table has registers 81/82, 6/7 from
    firmware 2.0.0."""
    out = tuple(m for m, code in velocity.MODE_REGISTERS.items() if code in ctl.registers)
    if online.available(ctl):
        out += (online.MODE_JOINT_ONLINE, online.MODE_CARTESIAN_ONLINE)
    return out


def route(ctl: Controller, code: int) -> Handler | None:
    """The handler of register ``code`` in ``ctl``'s present mode, when the mode changes it."""
    fn = MODE_ROUTES.get((ctl.mode, code))
    if fn is None:
        return None
    return functools.partial(fn, ctl)


def create_state(ctl: Controller) -> None:
    """Create the state behind modes 4-7 and 11, trajectories and reduced mode at construction, in
    their declared fields of ``ctl.data`` (the :class:`~.state.ControllerState`), so that a
    checkpoint (a copy of that state) always holds it."""
    velocity.control_of(ctl)
    online.planner_of(ctl)
    trajectory.store_of(ctl)
    reduced.reduced_of(ctl)
