"""The Lite 6 gripper and vacuum gripper components stepped in controller time, and the tool input
numbering (TI0-TI4, TI2 at 0x0A12) of the tool board (manual section 2.1.4, registers 127/128)."""

from __future__ import annotations

import pytest

from xarm_emu.controller.core.interface import PERIOD, ParameterError
from xarm_emu.controller.devices.io import ADDR_TOOL_DO, ADDR_TOOL_DO_READ, ADDR_TOOL_TI2
from xarm_emu.controller.devices.lite6_gripper import TRAVEL_TIME
from xarm_emu.controller.devices.vacuum import PRESSURE_BUILD
from xarm_emu.controller.emulator import Emulator
from xarm_emu.protocol.rtu import TOOL_HOST

FW = "2.4.101"


def _write_do(emu: Emulator, word: int) -> None:
    emu.io.tool.write(TOOL_HOST, ADDR_TOOL_DO, float(word))


def test_lite6_jaws_travel_in_the_documented_time() -> None:
    emu = Emulator("lite6", firmware=FW)
    g = emu.lite6_gripper
    assert g is not None and (g.jaw, g.opening) == ("open", 1.0)
    _write_do(emu, 0x0300 | 0x0002)  # TO0 = 0, TO1 = 1: close
    assert g.jaw == "closing"
    n = round(TRAVEL_TIME / PERIOD)
    emu.step(n - 2)
    assert g.jaw == "closing" and 0.0 < g.opening < 3 * PERIOD / TRAVEL_TIME
    emu.step(2)
    assert (g.jaw, g.opening) == ("closed", 0.0)
    _write_do(emu, 0x0300 | 0x0001)  # open
    emu.step(n // 2)
    _write_do(emu, 0x0300)  # stop
    emu.step(n)
    assert g.jaw == "stopped" and g.opening == pytest.approx(0.5, abs=0.01)


def test_lite6_gripper_state_survives_a_checkpoint() -> None:
    emu = Emulator("lite6", firmware=FW)
    cp = emu.checkpoint()
    _write_do(emu, 0x0302)
    emu.step(round(TRAVEL_TIME / PERIOD) + 1)
    assert emu.lite6_gripper is not None and emu.lite6_gripper.jaw == "closed"
    emu.restore(cp)
    g = emu.lite6_gripper
    assert g.tool is emu.io.tool and (g.jaw, g.opening) == ("open", 1.0)


def test_vacuum_second_wiring_uses_to3_to4_and_ti3() -> None:
    emu = Emulator("850", firmware=FW, vacuum=True)
    _write_do(emu, 0x0C00 | 0x0004)  # TO3 = 1, TO4 = 0 (the SDK's masks for ionum 3 and 4)
    assert emu.io.tool.read(TOOL_HOST, ADDR_TOOL_DO_READ) == 0b0100
    emu.step(round(PRESSURE_BUILD / PERIOD) + 1)
    assert emu.io.tool.input(3) == 1 and emu.io.tool.digital_inputs == 0b0100
    assert emu.io.tool.input(0) == 0
    _write_do(emu, 0x0C00 | 0x0008)  # release
    emu.step(round(0.5 / PERIOD))
    assert emu.io.tool.input(3) == 0


@pytest.mark.parametrize("model", ["lite6", "850"])
def test_ti2_register_on_lite6_and_850(model: str) -> None:
    emu = Emulator(model, firmware=FW)
    emu.set_input("tgpio", 2, 1)
    assert emu.io.tool.read(TOOL_HOST, ADDR_TOOL_TI2) == 1
    assert emu.io.tool.digital_inputs == 0


def test_xarm_refuses_ti2_and_unknown_inputs() -> None:
    emu = Emulator(6)
    with pytest.raises(ParameterError):
        emu.io.tool.read(TOOL_HOST, ADDR_TOOL_TI2)
    for bad in (2, 5, -1):
        with pytest.raises(ParameterError):
            emu.set_input("tgpio", bad, 1)
    emu.set_input("tgpio", 4, 1)  # TI4 is bit 3 of 0x0A14
    assert emu.io.tool.digital_inputs == 0b1000
