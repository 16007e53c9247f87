"""Relative moves (register 83) and velocity control (registers 81, 82; modes 4 and 5) in process,
on the stepped clock: the bytes the SDK sends, the replies, the refusals (warning 12, reply bit 0x10,
C23) and what the arm does."""

from __future__ import annotations

import math
import struct
from typing import Any

import numpy as np
import pytest
from helpers import bits

from xarm_emu.controller.emulator import Emulator
from xarm_emu.protocol.registers import registers_for

FW = "2.7.103"


def _emu(firmware: str = FW) -> Emulator:
    emu = Emulator(6, firmware=firmware)
    emu.controller.strict = True
    return emu


def call(emu: Emulator, code: int, **values: Any) -> tuple[int, dict[str, Any], bytes]:
    reg = registers_for(emu.firmware)[code]
    state, reply = emu.handle(code, reg.request.encode(values))
    return state, (reg.reply.decode(reply) if reply else {}), reply


def ready(emu: Emulator, mode: int = 0) -> None:
    for code, values in ((11, {"joint": 8, "enable": 1}), (19, {"mode": mode}), (12, {"state": 0})):
        state, _, _ = call(emu, code, **values)
        assert not any(bits(state)[:2])
    assert emu.controller.state == 2 and emu.controller.mode == mode


def relative(emu: Emulator, deltas: tuple[float, ...], joint: int = 0, **extra: Any
             ) -> tuple[int, dict[str, Any], bytes]:
    speed, acc = (1.0, 10.0) if joint else (100.0, 2000.0)
    return call(emu, 83, deltas=tuple(deltas) + (0.0,) * (7 - len(deltas)), speed=speed, acc=acc, mvtime=0.0,
                radius=-1.0, is_joint_motion=joint, is_axis_angle=0, **extra)


def test_the_sdks_bytes_for_set_position_x10_relative_move_the_tcp_10_mm() -> None:
    emu = _emu()
    ready(emu)
    # set_position(x=10, relative=True) on firmware 2.x: 7 deltas, speed 100, acc 2000, mvtime 0,
    # radius -1, then is_joint_motion 0 and is_axis_angle 0 (46 bytes).
    wire = struct.pack("<11f", 10, 0, 0, 0, 0, 0, 0, 100, 2000, 0, -1) + b"\x00\x00"
    start = emu.controller.tcp_pose().copy()
    state, reply = emu.handle(83, wire)
    assert state == 0 and reply == b"\x00\x01\x00"  # buffer count, check result 0 (as register 21)
    emu.advance(2.0)
    assert emu.controller.tcp_pose() - start == pytest.approx([10, 0, 0, 0, 0, 0], abs=1e-6)


def test_plus_inf_in_a_delta_means_unchanged_from_2_4_101() -> None:
    emu = _emu()
    ready(emu)
    start = emu.controller.tcp_pose().copy()
    state, _, _ = relative(emu, (math.inf, 5.0, math.inf, math.inf, math.inf, math.inf))
    assert not any(bits(state))
    emu.advance(2.0)
    assert emu.controller.tcp_pose() - start == pytest.approx([0, 5, 0, 0, 0, 0], abs=1e-6)


def test_plus_inf_is_parameter_abnormal_below_2_4_101() -> None:
    emu = _emu("2.0.102")
    ready(emu)
    state, _, _ = relative(emu, (math.inf, 5.0))
    assert bits(state)[1] and emu.controller.warning_code == 12
    assert emu.controller.executor.cmdnum == 0


@pytest.mark.parametrize("bad", [math.nan, -math.inf, 2e9])
def test_nan_and_huge_deltas_are_refused(bad: float) -> None:
    emu = _emu()
    ready(emu)
    state, _, _ = relative(emu, (bad,))
    assert bits(state)[1] and emu.controller.warning_code == 12
    assert emu.controller.executor.cmdnum == 0


def test_only_check_queues_nothing_and_answers_three_bytes() -> None:
    emu = _emu()
    ready(emu)
    state, values, reply = relative(emu, (10.0,), only_check_type=1)
    assert state == 0 and len(reply) == 3 and values == {"cmdnum": 0, "check_result": 0}
    state, values, reply = relative(emu, (5000.0,), only_check_type=1)  # far out of reach
    assert len(reply) == 3 and values["check_result"] != 0
    state, values, reply = relative(emu, (0, 0, 0, 0, -3.0), joint=1, only_check_type=1)  # J5 beyond limit
    assert values["check_result"] != 0
    emu.advance(0.5)
    assert emu.controller.q == pytest.approx(np.zeros(6), abs=1e-12)


