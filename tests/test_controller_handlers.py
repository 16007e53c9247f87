"""Every register of the table has exactly one handler, the controller's or a component's."""

from __future__ import annotations

import pytest

from xarm_emu.controller.emulator import Emulator
from xarm_emu.protocol.firmware import SUPPORTED_VERSIONS, profile_for
from xarm_emu.protocol.frame import STATE_WARNING
from xarm_emu.protocol.registers import REGISTERS, registers_for


@pytest.mark.parametrize("vacuum", [False, True])
def test_handler_codes_are_the_register_table(vacuum: bool) -> None:
    emu = Emulator(6, vacuum=vacuum)
    assert emu.controller.handler_codes == frozenset(REGISTERS)


@pytest.mark.parametrize("version", SUPPORTED_VERSIONS)
@pytest.mark.parametrize("vacuum", [False, True])
def test_every_profile_handles_exactly_its_register_table(version: str, vacuum: bool) -> None:
    """No register a box of that firmware answers is left to warning 13, and none beyond its table
    is answered."""
    emu = Emulator(6, firmware=version, vacuum=vacuum)
    assert emu.controller.handler_codes == frozenset(registers_for(profile_for(version)))


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


#: Registers of the newest profile whose handlers have landed (relative moves, velocity control,
#: trajectories).
LANDED_FW2 = frozenset({61, 62, 63, 64, 65, 81, 82, 83, 230})


@pytest.mark.parametrize("firmware", ["1.11.100", "2.0.102", "2.7.103"])
def test_newer_firmware_binds_the_handlers_of_its_table(firmware: str) -> None:
    emu = Emulator(6, firmware=firmware)
    table = frozenset(emu.controller.registers)
    assert frozenset(REGISTERS) <= emu.controller.handler_codes <= table
    assert LANDED_FW2 <= emu.controller.handler_codes
