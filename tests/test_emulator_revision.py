"""``Emulator.next_event`` (controller/emulator.py): periods stepped before it, in any calls, change
nothing but the clock, and while ``Emulator.unchanged(mark)`` holds everything a register read or a
report frame without the clock shows is what it was at the mark. The servers encode report frames
and answer pure reads once per such quiet stretch (server/report_ports.py, server/command_port.py
``ReadCache``), so this is what keeps an arm at rest cheap without showing anything old."""

from __future__ import annotations

import dataclasses
import itertools
from typing import Any

import pytest
from helpers import report_frames
from test_clock_exact import IDLE, MIXED, READS, Action, gripper_to, ready, schedule_faults, send

from xarm_emu.controller.emulator import Emulator
from xarm_emu.protocol import reports


def shown(emu: Emulator) -> tuple[Any, ...]:
    """What a client sees that does not carry the clock: the report frames but the clocked ones,
    the snapshot behind them and the pure reads' replies (read without counting as a change)."""
    ports = sorted(reports.encoders_for(emu.firmware))
    frames = tuple(f for port, f in zip(ports, report_frames(emu), strict=True)
                   if port not in reports.CLOCKED_PORTS)
    regs = emu.controller.registers
    replies = tuple(emu.controller.handle(code, b"") for code in READS if code in regs)
    snap = dataclasses.replace(emu.snapshot(), timestamp_us=0)  # the clock (real-time report only)
    return frames, snap, replies


def walk(emu: Emulator, script: dict[int, list[Action]], total: int,
         pattern: tuple[int, ...]) -> tuple[int, int]:
    """Step ``emu`` through ``script`` in strides of ``pattern``; at every instant at which the box
    is unchanged since the instant before, what it shows must be the same. Returns (instants
    unchanged, instants changed)."""
    for action in script.get(0, []):
        action(emu)
    done, same, new = 0, 0, 0
    before: tuple[tuple[int, float], tuple[Any, ...]] | None = None
    strides = itertools.cycle(pattern)
    marks = sorted(script)
    while done < total:
        n = min(next(strides), total - done)
        upcoming = [m for m in marks if done < m < done + n]
        if upcoming:
            n = upcoming[0] - done
        emu.step(n)
        done += n
        for action in script.get(done, []):
            action(emu)
        if before is not None and emu.unchanged(before[0]):
            assert shown(emu) == before[1], f"unchanged box shows something new after period {done}"
            same += 1
        else:
            new += 1
        before = (emu.mark(), shown(emu))
    return same, new


@pytest.mark.parametrize("firmware", ["1.6.0", "2.7.103"])
def test_mixed_program_shows_nothing_new_while_unchanged(firmware: str) -> None:
    emu = Emulator(6, firmware=firmware)
    schedule_faults(emu)
    same, new = walk(emu, MIXED, 45 * 250, (2, 3, 1, 7, 250, 25))
    assert same > 100 and new > 50  # both kinds of instant occur: the test can fail either way


@pytest.mark.parametrize(("devices", "script"), [
    ({}, IDLE),
    ({"vacuum": True}, {0: [ready, lambda e: send(e, 143, ionum=0, on=1, delay=1.0)]}),
    ({"gripper": "robotiq-2f85"}, IDLE),
    ({"gripper": "bio"}, IDLE),
    ({"ft_sensor": True, "firmware": "2.7.103"}, {0: [*IDLE[0], lambda e: e.handle(201, b"\x01")]}),
])
def test_idle_programs_with_devices_show_nothing_new_while_unchanged(
        devices: dict[str, Any], script: dict[int, list[Action]]) -> None:
    emu = Emulator(6, **devices)
    walk(emu, script, 30 * 250, (2, 3, 25, 1, 300))


def test_a_box_at_rest_stays_unchanged_and_any_change_ends_it() -> None:
    emu = Emulator(6)
    ready(emu)
    emu.step(10)
    rev = emu.mark()
    for n in (1, 2, 3, 40, 7):  # periods at rest, none with a thermal step
        emu.step(n)
    assert emu.unchanged(rev)
    for change in (lambda: send(emu, 13), emu.touch, lambda: emu.inject_warning(12),
                   lambda: emu.set_input("cgpio", 1, 1), lambda: emu.step(250)):  # 250: a thermal step
        change()
        assert not emu.unchanged(rev)
        rev = emu.mark()
    send(emu, 23, joints=(0.3, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0), speed=1.0, acc=8.0, mvtime=0.0)
    rev = emu.mark()
    emu.step(2)
    assert not emu.unchanged(rev)  # in motion every call is a change
    gripper_to(emu, 400)
    rev = emu.mark()
    emu.step(1)
    assert not emu.unchanged(rev)  # the gripper moving on its own is a change too


@pytest.mark.parametrize("devices", [{}, {"vacuum": True}, {"gripper": "robotiq-2f85"},
                                     {"ft_sensor": True, "firmware": "2.7.103"}])
def test_next_event_is_a_promise_the_steps_keep(devices: dict[str, Any]) -> None:
    """The periods before ``next_event()``, stepped in any calls, leave the box unchanged, and what
    shows as it was (a server lets the last frame stand for the deadlines they cover); through the
    idle program's timers, delayed outputs and scheduled faults."""
    emu = Emulator(6, **devices)
    schedule_faults(emu)
    for action in IDLE[0]:
        action(emu)
    if devices.get("ft_sensor"):
        assert not emu.handle(201, b"\x01")[0] & 0x60  # switched on, it reads every period
    kept = 0
    while emu.controller.steps < 60 * 250:
        k = emu.next_event() - emu.controller.steps - 1  # the periods promised quiet
        if k == 0:
            emu.step(3)
            continue
        assert not devices.get("ft_sensor")  # its readings follow the clock: never quiet
        rev, before = emu.mark(), shown(emu)
        n = int(min(k, 700))
        for part in (n // 3, n - n // 3):
            emu.step(part)
        assert emu.unchanged(rev) and shown(emu) == before, emu.controller.steps
        kept += n
        emu.step(1)  # on into whatever ended the promise
    if not devices.get("ft_sensor"):
        assert kept > 30 * 250  # most of the idle minute was promised quiet


def test_a_dwell_ending_in_a_one_period_call_is_a_change() -> None:
    """A dwell (register 26) counts only time, yet its last period ends the command (cmdnum, state):
    stepped one period per call, no call of its run may count as unchanged while that shows."""
    emu = Emulator(6)
    script: dict[int, list[Action]] = {0: [ready, lambda e: send(e, 26, seconds=0.1)],
                                       60: [lambda e: send(e, 26, seconds=0.05)]}
    walk(emu, script, 120, (1,))
    assert emu.controller.executor.completed == 2
