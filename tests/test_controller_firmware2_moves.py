"""The later forms of the motion registers (firmware >= 1.11.100 and 2.4.101), in process: register
21's 43/44-byte common form (blend radius, frame, axis-angle, only-check, motion type) and 27 at 67
bytes with the 3-byte reply; the only-check byte of 23/24/25 (no motion, the check result in the
reply); +inf as "keep this component" in 21 and 23; the manual's forms under firmware 1.6.0."""

from __future__ import annotations

import math
import struct
from typing import Any

import numpy as np
import pytest

from xarm_emu.controller.core.interface import C_JOINT_LIMIT, C_SELF_COLLISION
from xarm_emu.controller.emulator import Emulator
from xarm_emu.model import rotations as rot
from xarm_emu.protocol.frame import STATE_WARNING

V2 = "2.7.103"
START = (300.0, 0.0, 200.0, math.pi, 0.0, 0.0)


def send(emu: Emulator, code: int, **values: Any) -> tuple[int, bytes]:
    """Encode ``values`` with the register table of the emulator's firmware and handle them."""
    return emu.handle(code, emu.controller.registers[code].request.encode(values))


def ready(firmware: str = V2) -> Emulator:
    emu = Emulator(6, firmware=firmware)
    for code, params in ((11, bytes([8, 1])), (19, bytes([0])), (12, bytes([0]))):
        emu.handle(code, params)
    assert emu.controller.state == 2
    return emu


def settle(emu: Emulator, seconds: float = 8.0) -> None:
    emu.advance(seconds)
    assert emu.controller.state == 2 and emu.controller.error_code == 0


def pose(emu: Emulator) -> np.ndarray:
    return np.asarray(emu.controller.tcp_pose())


def line(emu: Emulator, p: tuple[float, ...], *, coord: int = 0, aa: int = 0, check: int = 0,
         radius: float = -1.0) -> tuple[int, bytes]:
    return send(emu, 21, pose=p, speed=200.0, acc=2000.0, mvtime=0.0, radius=radius, coord=coord,
                is_axis_angle=aa, only_check_type=check)


def joint(emu: Emulator, q: tuple[float, ...], *, check: int = 0) -> tuple[int, bytes]:
    return send(emu, 23, joints=tuple(q) + (0.0,) * (7 - len(q)), speed=1.0, acc=10.0, mvtime=0.0,
                only_check_type=check)


def at_start(firmware: str = V2) -> Emulator:
    emu = ready(firmware)
    status, reply = line(emu, START) if firmware == V2 else send(
        emu, 21, pose=START, speed=200.0, acc=2000.0, mvtime=0.0)
    assert status == 0
    settle(emu)
    np.testing.assert_allclose(pose(emu)[:3], START[:3], atol=1e-3)
    return emu


def test_common_line_moves_to_the_pose_and_replies_three_bytes() -> None:
    emu = ready()
    status, reply = line(emu, START)
    assert status == 0 and reply == struct.pack(">HB", 1, 0)
    settle(emu)
    np.testing.assert_allclose(pose(emu)[:3], START[:3], atol=1e-3)
    assert abs(abs(pose(emu)[3]) - math.pi) < 1e-4


def test_common_line_in_the_tool_frame_moves_along_the_tool_axes() -> None:
    emu = at_start()
    line(emu, (0.0, 0.0, 30.0, 0.0, 0.0, 0.0), coord=1)  # tool z points down (roll pi)
    settle(emu)
    np.testing.assert_allclose(pose(emu)[:3], (300.0, 0.0, 170.0), atol=1e-3)


def test_common_line_with_an_axis_angle_pose() -> None:
    emu = at_start()
    target_rpy = (280.0, 40.0, 220.0, math.pi, 0.0, 0.3)
    aa = rot.matrix_to_pose_aa(rot.pose_to_matrix(list(target_rpy)))
    line(emu, tuple(float(x) for x in aa), aa=1)
    settle(emu)
    T = emu.controller.tcp_matrix()
    np.testing.assert_allclose(T, rot.pose_to_matrix(list(target_rpy)), atol=1e-4)


def test_plus_inf_keeps_pose_components_of_register_21() -> None:
    emu = at_start()
    inf = math.inf
    status, _ = line(emu, (inf, 60.0, inf, inf, inf, inf))
    assert status == 0
    settle(emu)
    np.testing.assert_allclose(pose(emu)[:3], (300.0, 60.0, 200.0), atol=1e-3)
    assert abs(abs(pose(emu)[3]) - math.pi) < 1e-4


