"""`xarm_emu.testing`: the emulator on free ports and the unchanged SDK pointed at it, then restored."""

from __future__ import annotations

import pytest

from xarm_emu.testing import running_emulator, sdk_pointed_at


def test_sdk_against_an_emulator_on_free_ports_and_restored_after() -> None:
    from xarm.core.config.x_config import XCONF
    from xarm.wrapper import XArmAPI
    from xarm.x3.report import ReportDataStructure

    create = ReportDataStructure.__dict__["create"]
    with running_emulator(model=7, speed=4.0) as st, sdk_pointed_at(st):
        assert XCONF.SocketConf.TCP_CONTROL_PORT == st.ports["command"] != 502
        arm = XArmAPI("127.0.0.1", forbid_uds=True)
        try:
            assert arm.axis == 7
            code, pose = arm.get_position()
            assert code == 0 and pose[:3] == pytest.approx([206.0, 0.0, 120.5], abs=1e-3)
            arm.motion_enable(True)
            arm.set_mode(0)
            arm.set_state(0)
            assert arm.set_servo_angle(angle=[20, 0, 0, 0, 0, 0, 0], speed=90, wait=True) == 0
            assert st.call(lambda: round(float(st.emulator.controller.q[0]), 4)) == pytest.approx(0.3491,
                                                                                                  abs=1e-4)
        finally:
            arm.disconnect()
    assert XCONF.SocketConf.TCP_CONTROL_PORT == 502
    assert XCONF.SocketConf.TCP_REPORT_RICH_PORT == 30002
    assert ReportDataStructure.__dict__["create"] is create


def test_running_emulator_with_a_vacuum_gripper() -> None:
    from xarm.wrapper import XArmAPI

    with running_emulator(speed=5.0, vacuum=True) as st, sdk_pointed_at(st):
        arm = XArmAPI("127.0.0.1", forbid_uds=True)
        try:
            arm.motion_enable(True)
            arm.set_mode(0)
            arm.set_state(0)
            assert arm.set_vacuum_gripper(True, wait=True, timeout=2) == 0
            assert st.call(lambda: st.emulator.vacuum is not None and st.emulator.vacuum.pressure_normal)
        finally:
            arm.disconnect()
