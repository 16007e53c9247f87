"""The official SDK's configuration and torque calls against the emulator.

``set_tcp_load`` (36), ``set_gravity_direction`` (51), ``set_tcp_offset`` (35), ``set_collision_sensitivity``
(37), ``save_conf`` (40) survive a restart on the same configuration directory and come back in the report
(manual 2.1.6 normal report bytes 87-144); ``clean_conf`` (39) then a restart restores the defaults.
``get_joints_torque`` (55) at the zero pose: gravity torques on J2, J3, J5, changed by a payload.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest
from helpers import sdk_ready as ready
from helpers import wait_for

from xarm_emu.controller.emulator import Emulator
from xarm_emu.server.app import ServerThread

G = 9.81  # m/s2, the emulator's documented gravity




def start(make_server, sdk_arm, config_dir: Path) -> tuple[Any, ServerThread]:
    st = make_server(emulator=Emulator(6, config_dir=config_dir), speed=5.0)
    arm = sdk_arm(st, report_type="normal")
    assert wait_for(lambda: arm.arm.reported)
    ready(arm)
    return arm, st


def stop(arm: Any, st: ServerThread) -> None:
    arm.disconnect()
    st.stop()


LOAD = [1.5, [10.0, -20.0, 35.0]]
GRAVITY = [0.0, 0.70710677, -0.70710677]
TCP = [5.0, -6.0, 120.0, 0.0, 0.0, 90.0]  # degrees in the SDK's default unit
SENSITIVITY = 5


def _report_matches(arm: Any) -> bool:
    return (arm.tcp_load[0] == pytest.approx(LOAD[0], abs=1e-3)
            and arm.tcp_load[1] == pytest.approx(LOAD[1], abs=1e-3)
            and list(arm.gravity_direction) == pytest.approx(GRAVITY, abs=1e-6)
            and list(arm.tcp_offset) == pytest.approx(TCP, abs=1e-3)
            and arm.collision_sensitivity == SENSITIVITY)


def _report_is_default(arm: Any) -> bool:
    return (arm.tcp_load[0] == 0 and arm.tcp_load[1] == [0, 0, 0]
            and list(arm.gravity_direction) == pytest.approx([0, 0, -1], abs=1e-9)
            and list(arm.tcp_offset) == pytest.approx([0] * 6, abs=1e-9)
            and arm.collision_sensitivity == 3)


def test_saved_configuration_survives_restart_and_clean_conf_restores_defaults(
        make_server, sdk_arm, tmp_path: Path) -> None:
    cfg = tmp_path / "conf"
    arm, st = start(make_server, sdk_arm, cfg)
    assert wait_for(lambda: _report_is_default(arm))
    assert arm.set_tcp_load(LOAD[0], LOAD[1]) == 0
    assert arm.set_gravity_direction(GRAVITY, wait=False) == 0
    assert arm.set_tcp_offset(TCP, wait=False) == 0
    assert arm.set_collision_sensitivity(SENSITIVITY, wait=False) == 0
    assert wait_for(lambda: _report_matches(arm))
    assert arm.save_conf() == 0
    stop(arm, st)

    arm, st = start(make_server, sdk_arm, cfg)
    assert wait_for(lambda: _report_matches(arm)), (arm.tcp_load, arm.gravity_direction, arm.tcp_offset,
                                                    arm.collision_sensitivity)
    assert st.call(lambda: st.emulator.config_message) is None
    # the restored TCP offset is live: the zero pose's TCP is 120 mm below the flange, offset (5, -6)
    code, pose = arm.get_position()
    assert code == 0 and pose[:3] == pytest.approx([212.0, 6.0, -8.0], abs=1e-3)
    assert arm.clean_conf() == 0
    stop(arm, st)

    arm, st = start(make_server, sdk_arm, cfg)
    assert wait_for(lambda: _report_is_default(arm)), (arm.tcp_load, arm.gravity_direction, arm.tcp_offset,
                                                       arm.collision_sensitivity)
    code, pose = arm.get_position()
    assert pose[:3] == pytest.approx([207.0, 0.0, 112.0], abs=1e-3)


def test_unsaved_changes_are_lost_on_restart(make_server, sdk_arm, tmp_path: Path) -> None:
    cfg = tmp_path / "conf"
    arm, st = start(make_server, sdk_arm, cfg)
    assert arm.set_tcp_load(LOAD[0], LOAD[1]) == 0
    assert wait_for(lambda: arm.tcp_load[0] == pytest.approx(LOAD[0], abs=1e-3))
    stop(arm, st)
    arm, st = start(make_server, sdk_arm, cfg)
    assert wait_for(lambda: _report_is_default(arm))


def test_joint_torques_at_zero_pose_and_payload(make_server, sdk_arm, tmp_path: Path) -> None:
    """Register 55: gravity loads J2, J3 and J5 at the zero pose (J1, J4, J6 axes are vertical there).

    A 1 kg payload at the flange (centre of mass at the flange origin) adds m g times the horizontal
    lever arm from each horizontal axis to the flange (manual 1.3 and the xArm6 geometry: J2 axis at x = 0,
    J3 at x = 53.5, J5 at x = 131 mm; flange at x = 207 mm): 2.0307, 1.5058 and 0.7456 N m.
    """
    arm, st = start(make_server, sdk_arm, tmp_path / "conf")
    code, tau0 = arm.get_joints_torque()
    assert code == 0 and len(tau0) >= 6
    for j in (1, 2, 4):
        assert abs(tau0[j]) > 0.05, tau0
    for j in (0, 3, 5):
        assert abs(tau0[j]) < 1e-3, tau0
    assert arm.set_tcp_load(1.0, [0, 0, 0]) == 0
    code, tau1 = arm.get_joints_torque()
    assert code == 0
    delta = [tau1[j] - tau0[j] for j in range(6)]
    for j, lever_mm in ((1, 207.0), (2, 153.5), (4, 76.0)):
        assert abs(delta[j]) == pytest.approx(G * lever_mm / 1000.0, rel=0.01), (j, delta)
    # the payload pulls the same way as the arm's own weight on J2 (both hang forward of the axis)
    assert math.copysign(1, delta[1]) == math.copysign(1, tau0[1])
    for j in (0, 3, 5):
        assert abs(delta[j]) < 1e-3
    # gravity along +X: the arm's weight no longer acts about the horizontal Y axes the same way
    assert arm.set_gravity_direction([1, 0, 0], wait=False) == 0
    code, tau2 = arm.get_joints_torque()
    assert code == 0 and tau2[:6] != pytest.approx(tau1[:6], abs=1e-3)
    # the report carries the same torques as register 55 (normal report bytes 60-87)
    snap = st.call(lambda: st.emulator.snapshot())
    assert list(snap.torques[:6]) == pytest.approx(tau2[:6], abs=1e-4)