def test_plus_inf_keeps_joints_of_register_23() -> None:
    emu = ready()
    joint(emu, (0.3, 0.2, -0.4, 0.0, 0.5, 0.0))
    settle(emu)
    status, reply = joint(emu, (math.inf, math.inf, -0.6, math.inf, math.inf, math.inf))
    assert status == 0 and reply == struct.pack(">HB", 1, 0)
    settle(emu)
    np.testing.assert_allclose(emu.joints, (0.3, 0.2, -0.6, 0.0, 0.5, 0.0), atol=1e-6)


def test_nan_and_minus_inf_are_still_refused() -> None:
    emu = ready()
    for bad in (math.nan, -math.inf):
        status, _ = joint(emu, (bad, 0.0, 0.0, 0.0, 0.0, 0.0))
        assert status & STATE_WARNING and emu.controller.warning_code == 12
        emu.handle(17, b"")
    assert emu.controller.executor.cmdnum == 0


def test_only_check_moves_nothing_and_replies_the_result() -> None:
    emu = ready()
    status, reply = joint(emu, (0.5, 0.0, -0.5, 0.0, 0.5, 0.0), check=1)
    assert status == 0 and reply == struct.pack(">HB", 0, 0)
    _, reply = joint(emu, (0.0, 0.0, math.radians(10), 0.0, 0.0, 0.0), check=1)  # forearm into the base
    assert reply == struct.pack(">HB", 0, C_SELF_COLLISION)
    _, reply = joint(emu, (0.0, 0.0, 0.0, 0.0, -3.0, 0.0), check=1)
    assert reply == struct.pack(">HB", 0, C_JOINT_LIMIT)
    emu.advance(1.0)
    assert emu.controller.state == 2 and not emu.joints.any() and emu.controller.error_code == 0


def test_only_check_of_a_line_into_the_arm_reports_the_collision() -> None:
    emu = at_start()
    status, reply = line(emu, (300.0, 0.0, 150.0, math.pi, 0.0, 0.0), check=1)
    assert status == 0 and reply == struct.pack(">HB", 0, 0)
    _, reply = line(emu, (2000.0, 0.0, 200.0, math.pi, 0.0, 0.0), check=1)  # out of reach
    assert reply[2] != 0
    emu.advance(1.0)
    np.testing.assert_allclose(pose(emu)[:3], START[:3], atol=1e-3)


def test_only_check_types_2_and_3_start_where_the_previous_check_ended() -> None:
    emu = ready()
    collide = (0.0, 0.0, math.radians(10), 0.0, 0.0, 0.0)
    half = (0.0, 0.0, math.radians(10) / 2, 0.0, 0.0, 0.0)
    # From the actual joints (type 1) the path to J3 = 5 deg is free, and that is where the check ends.
    assert joint(emu, half, check=1)[1][2] == 0
    # Type 3 continues from there: the same joint values are now "no motion", still free of contact.
    assert joint(emu, half, check=3)[1][2] == 0
    # The colliding target fails from either start; type 2 then returns to the actual joints.
    assert joint(emu, collide, check=2)[1][2] == C_SELF_COLLISION
    assert emu.controller.data.check_q is None
    assert not emu.joints.any()


def test_only_check_of_go_home_and_of_the_blended_joint_form() -> None:
    emu = ready()
    joint(emu, (0.4, 0.0, -0.4, 0.0, 0.4, 0.0))
    settle(emu)
    status, reply = send(emu, 25, speed=1.0, acc=10.0, mvtime=0.0, only_check_type=1)
    assert status == 0 and reply == struct.pack(">HB", 0, 0)
    status, reply = send(emu, 24, joints=(0.0, 0.0, math.radians(10), 0.0, 0.0, 0.0, 0.0), speed=1.0,
                         acc=10.0, radius=10.0, only_check_type=1)
    assert status == 0 and reply == struct.pack(">HB", 0, C_SELF_COLLISION)
    emu.advance(1.0)
    np.testing.assert_allclose(emu.joints, (0.4, 0.0, -0.4, 0.0, 0.4, 0.0), atol=1e-6)
    send(emu, 25, speed=1.0, acc=10.0, mvtime=0.0)
    settle(emu)
    assert np.allclose(emu.joints, 0.0, atol=1e-6)


