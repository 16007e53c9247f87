"""The official SDK's kinematics calls against the emulator: the SDK's
``get_forward_kinematics``, ``get_inverse_kinematics``, ``is_joint_limit``, ``get_position_aa``,
``set_tcp_offset`` and ``set_world_offset`` give the manual's answers; bad input never crashes the server.

Manual sections: 2.1.3 registers 41, 42, 43 (IK example), 44 (FK example), 45, 35, 73, 91.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from xarm_emu.server.app import ServerThread

SPEED = 5.0  # nothing here times motion; the factor only shortens settling



@pytest.fixture
def arm_st(shared_sdk_arm) -> tuple[Any, ServerThread]:
    """The module's shared arm, reset to the start state: no error or warning, TCP offset and world
    offset zero (registers 35 and 73), then the start sequence."""
    arm, st = shared_sdk_arm(report_type="real", speed=SPEED)
    assert arm.clean_warn() == 0  # first: a reply carries the warning bit until the warning is gone
    assert arm.clean_error() == 0
    assert arm.set_tcp_offset([0] * 6, wait=False) == 0
    assert arm.set_world_offset([0] * 6, wait=False) == 0
    assert arm.motion_enable(True) == 0
    assert arm.set_mode(0) == 0
    assert arm.set_state(0) == 0
    return arm, st


def test_fk_manual_example(arm_st) -> None:
    """Register 44 example: J1 = 60 degrees gives (103.5, 179.2673, 112) and yaw 60 (manual 2.1.3, 0x2C)."""
    arm, _ = arm_st
    code, pose = arm.get_forward_kinematics([60, 0, 0, 0, 0, 0], False, False)
    assert code == 0
    assert pose[:3] == pytest.approx([103.5, 179.2673, 112.0], abs=1e-3)
    assert abs(abs(pose[3]) - 180.0) < 1e-3
    assert pose[4] == pytest.approx(0.0, abs=1e-4)
    assert pose[5] == pytest.approx(60.0, abs=1e-3)
    # in radians, the yaw is float32(pi/3) and roll is on the seam
    code, rpose = arm.get_forward_kinematics([math.pi / 3, 0, 0, 0, 0, 0], input_is_radian=True,
                                             return_is_radian=True)
    assert code == 0
    assert rpose[5] == pytest.approx(math.pi / 3, abs=1e-6)
    assert abs(abs(rpose[3]) - math.pi) < 1e-6


def test_ik_manual_example(arm_st) -> None:
    """Register 43 example from zero joints: (400, 0, 200, pi, 0, 0) -> the manual's response bytes."""
    arm, st = arm_st
    code, joints = arm.get_inverse_kinematics([400, 0, 200, math.pi, 0, 0], input_is_radian=True,
                                              return_is_radian=True)
    assert code == 0
    expected = [0.0, 0.0817986, -0.6411543, 0.0, 0.5593557, 0.0]
    assert joints[:6] == pytest.approx(expected, abs=3e-7)
    # consistency: FK of the answer, through the SDK, is the asked pose
    code, pose = arm.get_forward_kinematics(joints[:6], input_is_radian=True, return_is_radian=True)
    assert code == 0
    assert pose[:3] == pytest.approx([400.0, 0.0, 200.0], abs=1e-3)
    assert abs(abs(pose[3]) - math.pi) < 1e-5
    # a query never moves the arm
    assert st.call(lambda: st.emulator.joints.tolist()) == [0.0] * 6


def test_ik_degrees_round_trip_from_fk(arm_st) -> None:
    """FK then IK through the SDK in degrees, from the current (zero) seed, near the seed's posture."""
    arm, _ = arm_st
    q = [10.0, -20.0, -30.0, 5.0, 40.0, -15.0]
    code, pose = arm.get_forward_kinematics(q, input_is_radian=False, return_is_radian=False)
    assert code == 0
    code, q_ik = arm.get_inverse_kinematics(pose, input_is_radian=False, return_is_radian=False)
    assert code == 0
    code, pose2 = arm.get_forward_kinematics(q_ik[:6], input_is_radian=False, return_is_radian=False)
    assert pose2[:3] == pytest.approx(pose[:3], abs=1e-2)  # degrees on the wire lose a little to float32


def test_is_joint_limit(arm_st) -> None:
    """Register 45: inside the limits -> False, beyond J2's range (-118..120 degrees) -> True (manual 1.3)."""
    arm, _ = arm_st
    code, limited = arm.is_joint_limit([0, 0, 0, 0, 0, 0], is_radian=False)
    assert (code, limited) == (0, False)
    code, limited = arm.is_joint_limit([0, 0, -100, 0, 0, 0], is_radian=False)
    assert (code, limited) == (0, False)
    code, limited = arm.is_joint_limit([0, 0, math.radians(15), 0, 0, 0], is_radian=True)  # J3 beyond 11 deg
    assert code == 0 and limited is True
    code, limited = arm.is_joint_limit([0, math.radians(125), 0, 0, 0, 0], is_radian=True)
    assert code == 0 and limited is True


def test_position_aa_at_zero(arm_st) -> None:
    """Register 91 at the zero pose: (207, 0, 112) and rotation pi about X (manual 2.1.3, 0x5B)."""
    arm, _ = arm_st
    code, aa = arm.get_position_aa(is_radian=False)
    assert code == 0
    assert aa[:3] == pytest.approx([207.0, 0.0, 112.0], abs=1e-3)
    assert abs(abs(aa[3]) - 180.0) < 1e-3
    assert aa[4:] == pytest.approx([0.0, 0.0], abs=1e-3)
    code, aa_r = arm.get_position_aa(is_radian=True)
    assert abs(np.linalg.norm(aa_r[3:]) - math.pi) < 1e-5


