"""Kinematics registers through the controller (manual 2.1.3, 41-45): bytes of the manual's examples,
TCP and user offsets, bad input."""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest
from helpers import bits, call, count_calls, joints7, ready

from xarm_emu.controller import controller as controller_core
from xarm_emu.controller.emulator import Emulator
from xarm_emu.model import kinematics as kin
from xarm_emu.model import rotations as rot

F32_PI = struct.unpack("<f", bytes.fromhex("db0f4940"))[0]


@pytest.fixture
def emu() -> Emulator:
    return Emulator(6)


def test_register_44_manual_example_bytes(emu: Emulator) -> None:
    request = bytes.fromhex("920a863f") + bytes(24)  # J1 = float32(pi/3), manual register 44
    state, reply = emu.handle(44, request)
    assert state & 0x60 == 0 and len(reply) == 24
    x, y, z = struct.unpack("<3f", reply[:12])
    assert (x, y, z) == pytest.approx((103.5, 179.2673, 112.0), abs=1e-3)
    # roll -pi, pitch -0.0, yaw +pi/3: the manual's bytes, signed zero included
    assert reply[12:24] == bytes.fromhex("db0f49c0" "00000080" "920a863f")


def test_register_43_manual_example(emu: Emulator) -> None:
    request = struct.pack("<6f", 400.0, 0.0, 200.0, F32_PI, 0.0, 0.0)
    state, reply = emu.handle(43, request)
    assert state & 0x60 == 0
    q = struct.unpack("<7f", reply)
    # The values (the manual's response bytes as the vendor sends them; labels are rounded).
    assert q[1] == pytest.approx(0.0817986, abs=3e-7)
    assert q[2] == pytest.approx(-0.6411543, abs=3e-7)
    assert q[4] == pytest.approx(0.5593557, abs=3e-7)
    assert q[0] == pytest.approx(0.0, abs=1e-7) and q[3] == pytest.approx(0.0, abs=1e-7)
    assert q[6] == 0.0


@pytest.mark.parametrize("dof,zero", [(5, (207.0, 0.0, 112.0)), (6, (207.0, 0.0, 112.0)),
                                      (7, (206.0, 0.0, 120.5))])
def test_register_41_zero_pose_of_each_model(dof: int, zero: tuple[float, float, float]) -> None:
    pose = call(Emulator(dof), 41)[1]["pose"]
    assert pose[:3] == pytest.approx(zero, abs=1e-3)
    assert abs(pose[3]) == pytest.approx(math.pi, abs=1e-6)
    assert pose[4:] == pytest.approx((0.0, 0.0), abs=1e-6)


def test_ik_no_solution_is_warning_14(emu: Emulator) -> None:
    state, reply = call(emu, 43, pose=(2000.0, 0.0, 200.0, math.pi, 0.0, 0.0))
    assert bits(state)[1]
    assert call(emu, 15)[1]["warning"] == 14
    assert len(reply["joints"]) == 7  # the full layout still answers


def test_nan_inputs_are_warnings_not_crashes(emu: Emulator) -> None:
    state, _ = call(emu, 43, pose=(math.nan, 0.0, 200.0, math.pi, 0.0, 0.0))
    assert bits(state)[1]
    state, _ = call(emu, 44, joints=joints7(math.inf))
    assert bits(state)[1]
    state, reply = call(emu, 45, joints=joints7(math.nan))
    assert reply["limited"] == 1


def test_register_45_joint_limit_check(emu: Emulator) -> None:
    assert call(emu, 45, joints=joints7(0.0, 2.0))[1]["limited"] == 0
    assert call(emu, 45, joints=joints7(0.0, 2.2))[1]["limited"] == 1
    assert call(emu, 45, joints=joints7(0.0, 0.0, 0.3))[1]["limited"] == 1  # J3 upper 11 deg


def test_tcp_offset_changes_poses_as_defined(emu: Emulator) -> None:
    # TCP 100 mm along the flange z axis: at the zero pose the flange z points down.
    call(emu, 35, pose=(0.0, 0.0, 100.0, 0.0, 0.0, 0.0))
    pose = call(emu, 41)[1]["pose"]
    assert pose[:3] == pytest.approx((207.0, 0.0, 12.0), abs=1e-3)
    fk = call(emu, 44, joints=joints7(math.pi / 2))[1]["pose"]
    assert fk[:3] == pytest.approx((0.0, 207.0, 12.0), abs=1e-3)
    # IK answers for the TCP, not the flange
    q = call(emu, 43, pose=(207.0, 0.0, 12.0, math.pi, 0.0, 0.0))[1]["joints"]
    assert q[:6] == pytest.approx((0.0,) * 6, abs=1e-5)
    assert emu.snapshot().pose[2] == pytest.approx(12.0, abs=1e-3)