def test_circle_at_67_bytes_ends_on_its_arc() -> None:
    emu = at_start()
    p1 = (300.0, 50.0, 250.0, math.pi, 0.0, 0.0)
    p2 = (300.0, 100.0, 200.0, math.pi, 0.0, 0.0)
    params = emu.controller.registers[27].request.encode(
        pose1=p1, pose2=p2, speed=100.0, acc=1000.0, mvtime=0.0, percent=50.0, coord=0, is_axis_angle=0,
        only_check_type=0)
    assert len(params) == 67
    status, reply = emu.handle(27, params)
    assert status == 0 and reply == struct.pack(">HB", 1, 0)
    settle(emu, 10.0)
    np.testing.assert_allclose(pose(emu)[:3], p2[:3], atol=1e-2)  # half the circle through START and p1


@pytest.mark.parametrize("code", [21, 23])
def test_firmware_1_6_0_keeps_the_manual_forms(code: int) -> None:
    emu = ready("1.6.0")
    args = (START if code == 21 else (0.2,) + (0.0,) * 6) + (1.0, 10.0, 0.0)
    status, reply = emu.handle(code, struct.pack(f"<{len(args)}f", *args))
    assert status == 0 and reply == struct.pack(">H", 1)  # the manual's 2-byte reply
    emu.handle(12, bytes([4]))
    longer = struct.pack(f"<{len(args) + 1}f", *args, -1.0) + bytes([0, 0, 0])
    status, _ = emu.handle(code, longer)  # the common form is not a 1.6.0 layout
    assert status & STATE_WARNING and emu.controller.warning_code == 12
    emu.handle(17, b"")
    status, _ = emu.handle(code, struct.pack(f"<{len(args)}f", *((math.inf,) + args[1:])))
    assert status & STATE_WARNING and emu.controller.warning_code == 12  # +inf is out of range here


def _off_line(emu: Emulator, target: tuple[float, ...], seconds: float) -> float:
    """Largest distance (mm) of the TCP from the line START -> ``target`` while a move runs."""
    a, b = np.asarray(START[:3]), np.asarray(target[:3])
    u = (b - a) / np.linalg.norm(b - a)
    worst = 0.0
    for _ in range(round(seconds / 0.05)):
        emu.advance(0.05)
        d = pose(emu)[:3] - a
        worst = max(worst, float(np.linalg.norm(d - (d @ u) * u)))
    return worst


def test_motion_type_1_is_a_line_where_one_exists_and_2_a_joint_move() -> None:
    target = (300.0, 150.0, 300.0, math.pi, 0.0, 0.0)
    for motion_type, on_line in ((1, True), (2, False)):
        emu = at_start()
        status, _ = send(emu, 21, pose=target, speed=200.0, acc=2000.0, mvtime=0.0, radius=-1.0, coord=0,
                         is_axis_angle=0, only_check_type=0, motion_type=motion_type)
        assert status == 0
        worst = _off_line(emu, target, 3.0)
        assert (worst < 1e-3) if on_line else (worst > 1.0)
        settle(emu)
        np.testing.assert_allclose(pose(emu)[:3], target[:3], atol=1e-3)


def test_motion_type_1_falls_back_to_a_joint_move_where_the_line_is_unreachable() -> None:
    target = (-300.0, 0.0, 200.0, math.pi, 0.0, 0.0)  # the line runs through the base's axis
    emu = at_start()
    line(emu, target)
    emu.advance(5.0)
    assert emu.controller.error_code == 21  # motion type 0: the line has no joint solution
    emu = at_start()
    send(emu, 21, pose=target, speed=200.0, acc=2000.0, mvtime=0.0, radius=-1.0, coord=0, is_axis_angle=0,
         only_check_type=0, motion_type=1)
    settle(emu, 15.0)
    np.testing.assert_allclose(pose(emu)[:3], target[:3], atol=1e-3)


def test_set_mode_takes_the_detection_byte() -> None:
    emu = ready()
    assert emu.handle(19, bytes([1, 0])) == (0x10, b"")  # servo mode, then a system reset (state 5)
    assert emu.controller.mode == 1


def test_joint_states_with_three_blocks_is_84_bytes() -> None:
    emu = ready()
    joint(emu, (0.8, 0.0, 0.0, 0.0, 0.0, 0.0))
    emu.advance(0.4)
    _, reply = emu.handle(42, bytes([3]))
    values = struct.unpack("<21f", reply)
    np.testing.assert_allclose(values[:6], emu.joints, atol=1e-6)
    assert values[7] > 0.1 and values[8:14] == (0.0,) * 6  # J1 turns, the others rest
    assert any(values[14:20])  # efforts
