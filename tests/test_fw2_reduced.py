"""Reduced mode (registers 47-50, 53, 58, 60) in process and through the official SDK: the settings
read back through register 53 / ``get_reduced_states``, and the limits act on the arm (TCP speed
not exceeded, joint speed capped, reduced joint ranges stop the arm with C23)."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from helpers import bits, sdk_ready, wait_for
from test_fw2_motion import _emu, call, ready

from xarm_emu.controller.emulator import Emulator
from xarm_emu.testing import running_emulator

SDKArm = Callable[..., Any]
POSE_Q = np.array([0.0, -0.5, -0.5, 0.0, 1.0, 0.0])


def _line(emu: Emulator, dx: float, speed: float) -> None:
    ctl = emu.controller
    pose = ctl.tcp_pose().copy()
    pose[0] += dx
    state, _, _ = call(emu, 21, pose=tuple(pose), speed=speed, acc=2000.0, mvtime=0.0, radius=-1.0, coord=0,
                       is_axis_angle=0, only_check_type=0, motion_type=0)
    assert not any(bits(state))


def _peak_tcp_speed(emu: Emulator, seconds: float) -> float:
    ctl = emu.controller
    peak = 0.0
    for _ in range(round(seconds / ctl.period)):
        p = ctl.tcp_matrix()[:3, 3].copy()
        emu.step()
        peak = max(peak, float(np.linalg.norm(ctl.tcp_matrix()[:3, 3] - p)) / ctl.period)
    return peak


def test_reduced_tcp_speed_caps_linear_moves_only_while_on() -> None:
    emu = _emu()
    ready(emu)
    emu.controller.q = POSE_Q.copy()
    call(emu, 47, speed=40.0)
    _line(emu, 60.0, 200.0)
    assert _peak_tcp_speed(emu, 2.0) == pytest.approx(200.0, rel=1e-3)  # reduced mode off
    call(emu, 50, on=1)
    assert call(emu, 49)[1] == {"on": 1}
    _line(emu, -60.0, 200.0)
    assert _peak_tcp_speed(emu, 3.0) == pytest.approx(40.0, rel=1e-3)
    assert emu.controller.state == 2


def test_reduced_joint_speed_caps_joint_moves_and_velocity_control() -> None:
    emu = _emu()
    ready(emu)
    call(emu, 48, speed=0.25)
    call(emu, 50, on=1)
    call(emu, 23, joints=(1.0, 0, 0, 0, 0, 0, 0), speed=1.0, acc=10.0, mvtime=0.0)
    peak = 0.0
    for _ in range(2000):
        emu.step()
        peak = max(peak, float(np.max(np.abs(emu.controller.qd))))
    assert peak == pytest.approx(0.25, rel=1e-6)
    assert emu.controller.q[0] == pytest.approx(1.0, abs=1e-9)
    ready(emu, mode=4)
    call(emu, 81, speeds=(-1.0, 0, 0, 0, 0, 0, 0), is_sync=1)
    emu.advance(1.0)
    assert emu.controller.qd[0] == pytest.approx(-0.25, rel=1e-6)


def test_reduced_joint_range_stops_the_arm_with_c23() -> None:
    emu = _emu()
    emu.controller.strict = False
    ready(emu)
    ctl = emu.controller
    lo, hi = ctl.model.lower, ctl.model.upper
    ranges = []
    for i in range(7):
        ranges += [-0.5, 0.5] if i == 0 else ([float(lo[i]), float(hi[i])] if i < 6 else [0.0, 0.0])
    assert not any(bits(call(emu, 58, joint_ranges=tuple(ranges))[0]))
    call(emu, 23, joints=(1.0, 0, 0, 0, 0, 0, 0), speed=1.0, acc=10.0, mvtime=0.0)
    emu.advance(3.0)
    assert ctl.error_code == 0 and ctl.q[0] == pytest.approx(1.0)  # reduced mode off: no effect
    call(emu, 50, on=1)
    call(emu, 23, joints=(0.0, 0, 0, 0, 0, 0, 0), speed=1.0, acc=10.0, mvtime=0.0)  # back in: allowed
    emu.advance(3.0)
    assert ctl.error_code == 0 and ctl.q[0] == pytest.approx(0.0, abs=1e-9)
    call(emu, 23, joints=(0.8, 0, 0, 0, 0, 0, 0), speed=1.0, acc=10.0, mvtime=0.0)
    emu.advance(3.0)
    assert ctl.error_code == 23 and ctl.state == 4
    assert ctl.q[0] <= 0.5 + 1e-9 and ctl.q[0] > 0.45


@pytest.mark.parametrize(("code", "values"), [
    (47, {"speed": 0.0}), (47, {"speed": 5000.0}), (48, {"speed": -1.0}), (48, {"speed": 4.0}),
    (50, {"on": 2}), (60, {"on": 7}),
    (58, {"joint_ranges": (0.5, -0.5) + (0.0,) * 12}),
    (58, {"joint_ranges": (10.0, 11.0) + (0.0,) * 12}),
    (58, {"joint_ranges": (math.nan, 1.0) + (0.0,) * 12}),
])
def test_bad_reduced_settings_are_warning_12(code: int, values: dict[str, Any]) -> None:
    emu = _emu()
    before = call(emu, 53)[2]
    state, _, _ = call(emu, code, **values)
    assert bits(state)[1] and emu.controller.warning_code == 12
    assert call(emu, 53)[2] == before


def test_sdk_reduced_mode_calls(sdk_arm: SDKArm) -> None:
    with running_emulator(firmware="2.7.103", speed=2.0) as st:
        arm = sdk_arm(st)
        sdk_ready(arm)
        ctl = st.emulator.controller
        assert arm.set_reduced_max_tcp_speed(50) == 0
        assert arm.set_reduced_max_joint_speed(30) == 0  # deg/s
        ranges_deg = [-90, 90, -100, 100, -200, 10, -180, 180, -90, 170, -180, 180]
        assert arm.set_reduced_joint_range(ranges_deg) == 0
        assert arm.set_reduced_tcp_boundary([500, -500, 400, -400, 600, -100]) == 0
        assert arm.set_fense_mode(True)[0] == 0
        assert arm.set_collision_rebound(True)[0] == 0
        assert arm.set_reduced_mode(True) == 0
        assert arm.get_reduced_mode() == (0, 1)
        code, states = arm.get_reduced_states()
        assert code == 0
        on, boundary, tcp_speed, joint_speed, ranges, fence, rebound = states
        assert (on, fence, rebound) == (1, 1, 1)
        assert boundary == [500, -500, 400, -400, 600, -100]
        assert tcp_speed == pytest.approx(50.0)
        assert joint_speed == pytest.approx(30.0, abs=0.1)
        assert ranges[:6] == pytest.approx([-90, 90, -100, 100, -200, 10], abs=0.01)
        # The reduced TCP speed acts on a move the SDK asks for at 200 mm/s.
        assert arm.set_servo_angle(angle=[0, -30, -30, 0, 60, 0], speed=20, wait=False) == 0
        assert wait_for(lambda: ctl.state == 2 and ctl.executor.cmdnum == 0, 20)
        assert float(np.max(np.abs(np.degrees(ctl.q) - [0, -30, -30, 0, 60, 0]))) < 1e-4  # fp32 angles
        x, y, z, roll, pitch, yaw = ctl.tcp_pose()
        t0 = ctl.time
        assert arm.set_position(x + 50, y, z, roll, pitch, yaw, is_radian=True, speed=200, mvacc=2000,
                                wait=False) == 0
        assert wait_for(lambda: ctl.state == 1, 5)
        assert wait_for(lambda: ctl.state == 2, 10)
        assert ctl.time - t0 > 50.0 / 50.0  # 50 mm at no more than 50 mm/s
        assert arm.set_reduced_mode(False) == 0
        assert arm.get_reduced_mode() == (0, 0)


def test_reduced_settings_are_saved_with_register_40(tmp_path: Any) -> None:
    emu = Emulator(6, firmware="2.7.103", config_dir=tmp_path)
    call(emu, 47, speed=120.0)
    call(emu, 48, speed=0.5)
    call(emu, 58, joint_ranges=(-1.0, 1.0) + (-2.0, 2.0) + (-3.0, 0.1) + (-6.0, 6.0) + (-1.5, 3.0)
         + (-6.0, 6.0) + (0.0, 0.0))
    call(emu, 60, on=1)
    call(emu, 50, on=1)
    saved = call(emu, 53)[2]
    restarted = Emulator(6, firmware="2.7.103", config_dir=tmp_path)
    assert call(restarted, 53)[2] != saved  # not saved yet: defaults
    call(emu, 40)
    restarted = Emulator(6, firmware="2.7.103", config_dir=tmp_path)
    assert call(restarted, 53)[2] == saved
    assert call(restarted, 49)[1] == {"on": 1}


def test_reduced_tcp_speed_caps_cartesian_velocity_and_online_targets() -> None:
    emu = _emu()
    ready(emu)
    ctl = emu.controller
    ctl.q = POSE_Q.copy()
    call(emu, 47, speed=25.0)
    call(emu, 50, on=1)
    ready(emu, mode=5)
    call(emu, 82, speeds=(60.0, 0, 0, 0, 0, 0), is_tool_coord=0, duration=1.0)
    assert _peak_tcp_speed(emu, 1.5) == pytest.approx(25.0, rel=1e-6)
    ready(emu, mode=7)
    pose = ctl.tcp_pose().copy()
    pose[1] += 40.0
    call(emu, 21, pose=tuple(pose), speed=200.0, acc=2000.0, mvtime=0.0, radius=-1.0, coord=0,
         is_axis_angle=0, only_check_type=0, motion_type=0)
    assert _peak_tcp_speed(emu, 3.0) == pytest.approx(25.0, rel=1e-3)
    assert ctl.tcp_pose()[1] == pytest.approx(pose[1], abs=1e-4)


def test_register_24_one_byte_form_still_works_in_mode_6() -> None:
    emu = _emu()
    ready(emu, mode=6)
    state, _, _ = call(emu, 24, tau_or_i=1)
    assert not any(bits(state)) and emu.controller.settings.report_current
