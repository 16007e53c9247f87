"""End tools of Lite 6 and 850 through the unchanged SDK: the Lite 6 gripper on TO0/TO1, the vacuum
gripper in both wirings (TO0/TO1 + TI0, TO3/TO4 + TI3, outputs read back at 0x0A18), TI2 at 0x0A12
and the five tool inputs of the 850 (manual section 2.1.4, registers 127/128)."""

from __future__ import annotations

import time
from collections.abc import Iterator
from typing import Any

import pytest
from helpers import run_cli, sdk_ready, wait_for

from xarm_emu.controller.core.interface import ParameterError
from xarm_emu.controller.devices.lite6_gripper import TRAVEL_TIME
from xarm_emu.server.app import ServerThread
from xarm_emu.testing import running_emulator, sdk_pointed_at

FW = "2.4.101"


def _arm(st: ServerThread) -> Any:
    from xarm.wrapper import XArmAPI

    return XArmAPI("127.0.0.1", forbid_uds=True)


@pytest.fixture
def lite6() -> Iterator[tuple[Any, ServerThread]]:
    with running_emulator(model="lite6", firmware=FW, vacuum=True, admin=True) as st, sdk_pointed_at(st):
        arm = _arm(st)
        try:
            sdk_ready(arm)
            yield arm, st
        finally:
            arm.disconnect()


@pytest.fixture
def uf850() -> Iterator[tuple[Any, ServerThread]]:
    with running_emulator(model="850", firmware=FW, vacuum=True) as st, sdk_pointed_at(st):
        arm = _arm(st)
        try:
            sdk_ready(arm)
            yield arm, st
        finally:
            arm.disconnect()


def _jaw(st: ServerThread) -> tuple[str, float]:
    def read() -> tuple[str, float]:
        g = st.emulator.lite6_gripper
        assert g is not None
        return g.jaw, g.opening
    return st.call(read)  # type: ignore[return-value]


# -- Lite 6 gripper ---------------------------------------------------------------------------------

def test_lite6_gripper_close_open_and_outputs_read_back(lite6) -> None:
    arm, st = lite6
    assert _jaw(st) == ("open", 1.0)
    t0 = time.monotonic()
    assert arm.close_lite6_gripper() == 0
    assert arm.get_tgpio_output_digital()[1][:2] == [0, 1]  # TO0, TO1 from 0x0A18
    assert wait_for(lambda: _jaw(st)[0] == "closing", timeout=1.0)
    assert wait_for(lambda: _jaw(st) == ("closed", 0.0), timeout=2.0)
    assert time.monotonic() - t0 >= TRAVEL_TIME * 0.9  # a full stroke takes its travel time
    assert arm.open_lite6_gripper() == 0
    assert arm.get_tgpio_output_digital()[1][:2] == [1, 0]
    assert wait_for(lambda: _jaw(st) == ("open", 1.0), timeout=2.0)


def test_lite6_gripper_stop_holds_the_jaws_between_the_ends(lite6) -> None:
    arm, st = lite6
    assert arm.close_lite6_gripper() == 0
    assert wait_for(lambda: _jaw(st)[1] < 0.8, timeout=2.0)
    assert arm.stop_lite6_gripper() == 0
    assert arm.get_tgpio_output_digital()[1][:2] == [0, 0]
    jaw, opening = _jaw(st)
    time.sleep(TRAVEL_TIME)
    assert _jaw(st) == (jaw, opening)  # nothing moves after stop
    assert jaw == "stopped" and 0.0 < opening < 1.0


def test_only_lite6_has_the_pneumatic_gripper() -> None:
    with running_emulator(model="850", firmware=FW) as st:
        assert st.call(lambda: st.emulator.lite6_gripper) is None


# -- vacuum gripper ---------------------------------------------------------------------------------

