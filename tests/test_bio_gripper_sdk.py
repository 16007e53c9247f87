"""The official SDK's ``*_bio_gripper*`` functions against an emulator with the BIO gripper on the
tool RS-485 (``running_emulator(gripper="bio")``, register 124 host 9, slave 8 at 2 Mbps): one test
per function, object detection and errors played through the CLI's admin commands, bad input, a
gripper that is not the one attached, and the SDK's example 5009 run unchanged."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from helpers import run_cli
from test_robotiq_sdk import MODBUS_ERR_LENG, addr, run_sdk_example, sdk_arm_with

from xarm_emu.controller.devices.bio_gripper import PULSE_MAX, BioGripper, mm_to_pulses
from xarm_emu.server.app import ServerThread
from xarm_emu.testing import running_emulator

END_EFFECTOR_HAS_FAULT = 102
END_EFFECTOR_NOT_ENABLED = 103


@pytest.fixture(scope="module")
def bio() -> Iterator[tuple[Any, ServerThread]]:
    with sdk_arm_with("bio") as pair:
        yield pair


def device(st: ServerThread) -> BioGripper:
    dev = st.emulator.gripper.device
    assert isinstance(dev, BioGripper)
    return dev


def enable(arm: Any) -> None:
    assert arm.set_bio_gripper_enable(True) == 0


def test_set_bio_gripper_enable_waits_until_enabled(bio) -> None:
    arm, st = bio
    assert arm.set_bio_gripper_enable(False) == 0
    assert arm.get_bio_gripper_status() == (0, 0)
    assert arm.set_bio_gripper_enable(True) == 0
    code, status = arm.get_bio_gripper_status()
    assert code == 0 and (status >> 2) & 0x03 == 2  # enabled


def test_get_bio_gripper_status_shows_the_motion(bio) -> None:
    arm, st = bio
    enable(arm)
    assert arm.open_bio_gripper() == 0
    assert arm.close_bio_gripper(wait=False) == 0
    code, status = arm.get_bio_gripper_status()
    assert code == 0 and status & 0x03 == 1  # moving
    assert arm.close_bio_gripper() == 0
    assert arm.get_bio_gripper_status() == (0, 2 << 2)  # stopped, enabled


def test_set_bio_gripper_speed(bio) -> None:
    arm, st = bio
    assert arm.set_bio_gripper_speed(300) == 0
    assert arm._arm.get_bio_gripper_speed() == (0, 300)
    assert st.call(lambda: device(st).speed) == 300


def test_set_bio_gripper_force(bio) -> None:
    arm, st = bio
    assert arm.set_bio_gripper_force(40) == 0
    assert arm._arm.get_bio_gripper_force() == (0, 40)


def test_open_and_close_bio_gripper_reach_150_and_71_mm(bio) -> None:
    arm, st = bio
    enable(arm)
    assert arm.close_bio_gripper() == 0
    assert arm.get_bio_gripper_g2_position() == (0, 71)
    assert st.call(lambda: (device(st).position, device(st).moving)) == (0.0, False)
    assert arm.open_bio_gripper() == 0
    assert arm.get_bio_gripper_g2_position() == (0, 150)
    assert st.call(lambda: device(st).position) == PULSE_MAX


def test_set_bio_gripper_g2_position_and_get_bio_gripper_g2_position(bio) -> None:
    arm, st = bio
    enable(arm)
    assert arm.set_bio_gripper_g2_position(100, speed=3000, force=60) == 0
    assert arm.get_bio_gripper_g2_position() == (0, 100)
    dev = device(st)
    assert st.call(lambda: (dev.speed, dev.force)) == (3000, 60)
    assert st.call(lambda: dev.position) == pytest.approx(mm_to_pulses(100), abs=1.0)


def test_set_bio_gripper_control_mode_switches_to_the_position_loop(bio) -> None:
    arm, st = bio
    assert arm.set_bio_gripper_control_mode(1) == 0
    assert arm._arm.get_bio_gripper_control_mode() == (0, 1)
    try:
        enable(arm)  # the reboot left the motor disabled
        assert arm.set_bio_gripper_g2_position(120) == 0  # the SDK sends pulses in this mode
        assert st.call(lambda: round(device(st).position)) == int(120 * 3.7342 - 265.13)
        assert arm.get_bio_gripper_g2_position() == (0, 120)
    finally:
        assert arm.set_bio_gripper_control_mode(0) == 0
        enable(arm)
    assert arm._arm.get_bio_gripper_control_mode() == (0, 0)


def test_get_bio_gripper_error_and_clean_bio_gripper_error(bio) -> None:
    arm, st = bio
    enable(arm)
    assert arm.get_bio_gripper_error() == (0, 0)
    code, out = run_cli("inject", "gripper-error", "11", *addr(st))
    assert code == 0 and "current beyond limit" in out
    code, status = arm.get_bio_gripper_status()
    assert code == 0 and status & 0x03 == 3  # fault
    assert arm.get_bio_gripper_error() == (0, 11)
    assert arm.open_bio_gripper() == END_EFFECTOR_HAS_FAULT
    assert arm.clean_bio_gripper_error() == 0
    assert arm.get_bio_gripper_error() == (0, 0)
    assert arm.open_bio_gripper() == 0


def test_closing_on_an_object_then_it_slips_out(bio) -> None:
    arm, st = bio
    enable(arm)
    assert arm.open_bio_gripper() == 0
    assert run_cli("set-input", "gripper-object", "0", "100", *addr(st))[0] == 0
    assert arm.close_bio_gripper() == 0
    code, status = arm.get_bio_gripper_status()
    assert code == 0 and status & 0x03 == 2  # stopped on the object
    assert arm.get_bio_gripper_g2_position() == (0, 100)
    assert st.call(lambda: st.emulator.gripper_status())["object"] is True
    code, out = run_cli("set-input", "gripper-object", "0", "0", *addr(st))
    assert code == 0 and "removed" in out
    assert arm.get_bio_gripper_error() == (0, 12)  # the object slipped from the gripper
    assert arm.clean_bio_gripper_error() == 0
    enable(arm)


def test_out_of_range_speed_is_refused_and_changes_nothing(bio) -> None:
    arm, st = bio
    assert arm.set_bio_gripper_speed(2000) == 0
    assert arm.set_bio_gripper_speed(5000) == MODBUS_ERR_LENG  # the device's exception reply
    assert arm._arm.get_bio_gripper_speed() == (0, 2000)


def test_position_while_disabled_ends_not_enabled(bio) -> None:
    arm, st = bio
    assert arm.set_bio_gripper_enable(False) == 0
    before = st.call(lambda: device(st).position)
    assert arm.set_bio_gripper_g2_position(80) == END_EFFECTOR_NOT_ENABLED
    assert st.call(lambda: device(st).position) == before
    enable(arm)


def test_robotiq_and_xarm_gripper_calls_get_no_answer(bio) -> None:
    arm, st = bio
    code, ret = arm.robotiq_get_status()
    assert code == MODBUS_ERR_LENG and ret[:2] == [0x09, 0x83]
    assert arm.get_bio_gripper_status()[0] == 0  # the BIO gripper still answers afterwards


def test_bio_gripper_calls_with_the_xarm_gripper_attached() -> None:
    with sdk_arm_with("xarm") as (arm, st):
        # the xArm gripper is slave 8 too but has no serial number register: the SDK's probe fails
        code, _ = arm._arm.get_bio_gripper_sn()
        assert code == MODBUS_ERR_LENG


def test_sdk_example_5009_runs_unchanged(tmp_path: Path) -> None:
    with running_emulator(6, gripper="bio", speed=5.0) as st:
        env, out = run_sdk_example("wrapper/common/5009-set_bio_gripper.py", st, tmp_path, 5.0,
                                   lambda: st.emulator.inject_error(31))
        try:
            assert "set_bio_gripper_enable, code=0" in out and "set_bio_gripper_speed, code=0" in out
            assert out.count("open_bio_gripper, code=0") >= 2, out
            assert out.count("close_bio_gripper, code=0") >= 2, out
            assert env["arm"].error_code == 31  # the loop ended on the injected error
        finally:
            env["arm"].disconnect()


def test_status_shows_the_bio_gripper_it_finds_on_the_tool_bus(bio) -> None:
    import json

    arm, st = bio
    enable(arm)
    assert arm.close_bio_gripper() == 0
    code, out = run_cli("status", "--json", "--port", str(st.ports["command"]),
                        "--report-port", str(st.ports["develop"]))
    assert code == 0, out
    assert json.loads(out)["gripper"] == {"type": "bio", "enabled": True, "motion": 0, "position": 0,
                                          "error": 0}


def test_serve_refuses_an_unknown_gripper_or_two_end_tools() -> None:
    code, out = run_cli("serve", "--gripper", "robotiq-3f", "--port", "0")
    assert code == 2 and "--gripper: one of xarm, robotiq-2f85, robotiq-2f140, bio" in out
    code, out = run_cli("serve", "--gripper", "bio", "--vacuum", "--port", "0")
    assert code == 2 and "one end tool at a time" in out