def test_joint_deltas_add_to_where_the_previous_move_ended() -> None:
    emu = _emu()
    ready(emu)
    relative(emu, (0.2, -0.1), joint=1)
    relative(emu, (0.1, 0.0, -0.3), joint=1)
    assert emu.controller.executor.cmdnum == 2
    emu.advance(4.0)
    assert emu.controller.q == pytest.approx([0.3, -0.1, -0.3, 0, 0, 0], abs=1e-7)


def test_a_queued_joint_delta_that_ends_beyond_the_limits_stops_with_c23() -> None:
    emu = _emu()
    emu.controller.strict = False
    ready(emu)
    relative(emu, (0, 0, 0, 0, -1.0), joint=1)
    relative(emu, (0, 0, 0, 0, -1.0), joint=1)  # J5 would end at -2.0 rad, below its limit
    emu.advance(6.0)
    assert emu.controller.error_code == 23 and emu.controller.state == 4
    assert emu.controller.q[4] == pytest.approx(-1.0, abs=1e-9)


def test_relative_moves_refused_while_not_in_position_mode() -> None:
    emu = _emu()
    ready(emu, mode=4)
    state, _, _ = relative(emu, (10.0,))
    assert bits(state)[2] and emu.controller.executor.cmdnum == 0


def jointv(emu: Emulator, speeds: tuple[float, ...], sync: int = 1, **extra: Any) -> int:
    return call(emu, 81, speeds=tuple(speeds) + (0.0,) * (7 - len(speeds)), is_sync=sync, **extra)[0]


def test_joint_velocity_reaches_the_commanded_speed_and_holds_it() -> None:
    emu = _emu()
    ready(emu, mode=4)
    assert jointv(emu, (0.2, -0.1, 0.0, 0.3)) == 0
    emu.advance(0.5)  # the ramp is over
    ctl = emu.controller
    assert ctl.state == 1
    q0, t0 = ctl.q.copy(), ctl.time
    emu.advance(1.0)
    v = (ctl.q - q0) / (ctl.time - t0)
    assert v == pytest.approx([0.2, -0.1, 0.0, 0.3, 0, 0], rel=1e-6, abs=1e-12)  # fp32 speeds


def test_the_ramp_is_jerk_and_acceleration_limited() -> None:
    emu = _emu()
    ready(emu, mode=4)
    ctl = emu.controller
    jointv(emu, (2.0,))
    acc = []
    for _ in range(200):
        emu.step()
        acc.append(ctl.qdd[0])
    acc_a = np.asarray(acc)
    assert float(np.max(np.abs(acc_a))) <= ctl.settings.joint_maxacc * (1 + 1e-6)
    jerk = np.diff(acc_a) / ctl.period
    assert float(np.max(np.abs(jerk))) <= ctl.settings.joint_jerk * 1.05
    assert ctl.qd[0] == pytest.approx(2.0, abs=1e-9)


def test_duration_zero_keeps_the_velocity_and_a_new_command_replaces_it() -> None:
    emu = _emu()
    ready(emu, mode=4)
    ctl = emu.controller
    jointv(emu, (0.1,), duration=0.0)
    emu.advance(3.0)
    assert ctl.qd[0] == pytest.approx(0.1, rel=1e-6)
    jointv(emu, (0.0,))
    emu.advance(0.5)
    assert ctl.qd[0] == 0.0 and ctl.state == 2


def test_duration_ends_the_motion() -> None:
    emu = _emu()
    ready(emu, mode=4)
    ctl = emu.controller
    jointv(emu, (0.1,), duration=1.0)
    emu.advance(1.0)
    assert ctl.state == 1
    emu.advance(0.5)
    assert ctl.state == 2 and ctl.qd[0] == 0.0
    assert ctl.q[0] == pytest.approx(0.1, abs=0.005)


def test_a_stop_drops_the_commanded_velocity() -> None:
    emu = _emu()
    ready(emu, mode=4)
    ctl = emu.controller
    jointv(emu, (0.3,))
    emu.advance(0.5)
    call(emu, 12, state=4)
    emu.advance(0.2)
    q = ctl.q.copy()
    call(emu, 12, state=0)
    emu.advance(0.5)
    assert ctl.q == pytest.approx(q, abs=1e-12) and ctl.state == 2


@pytest.mark.parametrize("values", [
    {"speeds": (4.0, 0, 0, 0, 0, 0, 0), "is_sync": 1},  # above pi rad/s
    {"speeds": (0.1, 0, 0, 0, 0, 0, 0), "is_sync": 2},
    {"speeds": (math.nan, 0, 0, 0, 0, 0, 0), "is_sync": 1},
    {"speeds": (0.1, 0, 0, 0, 0, 0, 0), "is_sync": 1, "duration": -1.0},
])
def test_bad_joint_velocities_are_warning_12(values: dict[str, Any]) -> None:
    emu = _emu()
    ready(emu, mode=4)
    state, _, _ = call(emu, 81, **values)
    assert bits(state)[1] and emu.controller.warning_code == 12
    emu.advance(0.2)
    assert emu.controller.q == pytest.approx(np.zeros(6), abs=1e-12)


