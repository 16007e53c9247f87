"""The official SDK's calls that send the registers beyond manual V1.6.0 (other than motion and
feedback), through the unchanged ``XArmAPI`` against a box claiming firmware 2.7.103: the code,
the values read back and the effect on the emulator."""

from __future__ import annotations

import contextlib
import math
import time
from collections.abc import Iterator
from typing import Any

import pytest
from helpers import sdk_ready, wait_for

from xarm_emu.controller.handlers.service import HARMONIC_TYPE, SERVO_VERSION, extra_state
from xarm_emu.server.app import ServerThread
from xarm_emu.testing import running_emulator, sdk_pointed_at

FW2 = "2.7.103"


@pytest.fixture(scope="module")
def fw2() -> Iterator[tuple[Any, ServerThread]]:
    from xarm.wrapper import XArmAPI

    with contextlib.ExitStack() as stack:
        st = stack.enter_context(running_emulator(firmware=FW2))
        stack.enter_context(sdk_pointed_at(st))
        arm = XArmAPI("127.0.0.1", report_type="rich", forbid_uds=True)
        stack.callback(arm.disconnect)
        sdk_ready(arm)
        yield arm, st


def test_the_sdk_sees_the_2x_firmware(fw2: tuple[Any, ServerThread]) -> None:
    arm, _ = fw2
    assert tuple(arm.version_number) == (2, 7, 103)


def test_counter(fw2: tuple[Any, ServerThread]) -> None:
    arm, st = fw2
    assert arm.set_counter_reset() == 0
    for _ in range(3):
        assert arm.set_counter_increase() == 0
    assert wait_for(lambda: st.call(lambda: st.emulator.controller.user_counter) == 3)
    assert arm.set_counter_reset() == 0
    assert wait_for(lambda: st.call(lambda: st.emulator.controller.user_counter) == 0)


def test_is_tcp_limit(fw2: tuple[Any, ServerThread]) -> None:
    arm, _ = fw2
    code, pos = arm.get_position()
    assert code == 0
    assert arm.is_tcp_limit(pos) == (0, False)
    assert arm.is_tcp_limit([3000, 0, 100, 180, 0, 0]) == (0, True)


def test_servo_version_and_harmonic_type(fw2: tuple[Any, ServerThread]) -> None:
    arm, _ = fw2
    assert arm.get_servo_version(servo_id=1) == (0, ".".join(map(str, SERVO_VERSION)))
    code, types = arm.get_harmonic_type(servo_id=8)  # every joint
    assert code == 0 and types == [HARMONIC_TYPE] * 6


def test_tgpio_modbus_timeout_reads_back_and_is_honoured(fw2: tuple[Any, ServerThread]) -> None:
    arm, st = fw2
    assert arm.set_tgpio_modbus_timeout(7) == 0
    assert st.call(lambda: st.emulator.gripper.modbus_timeout_ms) == 7
    assert arm.get_rs485_timeout() == (0, 7)
    assert arm.set_tgpio_modbus_timeout(1) == 0  # shorter than the gripper's reply takes
    code, reply = arm.getset_tgpio_modbus_data([0x08, 0x03, 0x07, 0x02, 0x00, 0x02])
    assert reply[:3] == [0x08, 0x83, 0x0B]  # the gripper's reply came too late: no response
    assert arm.set_tgpio_modbus_timeout(20) == 0
    code, reply = arm.getset_tgpio_modbus_data([0x08, 0x03, 0x07, 0x02, 0x00, 0x02])
    assert code == 0 and reply[:3] == [0x08, 0x03, 0x04]


def test_approx_motion_and_cartesian_continuous(fw2: tuple[Any, ServerThread]) -> None:
    arm, st = fw2
    assert arm.set_allow_approx_motion(True) == 0
    assert arm.get_allow_approx_motion() == (0, True)
    assert arm.set_allow_approx_motion(False) == 0
    assert arm.get_allow_approx_motion() == (0, False)
    assert arm.set_cartesian_velo_continuous(True) == 0
    assert st.call(lambda: extra_state(st.emulator.controller).cartesian_velocity_continuous)
    assert arm.set_cartesian_velo_continuous(False) == 0


def test_dh_params(fw2: tuple[Any, ServerThread]) -> None:
    arm, _ = fw2
    code, dh = arm.get_dh_params()
    assert code == 0 and len(dh) == 28 and dh[0] == pytest.approx(267.0)
    assert arm.set_dh_params([float(i) for i in range(28)]) == 0
    assert arm.get_dh_params() == (0, pytest.approx([float(i) for i in range(28)]))
    assert arm.set_dh_params(dh) == 0


def test_check_verification_and_hd_types(fw2: tuple[Any, ServerThread]) -> None:
    arm, _ = fw2
    assert arm.check_verification() == (0, 0)
    code, types = arm.get_hd_types()
    assert code == 0 and len(types) == 2


def test_iden_joint_friction(fw2: tuple[Any, ServerThread]) -> None:
    arm, _ = fw2
    assert arm.iden_joint_friction(sn="XI1300" + "0" * 8) == (0, 0)
    assert arm.iden_joint_friction(sn="XI1900" + "0" * 8) == (0, -1)  # another arm's serial


def test_common_params_and_info(fw2: tuple[Any, ServerThread]) -> None:
    arm, st = fw2
    assert arm.set_linear_spd_limit_factor(0.5) == 0
    assert arm.get_linear_spd_limit_factor() == (0, pytest.approx(0.5))
    assert arm.set_ft_collision_detection(1) == 0
    assert arm.get_ft_collision_detection() == (0, 1)
    assert arm.set_rs485_timeout(30, target="control_box") == 0
    assert arm.get_rs485_timeout(target="control_box") == (0, 30)
    assert arm.get_poe_status() == (0, 0)
    assert arm.get_iden_status() == (0, 0)
    code, info = arm.get_c23_error_info()
    assert code == 0
    assert arm.set_linear_spd_limit_factor(1.0) == 0


