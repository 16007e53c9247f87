"""Emulator.checkpoint() / restore(): the whole state back, byte for byte (an emulator feature)."""

from __future__ import annotations

import functools
import struct
from typing import Any

import pytest

from xarm_emu.controller.emulator import Emulator
from xarm_emu.protocol import reports


def _joint_move(j1: float, speed: float = 0.6) -> bytes:
    return struct.pack("<10f", j1, -0.2, 0, 0, 0.1, 0, 0, speed, 4.0, 0)


def _line_move(x: float) -> bytes:
    return struct.pack("<9f", x, 0, 300, 3.1416, 0, 0, 100, 1000, 0)


def _prepare(emu: Emulator) -> None:
    for code, params in ((11, bytes([8, 1])), (19, bytes([0])), (12, bytes([0]))):
        emu.handle(code, params)
    emu.handle(23, _joint_move(0.4))
    emu.handle(21, _line_move(250))
    emu.handle(142, struct.pack("<BBf", 2, 1, 0.5))  # delayed control box output
    emu.advance(0.3)


#: The program replayed after the checkpoint: moves, a suspend and resume, IO, a gripper command.
PROGRAM: list[tuple[float, int, bytes]] = [
    (0.0, 23, _joint_move(-0.3)),
    (0.2, 12, bytes([3])),
    (0.3, 12, bytes([0])),
    (0.1, 135, struct.pack(">H", 2000)),
    (0.1, 124, bytes([9, 8, 0x10, 0x01, 0x00, 0x00, 0x01, 0x02, 0x00, 0x01])),
    (0.5, 21, _line_move(220)),
    (1.0, 13, b""),
]


def _run(emu: Emulator) -> list[tuple[int, bytes, bytes, bytes, bytes]]:
    out = []
    for wait, code, params in PROGRAM:
        emu.advance(wait)
        status, reply = emu.handle(code, params)
        snap = emu.snapshot()
        out.append((status, reply, reports.encode_normal(snap), reports.encode_rich(snap),
                    reports.encode_develop(snap)))
    return out


@pytest.mark.parametrize("kw", [{}, {"firmware": "2.7.103", "linear_track": 700, "ft_sensor": True},
                                {"firmware": "2.7.103", "gripper": "bio", "vacuum": False}],
                         ids=["1.6.0", "2.7.103-track-ft", "2.7.103-bio"])
def test_restore_replays_byte_for_byte(kw: dict[str, Any]) -> None:
    emu = Emulator(6, **kw)
    _prepare(emu)
    cp = emu.checkpoint()
    first = _run(emu)
    emu.advance(2.0)
    emu.inject_error(22)
    gen = emu.generation
    emu.restore(cp)
    assert emu.generation > gen
    assert emu.time == cp.time
    second = _run(emu)
    assert second == first
    emu.restore(cp)  # a checkpoint can be restored again
    assert _run(emu) == first


def test_checkpoint_is_independent_of_the_running_emulator() -> None:
    emu = Emulator(7, vacuum=True)
    _prepare(emu)
    cp = emu.checkpoint()
    before = reports.encode_rich(emu.snapshot())
    emu.handle(12, bytes([4]))
    emu.set_input("cgpio", 3, 0)
    emu.advance(1.0)
    assert reports.encode_rich(emu.snapshot()) != before
    emu.restore(cp)
    assert reports.encode_rich(emu.snapshot()) == before
    assert emu.vacuum is not None and emu.vacuum.tool is emu.io.tool


def test_clear_faults_resets_the_fault_group_and_the_gripper_error() -> None:
    emu = Emulator(6)
    emu.inject_servo_error(2, 0x21)
    emu.inject_warning(11)
    emu.inject_gripper_error(0x19)
    assert emu.controller.faults.error == 12 and emu.controller.faults.servo_errors[1] == 0x21
    emu.clear_faults()
    assert (emu.controller.error_code, emu.controller.warning_code) == (0, 0)
    assert emu.controller.servo_errors == [0] * 6
    assert emu.gripper.gripper.error == 0
    status, reply = emu.handle(15, b"")
    assert reply == b"\x00\x00" and status & 0x60 == 0


def test_restore_puts_the_schedule_back_where_it_was() -> None:
    """Actions pending at the checkpoint (a fault schedule) run again after a restore; one scheduled
    after the checkpoint is gone with the rest of that later state."""
    emu = Emulator(6)
    emu.at(0.5, functools.partial(emu.inject_warning, 11))  # actions are partials: a checkpoint writes them
    emu.advance(0.2)
    cp = emu.checkpoint()
    emu.at(0.6, functools.partial(emu.inject_error, 22))
    emu.advance(1.0)
    assert (emu.controller.warning_code, emu.controller.error_code) == (11, 22)
    emu.restore(cp)
    assert (emu.controller.warning_code, emu.controller.error_code) == (0, 0)
    emu.advance(1.0)
    assert (emu.controller.warning_code, emu.controller.error_code) == (11, 0)


def test_a_checkpoint_of_another_layout_is_refused_and_changes_nothing() -> None:
    vacuum, plain = Emulator(6, vacuum=True), Emulator(6)
    plain.advance(0.1)
    before = reports.encode_rich(plain.snapshot())
    with pytest.raises(ValueError, match="other components"):
        plain.restore(vacuum.checkpoint())
    assert reports.encode_rich(plain.snapshot()) == before
