"""The xArm Vacuum Gripper model (controller/devices/vacuum.py): TI0 follows the pump on TO0/TO1 with the
documented delays, to the control period, and only while an object seals the cup."""

from __future__ import annotations

import pytest
from helpers import ready

from xarm_emu.controller.core.interface import PERIOD
from xarm_emu.controller.devices.vacuum import PRESSURE_BUILD, PRESSURE_RELEASE
from xarm_emu.controller.emulator import Emulator


def ti0(emu: Emulator) -> int:
    return emu.io.tool.digital_inputs & 1


def steps_until(emu: Emulator, value: int, limit: float = 2.0) -> float:
    """Controller seconds until TI0 == value."""
    t0 = emu.time
    while ti0(emu) != value:
        assert emu.time - t0 < limit, "TI0 never changed"
        emu.step(1)
    return emu.time - t0


def pump(emu: Emulator, on: bool) -> None:
    emu.io.tool.set_output(0, int(on))
    emu.io.tool.set_output(1, int(not on))


@pytest.fixture
def emu() -> Emulator:
    e = Emulator(6, vacuum=True)
    ready(e)
    return e


def test_pressure_builds_and_releases_with_the_documented_delays(emu: Emulator) -> None:
    pump(emu, True)
    assert steps_until(emu, 1) == pytest.approx(PRESSURE_BUILD, abs=PERIOD + 1e-9)
    emu.advance(1.0)
    assert ti0(emu) == 1
    pump(emu, False)
    assert steps_until(emu, 0) == pytest.approx(PRESSURE_RELEASE, abs=PERIOD + 1e-9)


def test_both_outputs_on_is_not_pumping(emu: Emulator) -> None:
    emu.io.tool.set_output(0, 1)
    emu.io.tool.set_output(1, 1)
    emu.advance(1.0)
    assert ti0(emu) == 0


def test_no_object_no_pressure_and_a_dropped_part_drops_at_once(emu: Emulator) -> None:
    emu.set_input("vacuum-object", 0, 0)
    pump(emu, True)
    emu.advance(1.0)
    assert ti0(emu) == 0
    emu.set_input("vacuum-object", 0, 1)
    assert steps_until(emu, 1) == pytest.approx(PRESSURE_BUILD, abs=PERIOD + 1e-9)
    emu.set_input("vacuum-object", 0, 0)
    assert steps_until(emu, 0) <= PERIOD + 1e-9
    with pytest.raises(ValueError, match="one cup"):
        emu.set_input("vacuum-object", 1, 1)


def test_the_model_owns_ti0_but_not_ti1(emu: Emulator) -> None:
    emu.set_input("tgpio", 0, 1)  # a stray input on TI0 is overruled: the pump is off
    emu.set_input("tgpio", 1, 1)
    emu.advance(1.0)
    assert emu.io.tool.digital_inputs == 0b10
