"""The motion state machine (controller/core/state_machine.py) against the manual: register 12/13 of section
2.1.3 and the error handling of chapter 3."""

from __future__ import annotations

import itertools
import re
import struct
from pathlib import Path

import pytest

from xarm_emu.controller.core import state_machine
from xarm_emu.controller.core.state_machine import Event
from xarm_emu.controller.emulator import Emulator
from xarm_emu.protocol.frame import STATE_NOT_READY

M, SL, SU, ST, RS = 1, 2, 3, 4, 5  # in motion, sleep, suspend, stop, system reset (register 13)

#: Where the manual sends each event; every pair not listed keeps its state.
EXPECTED: dict[Event, dict[int, int]] = {
    # Enable, mode change, clean error, offsets and sensitivities: a system reset (state 5).
    Event.ENABLE: dict.fromkeys((M, SL, SU, ST, RS), RS),
    Event.MODE_CHANGE: dict.fromkeys((M, SL, SU, ST, RS), RS),
    Event.SYSTEM_RESET: dict.fromkeys((M, SL, SU, ST, RS), RS),
    # Register 12 state 0 "motion": a suspend resumes, stop and system reset become ready (sleep).
    Event.SET_RUN: {SU: M, ST: SL, RS: SL},
    # Register 12 state 3 "suspend": only a moving or ready arm suspends.
    Event.SET_SUSPEND: {M: SU, SL: SU},
    # Register 12 state 4 "stop", and any control box error (section 3.2.1): stop.
    Event.SET_STOP: dict.fromkeys((M, SL, SU, ST, RS), ST),
    Event.ERROR: dict.fromkeys((M, SL, SU, ST, RS), ST),
    # A queued command starts a ready arm; a suspended arm stays suspended.
    Event.QUEUED: {SL: M},
    Event.IDLE: {M: SL},
    Event.PLAN_RUNNING: {SL: M},
    Event.PLAN_FINISHED: {M: SL, SU: SL},
    Event.SERVO_MOVING: {SL: M},
    Event.SERVO_AT_TARGET: {M: SL},
    Event.VIRTUAL_OFF: {M: SL, SU: SL},
}


def test_every_event_has_an_expectation() -> None:
    assert set(EXPECTED) == set(Event)


@pytest.mark.parametrize(("state", "event"), list(itertools.product(state_machine.STATES, Event)))
def test_every_pair_goes_where_the_manual_says(state: int, event: Event) -> None:
    class Holder:
        motion_state = state

    h = Holder()
    want = EXPECTED[event].get(state, state)
    assert state_machine.fire(h, event) == want
    assert h.motion_state == want
    assert state_machine.next_state(state, event) == want


def test_only_the_state_machine_writes_the_state() -> None:
    root = Path(state_machine.__file__).parents[1]  # the whole controller package
    writes = re.compile(r"\.motion_state\s*(=|\+=|-=)(?!=)|\b_state\s*=(?!=)")
    offenders = [f"{p.relative_to(root)}:{n}" for p in root.rglob("*.py") if p.name != "state_machine.py"
                 for n, line in enumerate(p.read_text().splitlines(), 1) if writes.search(line)]
    assert offenders == []


def _ready() -> Emulator:
    emu = Emulator(6)
    emu.handle(11, bytes([8, 1]))
    emu.handle(19, bytes([0]))
    emu.handle(12, bytes([0]))
    return emu


def test_state_follows_a_move_suspend_resume_and_stop() -> None:
    emu = _ready()
    assert emu.handle(13, b"")[1] == bytes([SL])
    emu.handle(23, struct.pack("<10f", 0.5, 0, 0, 0, 0, 0, 0, 0.5, 5.0, 0))
    assert emu.handle(13, b"")[1] == bytes([M])
    emu.advance(0.1)
    emu.handle(12, bytes([3]))
    assert emu.handle(13, b"")[1] == bytes([SU])
    emu.handle(12, bytes([0]))
    assert emu.handle(13, b"")[1] == bytes([M])
    emu.handle(12, bytes([4]))
    assert emu.handle(13, b"")[1] == bytes([ST])
    emu.advance(1.0)
    assert emu.handle(14, b"")[1][:2] == b"\x00\x00"


def test_not_ready_keeps_the_warning() -> None:
    emu = Emulator(6)  # state 4 after power-on: motion is refused
    emu.inject_warning(11)
    status, _ = emu.handle(23, struct.pack("<10f", 0.5, 0, 0, 0, 0, 0, 0, 0.5, 5.0, 0))
    assert status & STATE_NOT_READY
    assert emu.controller.warning_code == 11
    assert emu.controller.executor.cmdnum == 0


def test_the_mode_changes_through_its_table() -> None:
    """Register 19 selects the mode it names from any mode; playback (register 64) takes position
    mode to 11 and back; an event the table lacks keeps the mode."""
    ME = state_machine.ModeEvent
    for mode in state_machine.MODE_NAMES:
        assert state_machine.next_mode(mode, ME.SELECT, 1) == 1
    assert state_machine.next_mode(0, ME.PLAYBACK_START) == state_machine.MODE_PLAYBACK == 11
    assert state_machine.next_mode(11, ME.PLAYBACK_END) == 0
    assert state_machine.next_mode(1, ME.PLAYBACK_START) == 1
    assert state_machine.next_mode(2, ME.PLAYBACK_END) == 2
    with pytest.raises(ValueError):
        state_machine.next_mode(0, ME.SELECT)
    emu = _ready()
    emu.handle(19, bytes([1]))
    assert emu.controller.mode == 1
