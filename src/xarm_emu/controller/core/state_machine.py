"""The motion state machine (register 13, manual section 2.1.3; errors chapter 3) and the mode
(register 19).

Everything that changes the motion state or the mode lives here: the states and modes, the events
that move between them, the transition tables and :func:`fire` and :func:`fire_mode`, the only
functions that write the state and the mode.

States (register 13): 1 in motion, 2 sleep (idle and ready), 3 suspend, 4 stop, 5 system reset.
Modes (register 19): 0 position, 1 servo, 2 joint teaching, 3 Cartesian teaching (not available).

A (state, event) pair absent from :data:`TRANSITIONS` keeps the state: for example suspending
(register 12, state 3) in stop, or a command queued while suspended.
"""

from __future__ import annotations

from enum import Enum, auto
from typing import Protocol

STATE_MOVING = 1
STATE_SLEEP = 2
STATE_SUSPEND = 3
STATE_STOP = 4
STATE_SYSTEM_RESET = 5
STATES = (STATE_MOVING, STATE_SLEEP, STATE_SUSPEND, STATE_STOP, STATE_SYSTEM_RESET)

MODE_POSITION = 0
MODE_SERVO = 1
MODE_JOINT_TEACH = 2
MODE_CARTESIAN_TEACH = 3
#: Trajectory playback (register 64, not in manual V1.6.0): the mode the box shows while it plays.
MODE_PLAYBACK = 11

#: The manual's names of the states (register 13) and modes (register 19), for logs and displays;
#: modes 4-7 and 11 are beyond the manual (which firmware answers 4-7: ``applications/modes.extra_modes``).
STATE_NAMES = {STATE_MOVING: "in motion", STATE_SLEEP: "sleep (ready)", STATE_SUSPEND: "suspend",
               STATE_STOP: "stop", STATE_SYSTEM_RESET: "system reset"}
MODE_NAMES = {MODE_POSITION: "position", MODE_SERVO: "servo", MODE_JOINT_TEACH: "joint teaching",
              MODE_CARTESIAN_TEACH: "cartesian teaching", 4: "joint velocity", 5: "cartesian velocity",
              6: "joint online planning", 7: "cartesian online planning", 11: "trajectory playback"}


class Event(Enum):
    """What can change the motion state."""

    ENABLE = auto()  # registers 11 / 18: enable or brake joints (a system reset)
    MODE_CHANGE = auto()  # register 19 (a system reset)
    SYSTEM_RESET = auto()  # clean error (16), TCP/world offset (35/73), sensitivities (37/38)
    SET_RUN = auto()  # register 12 state 0: resume from suspend, leave stop / system reset
    SET_SUSPEND = auto()  # register 12 state 3
    SET_STOP = auto()  # register 12 state 4
    ERROR = auto()  # a control box error (section 3.2.1): stop at once
    QUEUED = auto()  # a motion command entered the buffer
    IDLE = auto()  # position mode, a control period starts with nothing to run
    PLAN_RUNNING = auto()  # position mode, a control period ran a command that goes on
    PLAN_FINISHED = auto()  # position mode, the last command of the buffer ended
    SERVO_MOVING = auto()  # servo mode (1): the arm is heading for its target
    SERVO_AT_TARGET = auto()  # servo mode (1): the arm holds its target
    VIRTUAL_OFF = auto()  # register 79 switched off: motion ends


_ALL_STOP = {(s, Event.SET_STOP): STATE_STOP for s in STATES}
_ALL_ERROR = {(s, Event.ERROR): STATE_STOP for s in STATES}
_ALL_RESET = {(s, e): STATE_SYSTEM_RESET for s in STATES
              for e in (Event.ENABLE, Event.MODE_CHANGE, Event.SYSTEM_RESET)}

