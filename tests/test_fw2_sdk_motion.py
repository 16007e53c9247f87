"""The official SDK's relative moves and velocity control against a box claiming firmware 1.8 or later.

From firmware 1.8.100 the SDK sends relative ``set_position`` / ``set_servo_angle`` as register 83
(below, it adds the offset to its cached pose and sends an absolute move); ``vc_set_joint_velocity``
and ``vc_set_cartesian_velocity`` send registers 81 and 82 in modes 4 and 5, with a duration from
firmware 1.8.0. Each test asserts what the emulated arm did (joints, pose, mode, state).

Timing: the server runs ``speed`` controller seconds per wall second.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest
from helpers import sdk_ready, wait_for

from xarm_emu.server.app import ServerThread
from xarm_emu.testing import running_emulator

SDKArm = Callable[..., Any]
VERSIONS = ("1.11.100", "2.4.101", "2.7.103")


@pytest.fixture(params=VERSIONS)
def fw_server(request: pytest.FixtureRequest) -> Iterator[ServerThread]:
    with running_emulator(firmware=request.param, speed=2.0) as st:
        yield st


def _seen_registers(st: ServerThread) -> list[int]:
    """Register codes the emulator handles from now on (wraps its ``handle``)."""
    emu = st.emulator
    seen: list[int] = []
    original = emu.handle

    def handle(code: int, params: bytes) -> tuple[int, bytes]:
        seen.append(code)
        return original(code, params)

    emu.handle = handle  # type: ignore[method-assign]
    return seen


def _idle(st: ServerThread) -> bool:
    ctl = st.emulator.controller
    return ctl.state == 2 and ctl.executor.cmdnum == 0


def test_relative_set_position_goes_through_register_83(fw_server: ServerThread, sdk_arm: SDKArm) -> None:
    arm = sdk_arm(fw_server)
    sdk_ready(arm)
    ctl = fw_server.emulator.controller
    start = ctl.tcp_pose().copy()
    seen = _seen_registers(fw_server)
    assert arm.set_position(x=10, z=-5, relative=True, speed=100, mvacc=2000, wait=False) == 0
    assert wait_for(lambda: ctl.executor.cmdnum == 0 and ctl.state == 2, 10)
    assert 83 in seen and 21 not in seen
    moved = ctl.tcp_pose() - start
    assert moved[:3] == pytest.approx([10.0, 0.0, -5.0], abs=1e-3)
    assert moved[3:] == pytest.approx([0.0, 0.0, 0.0], abs=1e-6)
    # A second relative move starts where the first ended.
    assert arm.set_position(y=20, relative=True, speed=100, mvacc=2000, wait=False) == 0
    assert wait_for(lambda: _idle(fw_server), 10)
    assert (ctl.tcp_pose() - start)[:3] == pytest.approx([10.0, 20.0, -5.0], abs=1e-3)


def test_relative_set_servo_angle_adds_to_the_joints(fw_server: ServerThread, sdk_arm: SDKArm) -> None:
    arm = sdk_arm(fw_server)
    sdk_ready(arm)
    ctl = fw_server.emulator.controller
    q0 = ctl.q.copy()
    seen = _seen_registers(fw_server)
    assert arm.set_servo_angle(angle=[10, 0, -5, 0, 0, 0], relative=True, speed=30, wait=False) == 0
    assert arm.set_servo_angle(angle=[5, 0, 0, 0, 0, 0], relative=True, speed=30, wait=False) == 0
    assert wait_for(lambda: _idle(fw_server), 10)
    assert 83 in seen and 23 not in seen
    want = q0 + np.radians([15, 0, -5, 0, 0, 0])
    assert ctl.q == pytest.approx(want, abs=1e-6)


def test_relative_joint_move_beyond_the_limits_is_refused(fw_server: ServerThread, sdk_arm: SDKArm) -> None:
    arm = sdk_arm(fw_server)
    sdk_ready(arm)
    ctl = fw_server.emulator.controller
    code = arm.set_servo_angle(angle=[0, 0, 0, 0, 400, 0], relative=True, speed=30, wait=False)
    assert wait_for(lambda: ctl.error_code == 23, 5)  # C23: joint angle exceeds the limit
    assert code != 0 or ctl.error_code == 23
    assert ctl.q == pytest.approx(np.zeros(6), abs=1e-9)


def _speed_of(st: ServerThread, seconds: float) -> np.ndarray:
    """Mean joint velocity (rad/s of controller time) over ``seconds`` of controller time."""
    ctl = st.emulator.controller

    def instant() -> tuple[float, np.ndarray]:  # time and joints of one period, read in the loop
        return ctl.time, ctl.q.copy()

    t0, q0 = st.call(instant)
    assert wait_for(lambda: ctl.time >= t0 + seconds, 10)
    t1, q1 = st.call(instant)
    return np.asarray((q1 - q0) / (t1 - t0))


def test_vc_set_joint_velocity_moves_at_the_commanded_speed_and_stops_after_the_duration(
        fw_server: ServerThread, sdk_arm: SDKArm) -> None:
    arm = sdk_arm(fw_server)
    sdk_ready(arm)
    ctl = fw_server.emulator.controller
    assert arm.set_mode(4) == 0 and arm.set_state(0) == 0
    assert wait_for(lambda: ctl.mode == 4 and ctl.state == 2)
    speeds = [8.0, -4.0, 0.0, 6.0, 0.0, 0.0]  # deg/s
    assert arm.vc_set_joint_velocity(speeds, duration=3.0) == 0
    assert wait_for(lambda: ctl.state == 1, 5)
    assert wait_for(lambda: float(np.max(np.abs(ctl.qd))) > 0.1 * math.radians(8.0), 5)
    t_start = ctl.time
    # The mean speed is measured once every joint cruises (past the acceleration ramp).
    assert wait_for(lambda: bool(np.allclose(ctl.qd, np.radians(speeds), rtol=1e-3, atol=1e-6)), 5)
    v = _speed_of(fw_server, 1.0)
    assert v == pytest.approx(np.radians(speeds), rel=0.01, abs=1e-6)
    assert wait_for(lambda: ctl.state == 2, 10)
    assert ctl.time - t_start < 3.0 + 0.5
    q_end = ctl.q.copy()
    assert wait_for(lambda: ctl.time > t_start + 4.0, 5)
    assert ctl.q == pytest.approx(q_end, abs=1e-12)
    travelled = np.degrees(q_end[0])
    assert 8.0 * 2.8 < travelled < 8.0 * 3.2


def test_vc_set_joint_velocity_stops_on_the_joint_limit(fw_server: ServerThread, sdk_arm: SDKArm) -> None:
    arm = sdk_arm(fw_server)
    sdk_ready(arm)
    ctl = fw_server.emulator.controller
    ctl.q = np.array([0.0, 0.0, 0.0, 0.0, 1.9, 0.0])  # J5 near its upper limit
    assert arm.set_mode(4) == 0 and arm.set_state(0) == 0
    assert wait_for(lambda: ctl.mode == 4 and ctl.state == 2)
    assert arm.vc_set_joint_velocity([0, 0, 0, 0, 60, 0]) == 0
    upper = ctl.model.upper[4]
    assert wait_for(lambda: ctl.q[4] >= upper - 1e-9 and ctl.state == 2, 10)
    assert ctl.q[4] == pytest.approx(upper, abs=1e-9)
    assert ctl.error_code == 0
    assert arm.vc_set_joint_velocity([0, 0, 0, 0, -60, 0]) == 0  # and leaves it again
    assert wait_for(lambda: ctl.q[4] < upper - 0.1, 10)


def test_vc_set_cartesian_velocity_moves_the_tcp(fw_server: ServerThread, sdk_arm: SDKArm) -> None:
    arm = sdk_arm(fw_server)
    sdk_ready(arm)
    ctl = fw_server.emulator.controller
    assert arm.set_servo_angle(angle=[0, -30, -30, 0, 60, 0], speed=60, wait=False) == 0
    assert wait_for(lambda: _idle(fw_server), 10)
    assert arm.set_mode(5) == 0 and arm.set_state(0) == 0
    assert wait_for(lambda: ctl.mode == 5 and ctl.state == 2)
    assert arm.vc_set_cartesian_velocity([0, 30, -20, 0, 0, 0], duration=2.0) == 0
    assert wait_for(lambda: ctl.state == 1, 5)
    target = math.hypot(30.0, 20.0)
    assert wait_for(lambda: abs(float(np.linalg.norm(_tcp_speed(ctl))) - target) < 1e-6, 5)  # ramp over
    t0, p0 = ctl.time, ctl.tcp_pose().copy()
    assert wait_for(lambda: ctl.time >= t0 + 0.8, 10)
    p1 = ctl.tcp_pose()
    v = (p1[:3] - p0[:3]) / (ctl.time - t0)
    assert v == pytest.approx([0.0, 30.0, -20.0], rel=0.01, abs=0.2)
    assert (p1 - p0)[3:] == pytest.approx([0, 0, 0], abs=1e-6)
    assert wait_for(lambda: ctl.state == 2, 10)


def _tcp_speed(ctl: Any) -> np.ndarray:
    from xarm_emu.controller.applications import velocity

    return np.asarray(velocity.control_of(ctl).velocity[:3])


def test_modes_4_and_5_are_refused_by_firmware_1_6_0(sdk_arm: SDKArm) -> None:
    with running_emulator(firmware="1.6.0") as st:
        arm = sdk_arm(st)
        sdk_ready(arm)
        ctl = st.emulator.controller
        arm.set_mode(4)
        assert wait_for(lambda: ctl.warning_code == 12)  # parameter abnormal: no such mode
        assert ctl.mode == 0


@pytest.mark.parametrize("firmware", ["2.0.102", "2.7.103"])
def test_mode_6_set_servo_angle_retargets_mid_move(firmware: str, sdk_arm: SDKArm) -> None:
    with running_emulator(firmware=firmware, speed=1.0) as st:
        arm = sdk_arm(st)
        sdk_ready(arm)
        ctl = st.emulator.controller
        assert arm.set_mode(6) == 0 and arm.set_state(0) == 0
        assert wait_for(lambda: ctl.mode == 6 and ctl.state == 2)
        assert arm.set_servo_angle(angle=[90, 0, 0, 0, 0, 0], speed=60, mvacc=500, wait=False) == 0
        assert wait_for(lambda: ctl.q[0] > math.radians(20), 5)
        assert ctl.state == 1 and ctl.executor.cmdnum == 0
        assert arm.set_servo_angle(angle=[40, 0, -20, 0, 0, 0], speed=60, mvacc=500, wait=False) == 0
        assert wait_for(lambda: ctl.state == 2, 10)
        assert ctl.q == pytest.approx(np.radians([40, 0, -20, 0, 0, 0]), abs=1e-6)
        assert arm.mode == 6


def test_mode_7_set_position_retargets_mid_move(sdk_arm: SDKArm) -> None:
    with running_emulator(firmware="2.7.103", speed=1.0) as st:
        arm = sdk_arm(st)
        sdk_ready(arm)
        ctl = st.emulator.controller
        assert arm.set_servo_angle(angle=[0, -30, -30, 0, 60, 0], speed=60, wait=False) == 0
        assert wait_for(lambda: _idle(st), 10)
        p0 = ctl.tcp_pose().copy()
        assert arm.set_mode(7) == 0 and arm.set_state(0) == 0
        assert wait_for(lambda: ctl.mode == 7 and ctl.state == 2)
        x, y, z = p0[:3]
        rpy = list(np.degrees(p0[3:]))
        assert arm.set_position(x + 80, y, z, *rpy, speed=100, mvacc=1000, wait=False) == 0
        assert wait_for(lambda: ctl.tcp_pose()[0] > x + 20, 5)
        assert arm.set_position(x + 30, y + 40, z - 10, *rpy, speed=100, mvacc=1000, wait=False) == 0
        assert wait_for(lambda: ctl.state == 2, 10)
        assert ctl.tcp_pose()[:3] == pytest.approx([x + 30, y + 40, z - 10], abs=1e-3)
        assert ctl.executor.cmdnum == 0


def test_set_position_aa_relative_goes_through_register_83(fw_server: ServerThread, sdk_arm: SDKArm) -> None:
    arm = sdk_arm(fw_server)
    sdk_ready(arm)
    ctl = fw_server.emulator.controller
    assert arm.set_servo_angle(angle=[0, -30, -30, 0, 60, 0], speed=60, wait=False) == 0
    assert wait_for(lambda: _idle(fw_server), 10)
    T0 = ctl.tcp_matrix().copy()
    seen = _seen_registers(fw_server)
    assert arm.set_position_aa([0, 15, 0, 0, 0, 10], relative=True, speed=50, mvacc=1000, wait=False) == 0
    assert wait_for(lambda: _idle(fw_server), 10)
    assert 83 in seen
    T1 = ctl.tcp_matrix()
    assert T1[:3, 3] - T0[:3, 3] == pytest.approx([0, 15, 0], abs=1e-3)
    c, s = math.cos(math.radians(10)), math.sin(math.radians(10))
    rz = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    assert T1[:3, :3] == pytest.approx(rz @ T0[:3, :3], abs=1e-6)  # rotation applied in the base frame


def test_relative_moves_with_wait_return_when_they_end(fw_server: ServerThread, sdk_arm: SDKArm) -> None:
    arm = sdk_arm(fw_server)
    sdk_ready(arm)
    ctl = fw_server.emulator.controller
    start = ctl.tcp_pose().copy()
    assert arm.set_position(x=20, relative=True, speed=100, mvacc=2000, wait=True) == 0
    assert ctl.executor.cmdnum == 0
    assert (ctl.tcp_pose() - start)[:3] == pytest.approx([20.0, 0.0, 0.0], abs=1e-3)
    q0 = ctl.q.copy()
    assert arm.set_servo_angle(angle=[10, 0, 0, 0, 0, 0], relative=True, speed=30, wait=True) == 0
    assert ctl.executor.cmdnum == 0
    assert ctl.q[0] - q0[0] == pytest.approx(math.radians(10), abs=1e-6)
