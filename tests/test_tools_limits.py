"""Every arm's joint limits as the SDK's client-side check and the emulator's refusals see them, and
register 8 (kinematics query) as xarm_ros2's kinematics generator reads it.

A target 0.2 degrees inside a limit passes the SDK's check and the emulator accepts the move; 0.2
degrees outside, the SDK refuses it without sending (its out-of-range code) and, sent raw, the
emulator refuses it with error C23 (joint limit, manual section 3.2.1). Self-collision detection is
switched off through the SDK so that only the joint limits decide.
"""

from __future__ import annotations

import math
import socket
import struct
from typing import Any

import pytest
from helpers import sdk_ready, wait_for

from xarm_emu.controller.core.interface import C_JOINT_LIMIT
from xarm_emu.model.robots import get_model
from xarm_emu.server.app import ServerThread
from xarm_emu.testing import running_emulator, sdk_pointed_at

ARMS = [(5, "1.6.0"), (6, "1.6.0"), (7, "1.6.0"), ("lite6", "2.4.101"), ("850", "2.4.101"),
        ("7t", "2.4.101")]
MARGIN = math.radians(0.2)


def _controller(st: ServerThread) -> tuple[int, int, int]:
    def read() -> tuple[int, int, int]:
        c = st.emulator.controller
        return c.error_code, c.warning_code, c.state
    return st.call(read)  # type: ignore[return-value]


def _ready_again(arm: Any, st: ServerThread) -> None:
    """Stop, clear and re-enable, then wait until the emulator is ready to move."""
    arm.set_state(4)
    assert wait_for(lambda: _controller(st)[2] == 4, timeout=3.0)
    arm.clean_error()
    arm.clean_warn()
    sdk_ready(arm)
    assert wait_for(lambda: _controller(st)[2] in (1, 2), timeout=3.0)


@pytest.mark.parametrize("model, firmware", ARMS)
def test_sdk_and_emulator_agree_at_the_joint_limits(model: int | str, firmware: str) -> None:
    from xarm.wrapper import XArmAPI
    from xarm.x3.code import APIState

    robot = get_model(model)
    with running_emulator(model=model, firmware=firmware) as st, sdk_pointed_at(st):
        arm = XArmAPI("127.0.0.1", forbid_uds=True)
        try:
            sdk_ready(arm)
            assert arm.set_self_collision_detection(False) == 0
            for i, joint in enumerate(robot.joints):
                for limit, inward in ((joint.lower, 1.0), (joint.upper, -1.0)):
                    q = [0.0] * robot.dof
                    q[i] = limit + inward * MARGIN
                    assert arm.set_servo_angle(angle=q, is_radian=True, wait=False) == 0, (i, limit)
                    assert _controller(st)[:2] == (0, 0), (i, limit)
                    _ready_again(arm, st)
                    q[i] = limit - inward * MARGIN
                    assert arm.set_servo_angle(angle=q, is_radian=True, wait=False) == APIState.OUT_OF_RANGE
                    arm._arm.arm_cmd.move_joint(q + [0.0] * (7 - robot.dof), 0.5, 5.0, 0)
                    assert wait_for(lambda: _controller(st)[0] == C_JOINT_LIMIT, timeout=2.0), (i, limit)
                    _ready_again(arm, st)
        finally:
            arm.disconnect()


@pytest.mark.parametrize("model, firmware", ARMS)
def test_register_8_answers_each_arms_kinematics(model: int | str, firmware: str) -> None:
    robot = get_model(model)
    with running_emulator(model=model, firmware=firmware) as st:
        with socket.create_connection(("127.0.0.1", st.ports["command"]), timeout=5.0) as s:
            s.sendall(bytes([0x00, 0x01, 0x00, 0x02, 0x00, 0x01, 0x08]))
            reply = b""
            while len(reply) < 179:
                chunk = s.recv(4096)
                assert chunk, f"connection closed after {len(reply)} bytes"
                reply += chunk
    assert len(reply) == 179 and reply[6] == 0x08  # [6] register, [7] state
    valid, dof, robot_type = reply[8], reply[9], reply[10]
    assert (valid, dof, robot_type) == (1, robot.axis, robot.robot_type)
    values = struct.unpack("<42f", reply[11:179])
    for n, joint in enumerate(robot.joints):
        xyz = [c / 1000.0 for c in joint.origin_xyz]
        assert values[6 * n: 6 * n + 6] == pytest.approx([*xyz, *joint.origin_rpy], abs=1e-6)
    assert values[6 * robot.dof:] == pytest.approx([0.0] * (42 - 6 * robot.dof))
