"""Every register of the table has exactly one handler, the controller's or a component's."""

from __future__ import annotations

import pytest

from xarm_emu.controller.emulator import Emulator
from xarm_emu.protocol.firmware import NEWEST_PROFILE
from xarm_emu.protocol.frame import STATE_WARNING
from xarm_emu.protocol.registers import REGISTERS, registers_for

#: Registers of the newest table whose handlers come with the feedback work (253/254) and the 2.x
#: motion work (relative moves, velocity control, trajectories, reduced mode); the others have theirs.
OTHER_PARTS = frozenset({253, 254}) | frozenset({47, 48, 49, 50, 53, 58, 60, 61, 62, 63, 64, 65, 81, 82, 83})


@pytest.mark.parametrize("vacuum", [False, True])
def test_handler_codes_are_the_register_table(vacuum: bool) -> None:
    emu = Emulator(6, vacuum=vacuum)
    codes = emu.controller.handler_codes
    assert frozenset(REGISTERS) <= codes <= frozenset(registers_for(NEWEST_PROFILE))


def test_every_register_of_the_newest_table_has_a_handler() -> None:
    emu = Emulator(6, firmware=str(NEWEST_PROFILE.version))
    missing = frozenset(registers_for(NEWEST_PROFILE)) - emu.controller.handler_codes
    assert missing == OTHER_PARTS


def test_a_code_outside_the_table_is_warning_13() -> None:
    emu = Emulator(6)
    code = next(c for c in range(1, 256) if c not in REGISTERS)
    status, reply = emu.handle(code, b"")
    assert status & STATE_WARNING and reply == b""
    assert emu.controller.warning_code == 13


def test_register_106_reports_the_gripper_error_through_the_hooks() -> None:
    emu = Emulator(6)
    emu.inject_gripper_error(0x19)
    _, reply = emu.handle(106, b"")
    assert reply[14:16] == bytes([1, 0x19])