def test_velocity_commands_in_the_wrong_mode_are_not_ready() -> None:
    emu = _emu()
    ready(emu, mode=0)
    assert bits(jointv(emu, (0.1,)))[2]
    ready(emu, mode=4)
    state, _, _ = call(emu, 82, speeds=(10.0, 0, 0, 0, 0, 0), is_tool_coord=0)
    assert bits(state)[2]
    emu.advance(0.3)
    assert emu.controller.q == pytest.approx(np.zeros(6), abs=1e-12)


def _cartesian_ready(emu: Emulator) -> None:
    ready(emu)
    emu.controller.q = np.array([0.0, -0.5, -0.5, 0.0, 1.0, 0.0])
    ready(emu, mode=5)


def test_cartesian_velocity_in_the_tool_frame_moves_along_the_tool_axes() -> None:
    emu = _emu()
    _cartesian_ready(emu)
    ctl = emu.controller
    T0 = ctl.tcp_matrix().copy()
    call(emu, 82, speeds=(0.0, 0.0, 20.0, 0, 0, 0), is_tool_coord=1, duration=1.0)
    emu.advance(1.5)
    T1 = ctl.tcp_matrix()
    moved = T1[:3, 3] - T0[:3, 3]
    along = float(moved @ T0[:3, 2])
    assert 18.0 < along < 20.0
    assert np.linalg.norm(moved - along * T0[:3, 2]) < 1e-3
    assert ctl.state == 2


def test_cartesian_rotation_keeps_the_tcp_position() -> None:
    emu = _emu()
    _cartesian_ready(emu)
    ctl = emu.controller
    p0 = ctl.tcp_pose().copy()
    call(emu, 82, speeds=(0.0, 0.0, 0.0, 0.0, 0.0, 0.2), is_tool_coord=0, duration=1.0)
    emu.advance(1.5)
    p1 = ctl.tcp_pose()
    assert p1[:3] == pytest.approx(p0[:3], abs=1e-3)
    assert p1[5] - p0[5] == pytest.approx(0.2, abs=0.02)


def test_cartesian_velocity_out_of_reach_stops_the_arm_without_an_error() -> None:
    emu = _emu()
    _cartesian_ready(emu)
    ctl = emu.controller
    call(emu, 82, speeds=(500.0, 0, 0, 0, 0, 0), is_tool_coord=0)
    emu.advance(6.0)
    assert ctl.state == 2 and ctl.error_code == 0
    x = ctl.tcp_pose()[0]
    emu.advance(0.5)
    assert ctl.tcp_pose()[0] == pytest.approx(x, abs=1e-9)


# ---- modes 6 and 7: online trajectory planning ------------------------------------------------------
def joint_target(emu: Emulator, *q: float, speed: float = 1.0, acc: float = 10.0) -> int:
    return call(emu, 23, joints=tuple(q) + (0.0,) * (7 - len(q)), speed=speed, acc=acc, mvtime=0.0)[0]


