"""Errors and safety through the official SDK: the safety boundary
stops the arm on it with C35, self-collision detection stops a folding move with C22 before links
overlap, and injected C1, S23 on joint 3 and G11 show up where a real arm shows them."""

from __future__ import annotations

import math

import pytest
from helpers import sdk_ready as ready
from helpers import wait_for

from xarm_emu.model import collision
from xarm_emu.model import kinematics as kin


def test_move_through_the_boundary_stops_on_it_with_c35(make_server, sdk_arm) -> None:  # type: ignore[no-untyped-def]
    st = make_server(speed=4.0)
    arm = sdk_arm(st, report_type="rich")
    assert arm.set_reduced_tcp_boundary([400, -400, 400, -400, 500, 60]) == 0
    arm.set_fence_mode(True)  # the SDK returns the raw reply list here ([0]), not a code
    assert st.call(lambda: st.emulator.controller.settings.boundary_on)
    ready(arm)
    arm.set_position(x=207, y=0, z=12, roll=180, pitch=0, yaw=0, speed=100, wait=True)
    assert wait_for(lambda: arm.error_code == 35)
    assert arm.get_err_warn_code() == (0, [35, 0])
    assert arm.get_state() == (0, 4)
    z = st.call(lambda: float(kin.fk(st.emulator.model, st.emulator.controller.q)[2, 3]))
    assert z == pytest.approx(60.0, abs=0.1)  # on the face z min = 60
    assert wait_for(lambda: arm.position[2] == pytest.approx(60.0, abs=0.1))
    # motion calls return 1 while the error is present
    assert arm.set_position(x=207, y=0, z=200, roll=180, pitch=0, yaw=0, speed=100, wait=False) == 1
    # recovery (manual 3.3): clean error, enable, set state 0; moving back inside works
    assert arm.clean_error() == 0
    ready(arm)
    assert wait_for(lambda: arm.error_code == 0)  # the SDK refuses motion while its report shows one
    assert arm.set_position(x=207, y=0, z=200, roll=180, pitch=0, yaw=0, speed=200, wait=True) == 0
    assert arm.get_err_warn_code() == (0, [0, 0])


def test_folding_move_stops_before_contact_with_c22(make_server, sdk_arm) -> None:  # type: ignore[no-untyped-def]
    st = make_server(speed=4.0)
    arm = sdk_arm(st, report_type="rich")
    assert arm.set_self_collision_detection(True) == 0
    ready(arm)
    arm.set_servo_angle(angle=[0, 0, 0, 0, 178, 0], speed=60, wait=True)
    assert wait_for(lambda: arm.error_code == 22)
    hit, dist, _ = st.call(lambda: collision.self_collision(st.emulator.model, st.emulator.controller.q))
    assert not hit and dist > 0.9  # stopped with the 1 mm margin left: links never overlap
    j5 = st.call(lambda: math.degrees(st.emulator.controller.q[4]))
    assert 0.0 < j5 < 178.0


def test_injected_faults_show_as_on_a_real_arm(make_server, sdk_arm) -> None:  # type: ignore[no-untyped-def]
    st = make_server(speed=2.0, admin=True)
    arm = sdk_arm(st, report_type="rich")
    ready(arm)
    st.call(lambda: st.emulator.inject_estop())
    assert wait_for(lambda: arm.error_code == 1 and arm.state == 4)
    assert arm.clean_error() == 0
    ready(arm)
    assert wait_for(lambda: arm.error_code == 0)
    # a servo error S23 on joint 3: controller error C13 and joint 3's servo state in the report
    st.call(lambda: st.emulator.inject_servo_error(3, 23))
    assert wait_for(lambda: arm.error_code == 13)
    assert wait_for(lambda: list(arm.servo_codes[2]) == [1, 23])
    assert [list(c) for c in arm.servo_codes[:2]] == [[0, 0], [0, 0]]
    # joint errors need the joints enabled again after clearing (manual 3.2.1: power on again)
    assert arm.clean_error() == 0
    assert arm.set_state(0) == 0
    assert arm.set_servo_angle(angle=[5, 0, 0, 0, 0, 0], speed=50, wait=False) != 0
    ready(arm)
    assert wait_for(lambda: arm.error_code == 0 and list(arm.servo_codes[2]) == [0, 0])
    # a gripper error G11 reads back through the gripper's error register
    st.call(lambda: st.emulator.inject_gripper_error(11))
    assert arm.get_gripper_err_code() == (0, 11)
