"""The unchanged official SDK (xarm-python-sdk 1.18.4) against the emulator server: connect with each
report type, enable, read poses and codes, and the SDK's return codes for replies with the error,
warning and not-ready bits of the reply state byte (manual section 2.1.2)."""

from __future__ import annotations

import math
import time
from typing import Any

import pytest
from helpers import sdk_ready as ready
from helpers import wait_for

from xarm_emu.server.app import ServerThread

SDK_REPORT_TYPES = {"normal": "normal", "rich": "rich", "real": "develop"}


@pytest.fixture
def real_arm(shared_sdk_arm) -> tuple[Any, ServerThread]:
    """The module's shared arm on 100 Hz reports at speed 5, as a fresh box leaves it: no fault,
    joints at zero, at rest in state 2, mode 0 (the tests run the start sequence themselves)."""
    arm, st = shared_sdk_arm(report_type="real", speed=5.0)
    st.call(lambda: st.emulator.clear_faults())
    assert arm.clean_warn() == 0 and arm.clean_error() == 0
    ready(arm)
    if st.call(lambda: any(st.emulator.joints)):
        # register 23 through the SDK's command layer (its set_servo_angle skips a repeated target)
        assert arm.arm.arm_cmd.move_joint([0.0] * 7, 2.0, 15.0, 0.0)[0] == 0
    assert wait_for(lambda: st.call(lambda: [float(q) for q in st.emulator.joints]) == [0.0] * 6)
    assert wait_for(lambda: arm.state == 2 and arm.mode == 0 and not any(arm.angles[:6]))
    return arm, st




@pytest.mark.parametrize("report_type", sorted(SDK_REPORT_TYPES))
def test_sdk_connects_enables_and_reads_zero_pose(make_server, sdk_arm, report_type: str) -> None:
    st: ServerThread = make_server(speed=4.0)
    arm = sdk_arm(st, report_type=report_type)
    assert arm.connected
    assert wait_for(lambda: arm.arm.reported)
    assert arm.version_number == (1, 6, 0)
    assert (arm.axis, arm.device_type) == (6, 6)
    # The SDK reads our reports on the port of its report type.
    assert st.call(lambda: len(st.server.report_clients[SDK_REPORT_TYPES[report_type]])) == 1
    ready(arm)
    code, pose = arm.get_position()
    assert code == 0
    assert pose[:3] == pytest.approx([207.0, 0.0, 112.0], abs=1e-3)
    assert abs(abs(pose[3]) - 180.0) < 1e-3
    assert pose[4:] == pytest.approx([0.0, 0.0], abs=1e-3)
    code, rad_pose = arm.get_position(is_radian=True)
    assert abs(abs(rad_pose[3]) - math.pi) < 1e-5
    assert arm.get_err_warn_code() == (0, [0, 0])
    # state and mode follow the report: state 2 after set_state(0) settles at rest (manual 2.1.3, 12/13)
    assert wait_for(lambda: arm.state == 2 and arm.mode == 0)
    assert arm.get_state() == (0, 2)


def test_sdk_version_and_serials(make_server, sdk_arm) -> None:
    st = make_server(speed=4.0)
    arm = sdk_arm(st, report_type="normal", check_robot_sn=True)
    code, version = arm.get_version()
    assert code == 0
    assert version == st.call(lambda: st.emulator.controller.version_string())
    assert version.startswith("6,6,") and version.endswith(",v1.6.0")
    assert arm.sn == version.split(",")[2]


def test_sdk_angles_follow_the_report_after_a_move(real_arm) -> None:
    arm, st = real_arm
    ready(arm)
    target = [30.0, -10.0, -20.0, 15.0, 25.0, -40.0]
    assert arm.set_servo_angle(angle=target, speed=120, mvacc=2000, wait=True) == 0
    emu_joints = st.call(lambda: [math.degrees(x) for x in st.emulator.joints])
    assert emu_joints == pytest.approx(target, abs=1e-3)
    assert wait_for(lambda: arm.angles[:6] == pytest.approx(target, abs=1e-3))
    code, angles = arm.get_servo_angle()
    assert code == 0 and angles[:6] == pytest.approx(target, abs=1e-3)
    # arm.position follows the report, and agrees with register 41
    code, pose = arm.get_position()
    assert wait_for(lambda: arm.position == pytest.approx(pose, abs=1e-2))
    assert wait_for(lambda: arm.state == 2)