def test_tcp_offset_moves_the_reported_tcp(arm_st) -> None:
    """Register 35: a 100 mm tool along the flange Z axis points down at the zero pose -> z = 12;
    a tool yawed 90 degrees turns the reported yaw (manual 2.1.3, 0x23; TCP = flange . offset)."""
    arm, st = arm_st
    assert arm.set_tcp_offset([0, 0, 100, 0, 0, 0], is_radian=False, wait=False) == 0
    arm.set_state(0)
    code, pose = arm.get_position(is_radian=False)
    assert code == 0
    assert pose[:3] == pytest.approx([207.0, 0.0, 12.0], abs=1e-3)
    # a tool offset along flange X (pointing along base X at the zero pose, since roll = pi flips Y/Z only)
    assert arm.set_tcp_offset([50, 20, 0, 0, 0, 90], is_radian=False, wait=False) == 0
    arm.set_state(0)
    code, pose = arm.get_position(is_radian=False)
    # flange frame at zero: x_f = +X, y_f = -Y, z_f = -Z; tool point (50, 20, 0) -> (257, -20, 112)
    assert pose[:3] == pytest.approx([257.0, -20.0, 112.0], abs=1e-3)
    # R = Rx(pi) Rz(90deg) = Rz(-90deg) Rx(pi): roll +-180, pitch 0, yaw -90
    assert abs(abs(pose[3]) - 180.0) < 1e-3
    assert pose[4] == pytest.approx(0.0, abs=1e-3)
    assert pose[5] == pytest.approx(-90.0, abs=1e-3)
    # FK honours the TCP offset too
    code, fk_pose = arm.get_forward_kinematics([0] * 6, input_is_radian=False, return_is_radian=False)
    assert fk_pose[:3] == pytest.approx([257.0, -20.0, 112.0], abs=1e-3)
    # the emulator's report agrees
    snap = st.call(lambda: st.emulator.snapshot())
    assert snap.tcp_offset[:3] == pytest.approx((50.0, 20.0, 0.0), abs=1e-4)


def test_world_offset_changes_the_reported_pose(arm_st) -> None:
    """Register 73: user frame at (1000, 0, 0) yawed 180 degrees turns (207, 0, 112, 180, 0, 0) into
    (793, 0, 112, 180, 0, 180) (user-manual example; pose seen in the user frame = inv(T_user) . T_tcp)."""
    arm, _ = arm_st
    assert arm.set_world_offset([1000, 0, 0, 0, 0, 180], is_radian=False, wait=False) == 0
    arm.set_state(0)
    code, pose = arm.get_position(is_radian=False)
    assert code == 0
    assert pose[:3] == pytest.approx([793.0, 0.0, 112.0], abs=1e-3)
    assert abs(abs(pose[3]) - 180.0) < 1e-3
    assert pose[4] == pytest.approx(0.0, abs=1e-3)
    assert abs(abs(pose[5]) - 180.0) < 1e-3
    # a pure translation: (100, -50, 20) shifts the pose by its negative
    assert arm.set_world_offset([100, -50, 20, 0, 0, 0], is_radian=False, wait=False) == 0
    arm.set_state(0)
    code, pose = arm.get_position(is_radian=False)
    assert pose[:3] == pytest.approx([107.0, 50.0, 92.0], abs=1e-3)
    # IK takes poses in the user frame: the user-frame zero pose gives zero joints
    code, q = arm.get_inverse_kinematics([107, 50, 92, 180, 0, 0], input_is_radian=False,
                                         return_is_radian=False)
    assert code == 0
    assert q[:6] == pytest.approx([0.0] * 6, abs=1e-3)
    code, aa = arm.get_position_aa(is_radian=False)
    assert aa[:3] == pytest.approx([107.0, 50.0, 92.0], abs=1e-3)


def test_bad_input_does_not_crash_the_server(arm_st) -> None:
    """NaN and infinite inputs: a warning or refusal, the server keeps answering (bad input)."""
    arm, st = arm_st
    nan = float("nan")
    code, _ = arm.get_forward_kinematics([nan, 0, 0, 0, 0, 0], input_is_radian=True, return_is_radian=True)
    assert code == 0  # non-motion call: the warning bit still maps to 0 (motion calls only)
    code, _ = arm.get_inverse_kinematics([nan, 0, 200, math.pi, 0, 0], input_is_radian=True,
                                         return_is_radian=True)
    assert code == 0
    code, _ = arm.get_inverse_kinematics([float("inf"), 0, 200, math.pi, 0, 0], input_is_radian=True,
                                         return_is_radian=True)
    code, _ = arm.is_joint_limit([nan] * 6, is_radian=True)
    # unreachable pose: no solution is a warning, not a crash (warning 14 or 12)
    code, _ = arm.get_inverse_kinematics([5000, 0, 0, math.pi, 0, 0], input_is_radian=True,
                                         return_is_radian=True)
    code, (err, warn) = arm.get_err_warn_code()
    assert code == 0 and err == 0 and warn in (12, 14)
    # still answering, with the right numbers
    code, pose = arm.get_forward_kinematics([60, 0, 0, 0, 0, 0], False, False)
    assert code == 0 and pose[:3] == pytest.approx([103.5, 179.2673, 112.0], abs=1e-3)
    assert st.call(lambda: st.emulator.controller.error_code) == 0