#: ``TRANSITIONS[(state, event)]`` is the state the event leads to; absent pairs keep the state.
TRANSITIONS: dict[tuple[int, Event], int] = {
    **_ALL_STOP,
    **_ALL_ERROR,
    **_ALL_RESET,
    (STATE_SUSPEND, Event.SET_RUN): STATE_MOVING,
    (STATE_STOP, Event.SET_RUN): STATE_SLEEP,
    (STATE_SYSTEM_RESET, Event.SET_RUN): STATE_SLEEP,
    (STATE_MOVING, Event.SET_SUSPEND): STATE_SUSPEND,
    (STATE_SLEEP, Event.SET_SUSPEND): STATE_SUSPEND,
    (STATE_SLEEP, Event.QUEUED): STATE_MOVING,
    (STATE_MOVING, Event.IDLE): STATE_SLEEP,
    (STATE_SLEEP, Event.PLAN_RUNNING): STATE_MOVING,
    (STATE_MOVING, Event.PLAN_FINISHED): STATE_SLEEP,
    (STATE_SUSPEND, Event.PLAN_FINISHED): STATE_SLEEP,
    (STATE_SLEEP, Event.SERVO_MOVING): STATE_MOVING,
    (STATE_MOVING, Event.SERVO_AT_TARGET): STATE_SLEEP,
    (STATE_MOVING, Event.VIRTUAL_OFF): STATE_SLEEP,
    (STATE_SUSPEND, Event.VIRTUAL_OFF): STATE_SLEEP,
}


class ModeEvent(Enum):
    """What can change the mode (register 19)."""

    SELECT = auto()  # register 19: the mode the command names (its handler checked the firmware has it)
    PLAYBACK_START = auto()  # register 64: trajectory playback runs in mode 11
    PLAYBACK_END = auto()  # the playback finished or ended unfinished: position mode again


#: In :data:`MODE_TRANSITIONS`: the mode the event names (register 19's request).
REQUESTED = -1

#: ``MODE_TRANSITIONS[(mode, event)]`` is the mode the event leads to (:data:`REQUESTED`: the one it
#: names); absent pairs keep the mode. Register 19 selects from any mode, modes 4-7 and 11 included.
MODE_TRANSITIONS: dict[tuple[int, ModeEvent], int] = {
    **{(m, ModeEvent.SELECT): REQUESTED for m in MODE_NAMES},
    (MODE_POSITION, ModeEvent.PLAYBACK_START): MODE_PLAYBACK,
    (MODE_PLAYBACK, ModeEvent.PLAYBACK_END): MODE_POSITION,
}


class HasState(Protocol):
    """What holds a motion state (the controller)."""

    motion_state: int


class HasMode(Protocol):
    """What holds a mode (the controller)."""

    mode: int


def next_mode(mode: int, event: ModeEvent, requested: int | None = None) -> int:
    """The mode ``event`` leads to from ``mode`` (the same mode when the table has no entry);
    ``requested``: the mode a :attr:`ModeEvent.SELECT` names."""
    new = MODE_TRANSITIONS.get((mode, event), mode)
    if new == REQUESTED:
        if requested is None:
            raise ValueError(f"{event.name} names no mode")
        return requested
    return new


def fire_mode(holder: HasMode, event: ModeEvent, requested: int | None = None) -> int:
    """Apply ``event`` to ``holder``'s mode (register 19); returns the new mode."""
    new = next_mode(holder.mode, event, requested)
    holder.mode = new
    return new


def next_state(state: int, event: Event) -> int:
    """The state ``event`` leads to from ``state`` (the same state when the table has no entry)."""
    return TRANSITIONS.get((state, event), state)


#: :data:`TRANSITIONS` keyed by the events' values: an enum member hashes in Python code, an int in C,
#: and :func:`fire` runs every control period.
_BY_VALUE: dict[tuple[int, int], int] = {(s, e.value): new for (s, e), new in TRANSITIONS.items()}


def fire(holder: HasState, event: Event) -> int:
    """Apply ``event`` to ``holder``'s motion state; returns the new state."""
    state = holder.motion_state
    new = _BY_VALUE.get((state, event._value_), state)
    holder.motion_state = new
    return new