def test_user_offset_changes_poses_as_defined(emu: Emulator) -> None:
    # User frame 1000 mm along base x, turned 180 deg about z: the zero pose (207, 0, 112)
    # lies at x = 1000 - 207 = 793 in front of it and its yaw turns by 180 deg.
    call(emu, 73, pose=(1000.0, 0.0, 0.0, 0.0, 0.0, math.pi))
    pose = call(emu, 41)[1]["pose"]
    assert pose[:3] == pytest.approx((793.0, 0.0, 112.0), abs=1e-3)
    assert abs(abs(pose[5]) - math.pi) < 1e-5
    q = call(emu, 43, pose=pose)[1]["joints"]
    assert q[:6] == pytest.approx((0.0,) * 6, abs=1e-5)


def test_axis_angle_pose_register_91(emu: Emulator) -> None:
    aa = call(emu, 91)[1]["pose"]
    assert aa[:3] == pytest.approx((207.0, 0.0, 112.0), abs=1e-3)
    assert aa[3:] == pytest.approx((math.pi, 0.0, 0.0), abs=1e-6)


def test_pose_offset_register_76(emu: Emulator) -> None:
    p1 = (300.0, 0.0, 200.0, math.pi, 0.0, 0.0)
    p2 = (300.0, 0.0, 100.0, math.pi, 0.0, 0.0)
    out = call(emu, 76, pose1=p1, pose2=p2, input_aa=0, output_aa=0)[1]["pose"]
    assert out[:3] == pytest.approx((0.0, 0.0, -100.0), abs=1e-4)


def test_register_8_kinematics_parameters(emu: Emulator) -> None:
    state, reply = emu.handle(8, b"")
    assert len(reply) == 3 + 42 * 4  # 179-byte frame with the 8-byte header
    valid, dof, rtype = reply[:3]
    assert (valid, dof, rtype) == (1, 6, 6)
    params = struct.unpack("<42f", reply[3:])
    assert params[2] == pytest.approx(0.267, abs=1e-6)  # J1 origin z, metres as the ROS generator reads


def test_reported_pose_is_fk_of_reported_joints() -> None:
    emu = Emulator(7)
    rng = np.random.default_rng(3)
    model = emu.model
    for _ in range(20):
        q = rng.uniform(model.lower * 0.5, model.upper * 0.5)
        emu.controller.q = q
        pose = np.array(call(emu, 41)[1]["pose"])
        T = kin.fk(model, q)
        np.testing.assert_allclose(pose[:3], T[:3, 3], atol=1e-3)
        R = rot.rpy_to_matrix(*pose[3:])
        np.testing.assert_allclose(R, T[:3, :3], atol=1e-5)


def test_register_42_joint_states_blocks(emu: Emulator) -> None:
    emu.controller.q = np.array([0.1, 0.2, -0.3, 0.0, 0.4, 0.0])
    assert len(emu.handle(42, b"")[1]) == 28
    state, reply = emu.handle(42, bytes([3]))
    values = struct.unpack("<21f", reply)
    assert values[:3] == pytest.approx((0.1, 0.2, -0.3), abs=1e-7)
    assert values[14:21] == pytest.approx(emu.controller.joint_torques7(), abs=1e-4)


def test_torques_are_computed_again_only_when_their_inputs_change(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """Every report frame carries the joint torques (manual 2.1.6); an arm at rest does not redo the
    Newton-Euler pass for each, and whatever changes an input gets fresh torques."""
    emu = Emulator(6)
    ready(emu)
    ctl = emu.controller
    calls = count_calls(monkeypatch, controller_core, "joint_torques")
    first = ctl.joint_torques().copy()
    for _ in range(50):  # at rest: 50 periods, a report read after each
        emu.step(1)
        assert np.array_equal(ctl.joint_torques(), first)
    assert calls[0] == 1
    call(emu, 36, mass=1.5, center=(0.0, 0.0, 30.0))  # payload (register 36)
    loaded = ctl.joint_torques().copy()
    assert calls[0] == 2 and not np.array_equal(loaded, first)
    call(emu, 23, joints=(0.3, 0.2, -0.2, 0.0, 0.1, 0.0, 0.0), speed=1.0, acc=8.0, mvtime=0.0)
    moving = []
    for _ in range(20):
        emu.step(1)
        moving.append(ctl.joint_torques().copy())
        fresh = controller_core.joint_torques(ctl.model, ctl.data, ctl.settings)
        assert np.array_equal(moving[-1], fresh)  # never a stale value
    assert calls[0] >= 2 + 2 * 20 - 1  # recomputed as the joints move (and once per check above)
