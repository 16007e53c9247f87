"""The official SDK's moves against a box claiming firmware 2.7.103: the SDK then sends the common
form of register 21 (frame, axis-angle flag, only-check byte) for ``set_position`` and
``set_position_aa``, 23 and 25 with an only-check byte, +inf for every pose or joint value it keeps,
``set_mode`` with its detection byte and ``get_joint_states`` asking 84 bytes. The arm ends where the
same calls take it under firmware 1.6.0, the manual's forms."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from helpers import sdk_ready as ready

from xarm_emu.controller.core.interface import C_SELF_COLLISION
from xarm_emu.controller.emulator import Emulator
from xarm_emu.server.app import ServerThread

V2 = "2.7.103"


def _arm(make_server: Any, sdk_arm: Any, tmp_path: Path, firmware: str) -> tuple[Any, ServerThread]:
    emu = Emulator(6, firmware=firmware, config_dir=tmp_path / f"config-{firmware}")
    st = make_server(emulator=emu, speed=5.0)
    arm = sdk_arm(st, report_type="real", is_radian=True)
    assert arm.version_number == tuple(int(x) for x in firmware.split("."))
    ready(arm)
    return arm, st


def _joints(st: ServerThread) -> np.ndarray:
    return np.asarray(st.call(lambda: st.emulator.joints))


def _pose(st: ServerThread) -> np.ndarray:
    return np.asarray(st.call(lambda: st.emulator.controller.tcp_pose()))


@pytest.mark.parametrize("firmware", [V2, "1.6.0"])
def test_set_position_and_set_position_aa_reach_their_poses(make_server, sdk_arm, tmp_path, firmware) -> None:
    arm, st = _arm(make_server, sdk_arm, tmp_path, firmware)
    assert arm.set_position(300, 0, 200, math.pi, 0, 0, speed=200, mvacc=2000, wait=True) == 0
    np.testing.assert_allclose(_pose(st)[:3], (300.0, 0.0, 200.0), atol=1e-3)
    # Only z given: the 2.x SDK sends +inf for the rest, the 1.x SDK its last commanded values.
    assert arm.set_position(z=250, speed=200, mvacc=2000, wait=True) == 0
    np.testing.assert_allclose(_pose(st)[:3], (300.0, 0.0, 250.0), atol=1e-3)
    assert abs(abs(_pose(st)[3]) - math.pi) < 1e-4
    assert arm.set_position_aa([280, 50, 220, math.pi, 0, 0], speed=200, mvacc=2000, wait=True) == 0
    np.testing.assert_allclose(_pose(st)[:3], (280.0, 50.0, 220.0), atol=1e-3)
    code, aa = arm.get_position_aa()
    assert code == 0 and aa[:3] == pytest.approx([280.0, 50.0, 220.0], abs=1e-3)
    # Relative in the tool frame (z of the tool points down here).
    assert arm.set_position_aa([0, 0, 20, 0, 0, 0], is_tool_coord=True, speed=200, mvacc=2000, wait=True) == 0
    np.testing.assert_allclose(_pose(st)[:3], (280.0, 50.0, 200.0), atol=1e-3)


@pytest.mark.parametrize("firmware", [V2, "1.6.0"])
def test_set_servo_angle_one_joint_keeps_the_others(make_server, sdk_arm, tmp_path, firmware) -> None:
    arm, st = _arm(make_server, sdk_arm, tmp_path, firmware)
    target = [0.3, 0.2, -0.4, 0.0, 0.5, 0.0]
    assert arm.set_servo_angle(angle=target, speed=1.5, mvacc=10, wait=True) == 0
    np.testing.assert_allclose(_joints(st), target, atol=1e-5)
    assert arm.set_servo_angle(servo_id=3, angle=-0.6, speed=1.5, mvacc=10, wait=True) == 0
    np.testing.assert_allclose(_joints(st), [0.3, 0.2, -0.6, 0.0, 0.5, 0.0], atol=1e-5)
    code, (pos, vel, eff) = arm.get_joint_states()
    assert code == 0 and pos[:6] == pytest.approx([0.3, 0.2, -0.6, 0.0, 0.5, 0.0], abs=1e-5)
    assert vel == pytest.approx([0.0] * 7, abs=1e-9) and len(eff) == 7 and any(eff)
    assert arm.move_gohome(speed=1.5, mvacc=10, wait=True) == 0
    np.testing.assert_allclose(_joints(st), 0.0, atol=1e-5)


def test_only_check_replies_through_only_check_result_and_moves_nothing(make_server, sdk_arm, tmp_path):
    arm, st = _arm(make_server, sdk_arm, tmp_path, V2)
    assert arm.set_servo_angle(angle=[0.4, 0, -0.4, 0, 0.4, 0], speed=1.5, mvacc=10, wait=True) == 0
    before = _joints(st)
    # A failed check: the SDK returns its "has error" code and keeps the box's result.
    assert arm.set_servo_angle(angle=[0, 0, math.radians(10), 0, 0, 0], speed=1, only_check_type=1) == 1
    assert arm.only_check_result == C_SELF_COLLISION
    assert arm.move_gohome(speed=1, only_check_type=1) == 0
    assert arm.only_check_result == 0
    assert arm.set_position(300, 0, 200, math.pi, 0, 0, speed=100, only_check_type=1) == 0
    assert arm.only_check_result == 0
    np.testing.assert_allclose(_joints(st), before, atol=1e-9)
    assert st.call(lambda: st.emulator.controller.executor.cmdnum) == 0


def test_set_mode_with_its_detection_byte(make_server, sdk_arm, tmp_path) -> None:
    arm, st = _arm(make_server, sdk_arm, tmp_path, V2)
    assert arm.set_mode(1) == 0 and arm.set_state(0) == 0
    assert st.call(lambda: st.emulator.controller.mode) == 1
    assert arm.set_servo_angle_j([0.05, 0, 0, 0, 0, 0, 0], speed=1, mvacc=10) == 0
    assert st.call(lambda: st.emulator.controller.servo_target is not None)
    assert arm.set_mode(0) == 0 and arm.set_state(0) == 0
    assert st.call(lambda: st.emulator.controller.mode) == 0
