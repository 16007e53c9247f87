"""Every register of the table has exactly one handler, the controller's or a component's, bound in
one table that names it."""

from __future__ import annotations

import functools
import importlib
import re
from typing import Any

import pytest
from typer.testing import CliRunner

from xarm_emu import cli
from xarm_emu.controller.applications import online
from xarm_emu.controller.core.interface import Binding, binding_table
from xarm_emu.controller.devices.gripper import GripperModule
from xarm_emu.controller.emulator import Emulator
from xarm_emu.controller.handlers import TABLE, motion
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


# --- one binding table ------------------------------------------------------------------------------


def _resolve(name: str) -> Any:
    """The function a ``module.qualname`` of the ``registers`` command names."""
    parts = name.split("(")[0].split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj: Any = importlib.import_module(".".join(parts[:i]))
        except ModuleNotFoundError:
            continue
        for attr in parts[i:]:
            obj = getattr(obj, attr)
        return obj
    raise AssertionError(f"no module in {name}")


def _named(output: str, version: str) -> str:
    match = re.search(rf"handler on {re.escape(version)}: (\S+)", output)
    assert match, output
    return match.group(1)


@pytest.mark.parametrize("version", ["1.6.0", "2.7.103"])
def test_registers_names_the_function_the_controller_calls_for_124_and_21(version: str) -> None:
    """`xarm-emu registers N` names the handler of N on both firmwares, read from the binding table,
    and it is the very function the controller dispatches the code to (with the register bound)."""
    runner = CliRunner()
    emu = Emulator(6, firmware=version)
    for code in (124, 21):
        result = runner.invoke(cli.app, ["registers", str(code)], terminal_width=250)
        assert result.exit_code == 0, result.output
        name = _named(result.output, version)
        handler = emu.controller._handlers[code]
        assert isinstance(handler, functools.partial)
        assert handler.func is _resolve(name)
        if code == 124:
            assert name == "xarm_emu.controller.devices.gripper.GripperModule.rs485_rtu"
            assert handler.args == (emu.gripper,)
        else:
            assert name == "xarm_emu.controller.handlers.motion.move_line(register=21)"
            assert handler.keywords == {"register": 21}


def test_registers_names_the_online_route_of_21_on_firmware_2_only() -> None:
    """Mode 7 (online Cartesian planning, firmware 2.x) routes register 21 to the online planner: a
    column of the same table, shown for 2.7.103 and absent on 1.6.0 (which has no mode 7)."""
    out = CliRunner().invoke(cli.app, ["registers", "21"], terminal_width=250).output
    on_1_6, on_2_7 = out.split("handler on 2.7.103")
    assert "in mode 7: xarm_emu.controller.applications.online.cartesian_target" in on_2_7
    assert "in mode 7" not in on_1_6
    emu = Emulator(6, firmware="2.7.103")
    assert emu.controller._routes[21][7].func is online.cartesian_target
    assert Emulator(6, firmware="1.6.0").controller._routes[21][7].func is online.cartesian_target


def test_a_code_bound_twice_is_an_error_naming_both() -> None:
    rows = (Binding(21, motion.move_home), Binding(21, motion.dwell))
    both = r"register 21 is bound twice: .*motion\.move_home and .*motion\.dwell"
    with pytest.raises(ValueError, match=both):
        binding_table(rows)


def test_a_lambda_cannot_be_bound() -> None:
    with pytest.raises(ValueError, match="not a plain function"):
        binding_table((Binding(13, lambda ctl, v: None),))


def test_every_handler_of_the_table_is_named() -> None:
    for row in TABLE.values():
        assert _resolve(row.where) is (row.handler.func if isinstance(row.handler, functools.partial)
                                       else row.handler)


def test_a_component_cannot_rebind_a_bound_code() -> None:
    emu = Emulator(6)
    with pytest.raises(ValueError, match="register 124 of GripperModule is bound already"):
        emu.controller.add_component(GripperModule())
