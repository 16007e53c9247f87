"""The Inspire RH56 hand on the tool RS-485 (``--gripper inspire-rh56``, slave 1 at 115200 bps):
its register map through the SDK's raw Modbus calls, and the finger functions of the SDK's example
program ``set_yinshi_rh56_gripper.py`` (its own code, run against the emulator; the program's loop
of 100 two-second cycles is left out)."""

from __future__ import annotations

import struct
import time
from collections.abc import Iterator
from typing import Any

import pytest
from test_robotiq_sdk import sdk_arm_with, sdk_example_source

from xarm_emu.controller.devices.inspire_hand import ANGLE_ACT, ANGLE_SET, DOF, STATUS, InspireHand
from xarm_emu.server.app import ServerThread


@pytest.fixture(scope="module")
def hand() -> Iterator[tuple[Any, ServerThread]]:
    with sdk_arm_with("inspire-rh56") as pair:
        arm = pair[0]
        assert arm.set_tgpio_modbus_baudrate(115200) == 0
        yield pair


def device(st: ServerThread) -> InspireHand:
    dev = st.emulator.gripper.device
    assert isinstance(dev, InspireHand)
    return dev


def angles(arm: Any) -> list[int]:
    code, reply = arm.getset_tgpio_modbus_data([0x01, 0x03, *struct.pack(">HH", ANGLE_ACT, DOF)])
    assert code == 0 and reply[:3] == [0x01, 0x03, 2 * DOF]
    return list(struct.unpack(f">{DOF}H", bytes(reply[3:])))


def test_raw_modbus_moves_a_finger_and_reads_it_back(hand: tuple[Any, ServerThread]) -> None:
    arm, st = hand
    code, reply = arm.getset_tgpio_modbus_data([0x01, 0x06, *struct.pack(">HH", ANGLE_SET + 2, 200)])
    assert code == 0 and reply == [0x01, 0x06, *struct.pack(">HH", ANGLE_SET + 2, 200)]
    time.sleep(0.5)  # 800 units at speed 1000: 0.64 s of controller time (the server runs faster)
    assert angles(arm)[1] == 200 and angles(arm)[0] == 1000
    code, reply = arm.getset_tgpio_modbus_data([0x01, 0x03, *struct.pack(">HH", STATUS, 1)])
    assert code == 0 and reply[3:] == [2, 2]  # ring finger and little finger: at their targets
    code, reply = arm.getset_tgpio_modbus_data([0x01, 0x06, *struct.pack(">HH", ANGLE_SET, 1001)])
    assert reply[:3] == [0x01, 0x86, 0x03]  # beyond 0..1000: illegal data value
    code, reply = arm.getset_tgpio_modbus_data([0x01, 0x03, *struct.pack(">HH", 0x0001, 1)])
    assert reply[:3] == [0x01, 0x83, 0x02]  # not in the map: illegal data address


def test_the_sdk_example_functions_open_and_close_the_hand(hand: tuple[Any, ServerThread], tmp_path: Any,
                                                           monkeypatch: pytest.MonkeyPatch) -> None:
    arm, st = hand
    (tmp_path / "robot.conf").write_text("[xArm]\nip = 127.0.0.1\n", encoding="utf-8")
    (tmp_path / "thridparty").mkdir()
    monkeypatch.chdir(tmp_path / "thridparty")  # the program reads ../robot.conf
    source = sdk_example_source("wrapper/thridparty/set_yinshi_rh56_gripper.py")
    if source is None:
        pytest.skip("the SDK repository's examples are not here: set XARM_SDK_EXAMPLES to its example/")
    env: dict[str, Any] = {"__name__": "rh56_example", "__file__": "set_yinshi_rh56_gripper.py"}
    exec(compile(source.split("\narm = XArmAPI(ip)")[0], "set_yinshi_rh56_gripper.py", "exec"), env)
    env["set_rh56_finger"](arm, pos=0, force=500, speed=1000)
    time.sleep(0.5)
    assert angles(arm)[:5] == [0] * 5 and device(st).data.force_set[:5] == [500] * 5
    env["set_rh56_finger"](arm, pos=1000, force=500, speed=1000)
    time.sleep(0.5)
    assert angles(arm)[:5] == [1000] * 5