def test_sdk_return_codes_with_injected_error(real_arm) -> None:
    arm, st = real_arm
    ready(arm)
    st.call(lambda: st.emulator.inject_error(31))
    # non-motion calls return 0 with the error bit set (motion calls only map it); the error reads C31
    assert arm.get_err_warn_code() == (0, [31, 0])
    assert wait_for(lambda: arm.error_code == 31)
    assert arm.get_state() == (0, 4)
    # motion calls return 1 while an error is present
    assert arm.set_servo_angle(angle=[10, 0, 0, 0, 0, 0], speed=50, wait=False) == 1
    # recovery (manual 3.3): clean error, enable, set_state(0)
    assert arm.clean_error() == 0
    ready(arm)
    assert arm.get_err_warn_code() == (0, [0, 0])
    assert wait_for(lambda: arm.error_code == 0 and arm.state in (1, 2))
    assert arm.set_servo_angle(angle=[10, 0, 0, 0, 0, 0], speed=100, wait=True) == 0
    assert wait_for(lambda: arm.angles[0] == pytest.approx(10.0, abs=1e-3))


def test_sdk_return_codes_with_injected_warning(real_arm) -> None:
    arm, st = real_arm
    ready(arm)
    st.call(lambda: st.emulator.inject_warning(11))
    assert arm.get_err_warn_code() == (0, [0, 11])
    # a warning changes nothing else: motion calls return 0 (the warning bit maps to no code)
    assert arm.set_servo_angle(angle=[5, 0, 0, 0, 0, 0], speed=100, wait=True) == 0
    assert arm.clean_warn() == 0
    assert arm.get_err_warn_code() == (0, [0, 0])


def test_sdk_refuses_motion_while_not_ready(make_server, sdk_arm) -> None:
    # an arm of its own: the SDK's code for a refused move depends on what its earlier calls left
    st = make_server(speed=5.0)
    arm = sdk_arm(st, report_type="real")
    ready(arm)
    assert wait_for(lambda: arm.state == 2)
    assert arm.arm.arm_cmd.state_is_ready
    # Disabling the motors makes the box not ready: replies carry 0x10 (the SDK's state_is_ready
    # goes False) and the state is 4 or 5, so the SDK refuses motion with NOT_READY (-2) itself. The
    # SDK's code 9 needs a 0x10 reply while the state is below 4, which this box never sends.
    assert arm.motion_enable(False) == 0
    code, state = arm.get_state()
    assert code == 0 and state >= 4
    assert arm.arm.arm_cmd.state_is_ready is False
    assert wait_for(lambda: arm.state >= 4)
    assert arm.set_servo_angle(angle=[5, 0, 0, 0, 0, 0], speed=50, wait=False) == -2
    assert st.call(lambda: st.emulator.joints[0]) == 0.0



def test_sdk_emergency_stop_leaves_state_4(real_arm) -> None:
    arm, st = real_arm
    ready(arm)
    assert arm.set_servo_angle(angle=[90, 0, 0, 0, 0, 0], speed=20, wait=False) == 0
    assert wait_for(lambda: arm.state == 1)
    arm.emergency_stop()
    assert arm.get_state() == (0, 4)
    time.sleep(0.3)  # 1.5 s of controller time: any stopping ramp is over
    q1 = st.call(lambda: st.emulator.joints[0])
    time.sleep(0.1)
    assert st.call(lambda: st.emulator.joints[0]) == q1  # stopped, short of the target
    assert math.degrees(q1) < 45.0
    assert arm.state == 4


@pytest.mark.parametrize("use_uvloop", [False, True])
def test_sdk_mode_follows_the_report(make_server, sdk_arm, use_uvloop: bool) -> None:
    """Mode changes reach arm.mode through the report; on both event loops (`serve` uses uvloop)."""
    if use_uvloop:
        pytest.importorskip("uvloop")
    st = make_server(speed=5.0, use_uvloop=use_uvloop)
    arm = sdk_arm(st, report_type="real")
    ready(arm)
    assert wait_for(lambda: arm.mode == 0 and arm.state == 2)
    assert arm.set_mode(1) == 0 and arm.set_state(0) == 0
    assert wait_for(lambda: arm.mode == 1)
    assert st.call(lambda: st.emulator.controller.mode) == 1
    assert arm.set_mode(0) == 0 and arm.set_state(0) == 0
    assert wait_for(lambda: arm.mode == 0 and arm.state == 2)