def test_traj_speeding(fw2: tuple[Any, ServerThread]) -> None:
    arm, _ = fw2
    assert arm.get_traj_speeding(1) == (0, [0, 0, 0.0])


def test_ft_sensor_absent(fw2: tuple[Any, ServerThread]) -> None:
    arm, st = fw2
    assert arm.get_ft_sensor_data() == (0, [0.0] * 6)
    assert arm.get_ft_sensor_mode() == (0, 0)
    arm.set_ft_sensor_enable(1)
    assert st.call(lambda: st.emulator.controller.warning_code) == 12  # nothing to switch on
    assert arm.clean_warn() == 0
    assert arm.set_ft_sensor_admittance_parameters(coord=1, c_axis=[0, 0, 1, 0, 0, 0],
                                                   M=[0.06] * 3 + [0.001] * 3, K=[0.0] * 6, B=[0.0] * 6) == 0
    code, cfg = arm.get_ft_sensor_config()
    assert code == 0
    assert cfg[0] == 0 and cfg[1] == 0  # application off, not started
    assert cfg[9] == 1 and cfg[10] == [0, 0, 1, 0, 0, 0]  # admittance frame and axes read back
    assert cfg[11] == pytest.approx([0.06] * 3 + [0.001] * 3)


def test_sync_io_waits_for_the_queued_move(fw2: tuple[Any, ServerThread]) -> None:
    arm, st = fw2
    io = st.emulator.io
    assert arm.clean_warn() == 0
    assert arm.set_cgpio_digital(3, 0) == 0
    assert wait_for(lambda: st.call(lambda: io.cgpio.output(3)) == 0)
    assert arm.set_servo_angle(angle=[20, 0, 0, 0, 0, 0], speed=20, wait=False) == 0
    assert arm.set_cgpio_digital(3, 1) == 0  # sync=True: in turn, after the move
    assert st.call(lambda: (io.cgpio.output(3), st.emulator.controller.is_moving)) == (0, True)
    assert wait_for(lambda: st.call(lambda: io.cgpio.output(3)) == 1, timeout=10.0)
    assert math.degrees(st.call(lambda: float(st.emulator.controller.q[0]))) == pytest.approx(20.0, abs=1e-3)
    assert arm.set_servo_angle(angle=[0] * 6, speed=50, wait=True) == 0


def test_1_6_0_keeps_warning_13_for_registers_beyond_the_manual() -> None:
    from xarm.wrapper import XArmAPI

    with running_emulator() as st, sdk_pointed_at(st):
        arm = XArmAPI("127.0.0.1", report_type="rich", forbid_uds=True)
        try:
            sdk_ready(arm)
            assert tuple(arm.version_number) == (1, 6, 0)
            arm.set_counter_increase()
            time.sleep(0.1)
            assert st.call(lambda: st.emulator.controller.warning_code) == 13
            assert st.call(lambda: st.emulator.controller.user_counter) == 0
        finally:
            arm.disconnect()


def test_calibration_calls(fw2: tuple[Any, ServerThread]) -> None:
    arm, _ = fw2
    import numpy as np

    from xarm_emu.model import rotations as rot

    tool, point = np.array([0.0, 10.0, 120.0]), np.array([350.0, -40.0, 150.0])
    poses = []
    for rpy in ((180.0, 0.0, 0.0), (180.0, 15.0, 0.0), (165.0, 0.0, 30.0), (180.0, -10.0, 60.0)):
        R = rot.rpy_to_matrix(*np.radians(rpy))
        poses.append([*(point - R @ tool), *rpy])
    code, offset = arm.calibrate_tcp_coordinate_offset(poses)
    assert code == 0 and offset == pytest.approx(list(tool), abs=0.05)
    code, rpy = arm.calibrate_tcp_orientation_offset([180, 0, 0], [180, 0, 30])
    assert code == 0 and rpy == pytest.approx([0, 0, -30], abs=1e-3)  # in the flipped flange frame


@pytest.mark.parametrize("version", ["1.11.100", "2.0.102", "2.4.101"])
def test_calls_return_0_on_earlier_2x_profiles(version: str) -> None:
    from xarm.wrapper import XArmAPI

    with running_emulator(firmware=version) as st, sdk_pointed_at(st):
        arm = XArmAPI("127.0.0.1", report_type="rich", forbid_uds=True)
        try:
            sdk_ready(arm)
            assert arm.set_counter_increase() == 0
            assert wait_for(lambda: st.call(lambda: st.emulator.controller.user_counter) == 1)
            assert arm.is_tcp_limit([207, 0, 112, 180, 0, 0]) == (0, False)
            assert arm.get_servo_version(servo_id=2) == (0, ".".join(map(str, SERVO_VERSION)))
            assert arm.set_tgpio_modbus_timeout(9) == 0
            assert st.call(lambda: st.emulator.gripper.modbus_timeout_ms) == 9
            assert arm.get_ft_sensor_data() == (0, [0.0] * 6)
            assert arm.set_cgpio_digital(2, 1) == 0  # no sync byte below 2.4.101: at once
            assert wait_for(lambda: st.call(lambda: st.emulator.io.cgpio.output(2)) == 1)
            assert st.call(lambda: st.emulator.controller.warning_code) == 0
        finally:
            arm.disconnect()
