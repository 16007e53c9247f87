"""State machine, modes, command buffer and replies of the controller (issue 2 item 5, issue 4
items 2-4), driven in process with the stepped clock."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import bits, call, joints7, ready

from xarm_emu.controller.controller import BUFFER_CAPACITY
from xarm_emu.controller.emulator import Emulator


@pytest.fixture
def emu() -> Emulator:
    return Emulator(6)


def move_joint(emu: Emulator, *q: float, speed: float = 1.0, acc: float = 10.0) -> tuple[int, dict]:
    return call(emu, 23, joints=joints7(*q), speed=speed, acc=acc, mvtime=0.0)


def test_power_on_state_is_stop_and_not_ready(emu: Emulator) -> None:
    state, reply = call(emu, 13)
    assert reply["state"] == 4
    assert bits(state) == (False, False, True)


def test_start_sequence_reaches_sleep_and_clears_not_ready(emu: Emulator) -> None:
    # Enabling and setting the mode are system resets: the manual's replies carry 0x10.
    assert call(emu, 11, joint=8, enable=1)[0] == 0x10
    assert call(emu, 13)[1]["state"] == 5
    assert call(emu, 19, mode=0)[0] == 0x10
    assert call(emu, 12, state=0)[0] == 0x00
    assert call(emu, 13)[1]["state"] == 2


def test_queued_motion_reply_carries_buffer_count_and_runs(emu: Emulator) -> None:
    ready(emu)
    state, reply = move_joint(emu, 0.5)
    assert state == 0 and reply["cmdnum"] == 1
    state, reply = move_joint(emu, 0.0)
    assert reply["cmdnum"] == 2
    assert call(emu, 14)[1]["cmdnum"] == 2
    assert call(emu, 13)[1]["state"] == 1
    emu.advance(0.3)
    assert 0.0 < emu.controller.q[0] < 0.5
    emu.advance(5.0)
    assert call(emu, 14)[1]["cmdnum"] == 0
    assert call(emu, 13)[1]["state"] == 2
    assert emu.controller.q[0] == pytest.approx(0.0, abs=1e-9)


def test_motion_refused_when_not_ready_and_nothing_queued(emu: Emulator) -> None:
    state, reply = move_joint(emu, 0.5)  # power-on state 4
    assert bits(state)[2] and reply["cmdnum"] == 0
    emu.advance(0.5)
    assert np.all(emu.controller.q == 0.0)


def test_suspend_pauses_on_path_and_resume_continues(emu: Emulator) -> None:
    ready(emu)
    move_joint(emu, 1.0, speed=1.0, acc=10.0)
    emu.advance(0.4)
    call(emu, 12, state=3)
    emu.advance(0.5)
    assert call(emu, 13)[1]["state"] == 3
    paused = emu.controller.q.copy()
    emu.advance(0.5)
    np.testing.assert_array_equal(emu.controller.q, paused)  # at rest while suspended
    assert call(emu, 14)[1]["cmdnum"] == 1
    call(emu, 12, state=0)
    emu.advance(3.0)
    assert emu.controller.q[0] == pytest.approx(1.0, abs=1e-9)
    assert call(emu, 13)[1]["state"] == 2


def test_stop_clears_buffer_and_needs_set_state_0(emu: Emulator) -> None:
    ready(emu)
    move_joint(emu, 1.0)
    move_joint(emu, -1.0)
    emu.advance(0.3)
    call(emu, 12, state=4)
    assert call(emu, 14)[1]["cmdnum"] == 0  # discarded at once, while the arm comes to rest
    emu.advance(0.5)
    assert call(emu, 14)[1]["cmdnum"] == 0
    assert call(emu, 13)[1]["state"] == 4
    stopped = emu.controller.q.copy()
    assert 0.0 < stopped[0] < 1.0
    state, reply = move_joint(emu, 0.0)
    assert bits(state)[2] and reply["cmdnum"] == 0
    call(emu, 12, state=0)
    state, reply = move_joint(emu, 0.0)
    assert state == 0 and reply["cmdnum"] == 1


@pytest.mark.parametrize("code,values", [
    (35, {"pose": (0.0, 0.0, 50.0, 0.0, 0.0, 0.0)}),
    (37, {"sensitivity": 2}),
    (38, {"sensitivity": 2}),
    (19, {"mode": 0}),
    (11, {"joint": 8, "enable": 1}),
])
def test_system_reset_commands_end_motion_and_clear_buffer(emu: Emulator, code: int, values: dict) -> None:
    ready(emu)
    move_joint(emu, 1.0)
    move_joint(emu, 0.0)
    emu.advance(0.2)
    state, _ = call(emu, code, **values)
    assert bits(state)[2]  # 0x10 after a system reset
    assert call(emu, 13)[1]["state"] == 5
    assert call(emu, 14)[1]["cmdnum"] == 0
    q = emu.controller.q.copy()
    emu.advance(0.2)
    np.testing.assert_array_equal(emu.controller.q, q)


def test_unknown_register_gives_warning_13_and_clean_warning_clears(emu: Emulator) -> None:
    state, reply = emu.handle(200, b"")
    assert bits(state)[1] and reply == b""
    assert call(emu, 15)[1] == {"error": 0, "warning": 13}
    assert call(emu, 17)[0] & 0x20 == 0
    assert call(emu, 15)[1] == {"error": 0, "warning": 0}


def test_wrong_length_gives_warning_12(emu: Emulator) -> None:
    state, _ = emu.handle(23, b"\x00" * 39)
    assert bits(state)[1]
    assert call(emu, 15)[1]["warning"] == 12


@pytest.mark.parametrize("speed,acc", [(math.nan, 10.0), (1.0, -1.0), (4.0, 10.0), (0.5, math.inf),
                                       (0.0, 1.0)])
def test_bad_joint_speeds_refused_with_warning_12(emu: Emulator, speed: float, acc: float) -> None:
    ready(emu)
    state, reply = move_joint(emu, 0.5, speed=speed, acc=acc)
    assert bits(state)[1] and reply["cmdnum"] == 0
    assert call(emu, 15)[1]["warning"] == 12
    emu.advance(0.3)
    assert np.all(emu.controller.q == 0.0)


def test_speed_setter_outside_table_1_2_changes_nothing(emu: Emulator) -> None:
    before = emu.controller.settings.tcp_jerk
    state, _ = call(emu, 31, jerk=20000.0)
    assert bits(state)[1]
    assert emu.controller.settings.tcp_jerk == before
    state, _ = call(emu, 31, jerk=2000.0)
    assert emu.controller.settings.tcp_jerk == 2000.0


def test_joint_target_beyond_limit_is_error_c23(emu: Emulator) -> None:
    ready(emu)
    state, _ = move_joint(emu, 0.0, 2.5)  # J2 upper limit is 2.0944 rad
    assert bits(state)[0]
    assert call(emu, 15)[1]["error"] == 23
    assert call(emu, 13)[1]["state"] == 4
    # recovery sequence of section 3.3: clean error, enable, set state 0
    call(emu, 16)
    call(emu, 11, joint=8, enable=1)
    call(emu, 12, state=0)
    assert call(emu, 13)[1]["state"] == 2
    assert call(emu, 15)[1]["error"] == 0


def test_error_stops_within_one_period_and_discards_buffer(emu: Emulator) -> None:
    ready(emu)
    move_joint(emu, 1.0)
    move_joint(emu, 0.0)
    emu.advance(0.3)
    emu.inject_error(31)
    q = emu.controller.q.copy()
    emu.step()
    np.testing.assert_array_equal(emu.controller.q, q)
    assert call(emu, 14)[1]["cmdnum"] == 0
    state, _ = call(emu, 13)
    assert state & 0x40 and emu.controller.state == 4
    state, reply = move_joint(emu, 0.0)
    assert bits(state)[0] and reply["cmdnum"] == 0


def test_estop_needs_re_enable_after_clearing(emu: Emulator) -> None:
    ready(emu)
    emu.inject_estop()
    call(emu, 16)
    call(emu, 12, state=0)
    state, _ = move_joint(emu, 0.3)
    assert bits(state)[2]  # joints disabled until motion_enable
    call(emu, 11, joint=8, enable=1)
    call(emu, 12, state=0)
    state, _ = move_joint(emu, 0.3)
    assert state == 0


def test_buffer_capacity_gives_warning_11(emu: Emulator) -> None:
    ready(emu)
    for _ in range(BUFFER_CAPACITY):
        state, _ = call(emu, 26, seconds=0.01)
        assert state == 0
    state, reply = call(emu, 26, seconds=0.01)
    assert bits(state)[1] and reply["cmdnum"] == BUFFER_CAPACITY
    assert call(emu, 15)[1]["warning"] == 11


def test_modes_refuse_commands_that_do_not_fit(emu: Emulator) -> None:
    ready(emu)
    call(emu, 19, mode=1)
    call(emu, 12, state=0)
    state, reply = move_joint(emu, 0.5)  # queued motion in servo mode
    assert bits(state)[2] and reply["cmdnum"] == 0
    state, _ = call(emu, 29, joints=joints7(0.01), speed=0.0, acc=0.0, mvtime=0.0)
    assert state == 0
    call(emu, 19, mode=0)
    call(emu, 12, state=0)
    state, _ = call(emu, 29, joints=joints7(0.01), speed=0.0, acc=0.0, mvtime=0.0)
    assert bits(state)[2]
    state, _ = call(emu, 19, mode=3)  # Cartesian teaching: not available
    assert bits(state)[1] and call(emu, 15)[1]["warning"] == 12
    assert emu.controller.mode == 0


def test_joint_teaching_mode_moves_by_hand_and_refuses_motion(emu: Emulator) -> None:
    ready(emu)
    call(emu, 19, mode=2)
    call(emu, 12, state=0)
    emu.controller.teach_move([0.2, 0.1, -0.1, 0.0, 0.0, 0.0])
    assert call(emu, 42)[1]["joints"][:3] == pytest.approx((0.2, 0.1, -0.1), abs=1e-7)
    state, reply = move_joint(emu, 0.5)
    assert bits(state)[2] and reply["cmdnum"] == 0


def test_servo_mode_follows_each_target_within_one_period(emu: Emulator) -> None:
    ready(emu)
    call(emu, 19, mode=1)
    call(emu, 12, state=0)
    t = 0.0
    for _ in range(250):
        t += 0.004
        target = 0.3 * math.sin(2 * math.pi * 0.5 * t)
        call(emu, 29, joints=joints7(target), speed=0.0, acc=0.0, mvtime=0.0)
        emu.step()
        assert emu.controller.q[0] == pytest.approx(target, abs=1e-7)  # float32 on the wire


def test_version_string_and_robot_sn() -> None:
    for dof, prefix in ((5, "5,5,"), (6, "6,6,"), (7, "7,7,")):
        emu = Emulator(dof)
        version = call(emu, 1)[1]["version"]
        assert version.startswith(prefix) and version.endswith(",v1.6.0")
        robot_sn, box_sn = version.split(",")[2:4]
        assert robot_sn[:2].isalpha() and robot_sn[2:].isdigit() and len(robot_sn) == 6
        assert box_sn[:2].isalpha() and box_sn[2:].isdigit() and len(box_sn) == 6
        serials = call(emu, 2)[1]["serials"]
        assert serials.split(b"\0")[:2] == [robot_sn.encode(), box_sn.encode()]


def test_poses_are_computed_from_joints(emu: Emulator) -> None:
    ready(emu)
    pose0 = call(emu, 41)[1]["pose"]
    assert pose0[:3] == pytest.approx((207.0, 0.0, 112.0), abs=1e-3)
    move_joint(emu, math.pi / 3)
    emu.advance(3.0)
    pose = call(emu, 41)[1]["pose"]
    assert pose[:3] == pytest.approx((103.5, 179.2672, 112.0), abs=1e-3)
    assert pose[5] == pytest.approx(math.pi / 3, abs=1e-5)
    snap = emu.snapshot()
    assert snap.pose[:3] == pytest.approx(pose[:3], abs=1e-3)
    assert snap.joints[0] == pytest.approx(math.pi / 3, abs=1e-6)


def test_brake_engaged_joint_cannot_move_until_released(emu: Emulator) -> None:
    ready(emu)
    call(emu, 18, joint=2, enable=1)  # brake on for joint 2 (a system reset)
    call(emu, 12, state=0)
    state, reply = move_joint(emu, 0.3)
    assert bits(state)[2] and reply["cmdnum"] == 0
    assert emu.snapshot().brake_bits == 0b111101
    call(emu, 11, joint=8, enable=1)  # enabling releases the brakes
    call(emu, 12, state=0)
    assert move_joint(emu, 0.3)[0] == 0


def test_virtual_robot_mode_keeps_the_physical_arm(emu: Emulator) -> None:
    ready(emu)
    call(emu, 79, on=1)
    assert emu.snapshot().simulation
    move_joint(emu, 0.5)
    emu.advance(3.0)
    assert emu.controller.q[0] == pytest.approx(0.5, abs=1e-7)
    assert emu.controller.physical_joints[0] == 0.0
    call(emu, 79, on=0)
    assert emu.controller.q[0] == 0.0 and not emu.snapshot().simulation


def test_suspend_of_a_fast_move_decelerates_within_the_acceleration_limit(emu: Emulator) -> None:
    ready(emu)
    call(emu, 34, maxacc=5.0)
    move_joint(emu, 3.0, speed=math.pi, acc=5.0)
    emu.advance(0.9)  # at full speed
    qs = []
    call(emu, 12, state=3)
    for _ in range(400):
        emu.step()
        qs.append(emu.controller.q[0])
    v = np.diff(qs) / 0.004
    a = np.diff(v) / 0.004
    assert abs(v[-1]) < 1e-9
    assert np.max(np.abs(a)) <= 5.0 * 1.02


@pytest.mark.parametrize("code,values,expected", [
    (30, {"pose": (207.0, 0.0, 100.0, math.pi, 0.0, 0.0), "coord": 0.0}, (207.0, 0.0, 100.0)),
    (30, {"pose": (0.0, 0.0, 10.0, 0.0, 0.0, 0.0), "coord": 1.0}, (207.0, 0.0, 102.0)),  # tool z is down
    (93, {"pose": (5.0, 0.0, 0.0, 0.0, 0.0, 0.0), "coord": 0.0, "relative": 1}, (212.0, 0.0, 112.0)),
    (93, {"pose": (5.0, 0.0, 0.0, 0.0, 0.0, 0.0), "coord": 1.0, "relative": 0}, (212.0, 0.0, 112.0)),
])
def test_servo_cartesian_targets_in_base_tool_and_relative_frames(emu: Emulator, code: int, values: dict,
                                                                  expected: tuple[float, ...]) -> None:
    ready(emu)
    call(emu, 19, mode=1)
    call(emu, 12, state=0)
    state, _ = call(emu, code, speed=0.0, acc=0.0, **values)
    assert state == 0
    emu.advance(0.5)
    assert tuple(emu.controller.tcp_pose()[:3]) == pytest.approx(expected, abs=1e-3)


def test_gripper_error_shows_in_register_106_and_the_rich_report(emu: Emulator) -> None:
    emu.inject_gripper_error(11)
    state, reply = emu.handle(106, b"")
    assert reply[14:16] == bytes((1, 11)) and reply[:14] == bytes(14)
    assert tuple(emu.snapshot().tgpio_code) == (1, 11)