@pytest.mark.parametrize("hw, ti", [(1, 0), (2, 3)])
@pytest.mark.parametrize("which", ["lite6", "uf850"])
def test_vacuum_gripper_in_both_wirings(request, which: str, hw: int, ti: int) -> None:
    # ``check_on`` is a keyword of the SDK's own ``get_vacuum_gripper`` that the XArmAPI wrapper does
    # not pass on: it reads the outputs at 0x0A18 before the pressure input.
    arm, st = request.getfixturevalue(which)
    assert arm.set_vacuum_gripper(True, wait=True, timeout=2, hardware_version=hw) == 0
    assert st.call(lambda: st.emulator.io.tool.input(ti)) == 1
    assert arm._arm.get_vacuum_gripper(hardware_version=hw, check_on=True) == (0, 1)
    outs = arm.get_tgpio_output_digital()[1]
    assert ((outs[0], outs[1]) if hw == 1 else (outs[3], outs[4])) == (1, 0)
    other = 3 if hw == 1 else 0
    assert st.call(lambda: st.emulator.io.tool.input(other)) == 0  # the other wiring's input stays low
    assert arm.set_vacuum_gripper(False, wait=True, timeout=2, hardware_version=hw) == 0
    assert st.call(lambda: st.emulator.io.tool.input(ti)) == 0
    assert arm._arm.get_vacuum_gripper(hardware_version=hw, check_on=True) == (0, -1)  # outputs say off


@pytest.mark.parametrize("hw", [1, 2])
def test_missed_pick_times_out_with_the_sdks_code(lite6, hw: int) -> None:
    from xarm.x3.code import APIState

    arm, st = lite6
    st.call(lambda: st.emulator.set_input("vacuum-object", 0, 0))
    code = arm.set_vacuum_gripper(True, wait=True, timeout=0.5, hardware_version=hw)
    assert code == APIState.SUCTION_CUP_TOUT
    assert arm.get_vacuum_gripper(hardware_version=hw) == (0, 0)


# -- TI2 and the five tool inputs ------------------------------------------------------------------

def test_lite6_ti2_played_from_the_cli_and_read_by_the_sdk(lite6) -> None:
    arm, st = lite6
    assert arm.get_tgpio_digital(2) == (0, 0)
    code, out = run_cli("set-input", "tgpio", "2", "1", "--port", str(st.ports["command"]),
                        "--admin-port", str(st.ports["admin"]))
    assert code == 0, out
    assert arm.get_tgpio_digital(2) == (0, 1)
    assert arm.get_tool_digital_input() == (0, [0, 0, 1])  # Lite 6: TI0, TI1, TI2
    assert st.call(lambda: st.emulator.io.tool.digital_inputs) == 0  # not a 0x0A14 bit


def test_850_has_five_tool_inputs(uf850) -> None:
    arm, st = uf850
    for ti, v in ((1, 1), (2, 1), (4, 1)):
        st.call(lambda ti=ti, v=v: st.emulator.set_input("tgpio", ti, v))
    assert arm.get_tool_digital_input() == (0, [0, 1, 1, 0, 1])
    assert [arm.get_tgpio_digital(i)[1] for i in range(5)] == [0, 1, 1, 0, 1]
    assert st.call(lambda: st.emulator.io.tool.digital_inputs) == 0b1010  # TI1 bit 1, TI4 bit 3


def test_xarm_has_no_ti2() -> None:
    with running_emulator(model=6) as st, sdk_pointed_at(st):
        with pytest.raises(ParameterError):
            st.call(lambda: st.emulator.check_input("tgpio", 2))
        arm = _arm(st)
        try:
            assert arm.get_tgpio_digital(2)[0] != 0  # 0x0A12 is not a register of the xArm tool board
        finally:
            arm.disconnect()


def test_lite6_end_button_switches_manual_mode_as_studio_does(lite6) -> None:
    """Studio polls TI2 (the end teaching button) and answers a press with ``set_mode(2, 1)`` and
    ``set_state(0)``, the next with ``set_mode(0)``: the emulator's TI2 drives that loop."""
    arm, st = lite6

    def mode() -> int:
        return st.call(lambda: st.emulator.controller.mode)  # type: ignore[no-any-return]

    for pressed, want in ((1, 2), (0, 2), (1, 0)):
        st.call(lambda p=pressed: st.emulator.set_input("tgpio", 2, p))
        code, button = arm.get_tgpio_digital(2)
        assert (code, button) == (0, pressed)
        if button:
            target = 0 if mode() == 2 else 2
            assert arm.set_mode(target, 1 if target == 2 else 0) == 0
            assert arm.set_state(0) == 0
        assert wait_for(lambda w=want: mode() == w, timeout=2.0)