def _run(emu: Emulator, seconds: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Joints, velocities and accelerations of each control period for ``seconds``."""
    ctl = emu.controller
    qs, qds, qdds = [], [], []
    for _ in range(round(seconds / ctl.period)):
        emu.step()
        qs.append(ctl.q.copy())
        qds.append(ctl.qd.copy())
        qdds.append(ctl.qdd.copy())
    return np.asarray(qs), np.asarray(qds), np.asarray(qdds)


def test_mode_6_a_new_target_takes_over_mid_move_without_a_stop() -> None:
    emu = _emu()
    ready(emu, mode=6)
    ctl = emu.controller
    assert joint_target(emu, 1.0) == 0
    assert ctl.executor.cmdnum == 0  # nothing is queued
    q1, qd1, qdd1 = _run(emu, 0.5)
    assert qd1[-1][0] == pytest.approx(1.0) and qdd1[-1][0] == pytest.approx(0.0, abs=1e-9)  # cruising
    assert joint_target(emu, 1.8, 0.3) == 0
    q2, qd2, qdd2 = _run(emu, 4.0)
    # The next control period already follows the new plan: J2 starts to accelerate.
    assert qdd2[0][1] > 0.0
    on_the_way = (q2[:, 0] < 1.6)  # before J1's final deceleration
    assert float(np.min(qd2[on_the_way, 0])) > 0.9  # J1 goes on at its speed: no stop at the switch
    jerk = np.diff(np.concatenate([qdd1, qdd2]), axis=0) / ctl.period
    assert float(np.max(np.abs(jerk))) <= ctl.settings.joint_jerk * (1 + 1e-6)
    acc = np.concatenate([qdd1, qdd2])
    assert float(np.max(np.abs(acc))) <= 10.0 * (1 + 1e-6)
    assert ctl.q == pytest.approx([1.8, 0.3, 0, 0, 0, 0], abs=1e-6)
    assert ctl.state == 2 and not np.any(ctl.qd)


def test_mode_6_reversing_target_decelerates_at_once_and_ends_on_the_last_target() -> None:
    emu = _emu()
    ready(emu, mode=6)
    ctl = emu.controller
    joint_target(emu, 1.0)
    _run(emu, 0.5)
    joint_target(emu, -0.5)
    _, _, qdd = _run(emu, 0.004)
    assert qdd[0][0] < 0.0
    _run(emu, 4.0)
    assert ctl.q[0] == pytest.approx(-0.5, abs=1e-6) and ctl.state == 2


def test_mode_6_refusals() -> None:
    emu = _emu()
    emu.controller.strict = False
    ready(emu, mode=6)
    state = joint_target(emu, 0.1, speed=10.0)  # above pi rad/s
    assert bits(state)[1] and emu.controller.warning_code == 12
    call(emu, 17)
    state = joint_target(emu, 0, 0, 0, 0, -3.0)  # J5 below its limit
    assert bits(state)[0] and emu.controller.error_code == 23
    assert emu.controller.q == pytest.approx(np.zeros(6), abs=1e-12)


def test_modes_6_and_7_are_not_answered_below_firmware_2() -> None:
    emu = _emu("1.11.100")
    ready(emu)
    state, _, _ = call(emu, 19, mode=6)
    assert bits(state)[1] and emu.controller.mode == 0


def line_target(emu: Emulator, pose: np.ndarray, speed: float = 100.0) -> int:
    return call(emu, 21, pose=tuple(pose), speed=speed, acc=1000.0, mvtime=0.0, radius=-1.0, coord=0,
                is_axis_angle=0, only_check_type=0, motion_type=0)[0]


def test_mode_7_a_new_pose_replaces_the_current_one() -> None:
    emu = _emu()
    ready(emu)
    ctl = emu.controller
    ctl.q = np.array([0.0, -0.5, -0.5, 0.0, 1.0, 0.0])
    ready(emu, mode=7)
    p0 = ctl.tcp_pose().copy()
    assert line_target(emu, p0 + [60, 0, 0, 0, 0, 0]) == 0
    emu.advance(0.3)
    mid = ctl.tcp_pose().copy()
    assert 10.0 < mid[0] - p0[0] < 60.0
    last = p0 + [30, 40, -20, 0, 0, 0.2]
    assert line_target(emu, last) == 0
    xs = []
    for _ in range(round(4.0 / ctl.period)):
        emu.step()
        xs.append(ctl.tcp_pose()[0] - p0[0])
    assert max(xs) < 60.0  # the first target is never reached
    assert ctl.tcp_pose() == pytest.approx(last, abs=1e-4) and ctl.state == 2


@pytest.mark.parametrize("mode", [4, 6])
def test_checkpoint_mid_move_replays_the_same_joints(mode: int) -> None:
    emu = _emu()
    ready(emu, mode=mode)
    if mode == 4:
        jointv(emu, (0.3, -0.2), duration=1.0)
    else:
        joint_target(emu, 1.0, -0.5)
    emu.advance(0.3)
    cp = emu.checkpoint()
    first, _, _ = _run(emu, 1.5)
    emu.restore(cp)
    again, _, _ = _run(emu, 1.5)
    assert np.array_equal(first, again)
    assert emu.controller.state == 2


def test_restore_to_before_a_velocity_command_forgets_it() -> None:
    emu = _emu()
    ready(emu, mode=4)
    cp = emu.checkpoint()
    jointv(emu, (0.3,))
    emu.advance(0.5)
    emu.restore(cp)
    emu.advance(0.5)
    assert emu.controller.q == pytest.approx(np.zeros(6), abs=1e-12) and emu.controller.state == 2


@pytest.mark.parametrize("code", [47, 48, 49, 50, 53, 58, 60, 61, 62, 63, 64, 65, 81, 82, 83, 230])
def test_firmware_1_6_0_still_answers_the_2x_motion_registers_with_warning_13(code: int) -> None:
    emu = _emu("1.6.0")
    state, reply = emu.handle(code, b"")
    assert bits(state)[1] and reply == b"" and emu.controller.warning_code == 13
