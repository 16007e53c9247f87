"""The unchanged SDK drives the other arms: it recognises the model from register 1 (axis and robot
type), reads the zero pose the model's joint frames give and moves the joints."""

from __future__ import annotations

import math

import pytest

from xarm_emu.model.kinematics import tcp_pose
from xarm_emu.model.robots import get_model
from xarm_emu.testing import running_emulator, sdk_pointed_at


@pytest.mark.parametrize("name, device_type", [("lite6", 9)])
def test_sdk_moves_the_arm_and_reads_its_pose(name: str, device_type: int) -> None:
    from xarm.wrapper import XArmAPI

    model = get_model(name)
    with running_emulator(model=name, speed=5.0) as st, sdk_pointed_at(st):
        arm = XArmAPI("127.0.0.1", forbid_uds=True)
        try:
            assert arm.axis == model.dof and arm.device_type == device_type
            code, pose = arm.get_position()
            zero = tcp_pose(model, [0.0] * model.dof, [0.0] * 6, [0.0] * 6)
            assert code == 0 and pose[:3] == pytest.approx(list(zero[:3, 3]), abs=1e-3)
            arm.motion_enable(True)
            arm.set_mode(0)
            arm.set_state(0)
            assert arm.set_servo_angle(angle=[30, 10, 20, 0, 0, 0], speed=60, wait=True) == 0
            q = st.call(lambda: [float(x) for x in st.emulator.controller.q])
            assert q[:3] == pytest.approx([math.radians(30), math.radians(10), math.radians(20)], abs=1e-4)
        finally:
            arm.disconnect()
