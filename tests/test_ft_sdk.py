"""The six-axis F/T sensor through the unchanged SDK: the gravity of the load in the sensor frame at
several wrist orientations, zeroing, load identification with and without the sensor, the contact
force of a plane, the report fields, at firmware 1.11.100 and 2.7.103 (register 200; the SDK documents
every F/T call from 1.8.3, and an older box is refused the sensor: tests/test_device_gate.py)."""

from __future__ import annotations

import time
from typing import Any

import numpy as np
import pytest
from helpers import sdk_ready, wait_for

from xarm_emu.controller.devices import ft_sensor as ft
from xarm_emu.controller.emulator import Emulator
from xarm_emu.controller.scene import contact
from xarm_emu.model import kinematics as kin
from xarm_emu.protocol.firmware import FirmwareProfile

G = 9.81
PAYLOAD_MASS = 1.0
PAYLOAD_COM = (12.0, -8.0, 60.0)  # mm, flange frame
#: Wrist orientations (deg) the gravity is checked at.
POSES = ([0, -20, -30, 0, 50, 0], [0, -20, -30, 40, 80, 30], [20, -10, -40, -60, 30, -90],
         [0, 0, -60, 90, 90, 45])
#: 1.11.100: register 200 without the raw form; 2.7.103: 200 and 200 [01].
FIRMWARES = ("1.11.100", "2.7.103")


def expected_gravity(model: Any, q_deg: list[float], mass: float,
                     com_flange: tuple[float, ...]) -> np.ndarray:
    """The gravity wrench of a point load in the sensor frame, computed here from the flange's
    orientation: force m g rotated into the flange axes, torque about the sensor's tool face."""
    R = kin.fk(model, np.radians(q_deg))[:3, :3]
    f = R.T @ np.array([0.0, 0.0, -G * mass])
    r = (np.asarray(com_flange) - np.array([0.0, 0.0, ft.SENSOR_HEIGHT])) / 1000.0
    return np.concatenate([f, np.cross(r, f)])


def start(make_server: Any, sdk_arm: Any, *, firmware: str = "2.7.103", sensor: bool = True,
          speed: float = 10.0, report_type: str = "rich", model: int | str = 6) -> tuple[Any, Any]:
    emu = Emulator(model, load_config=False, firmware=FirmwareProfile.for_version(firmware), ft_sensor=sensor,
                   ft_noise=False)
    st = make_server(emulator=emu, speed=speed)
    arm = sdk_arm(st, report_type=report_type)
    sdk_ready(arm)
    return arm, st


def move(arm: Any, q_deg: list[float]) -> None:
    assert arm.set_servo_angle(angle=q_deg, speed=120, mvacc=1200, wait=True) == 0
    assert np.allclose(arm.get_servo_angle()[1][:6], q_deg, atol=0.01)


@pytest.mark.parametrize("firmware", FIRMWARES)
def test_gravity_of_the_payload_in_the_sensor_frame(make_server: Any, sdk_arm: Any, firmware: str) -> None:
    arm, st = start(make_server, sdk_arm, firmware=firmware)
    st.call(lambda: st.emulator.set_payload(PAYLOAD_MASS, PAYLOAD_COM))
    assert arm.get_ft_sensor_data() == (0, [0.0] * 6)  # switched off: zeros
    assert arm.set_ft_sensor_enable(1) == 0
    for q in POSES:
        move(arm, q)
        code, data = arm.get_ft_sensor_data()
        assert code == 0
        want = expected_gravity(st.emulator.model, q, PAYLOAD_MASS, PAYLOAD_COM)
        assert np.allclose(data[:3], want[:3], atol=0.05), (q, data, want)
        assert np.allclose(data[3:], want[3:], atol=0.005), (q, data, want)
    assert arm.set_ft_sensor_enable(0) == 0
    assert arm.get_ft_sensor_data() == (0, [0.0] * 6)
    assert arm.get_err_warn_code()[1] == [0, 0]


@pytest.mark.parametrize("firmware", ("1.11.100", "2.7.103"))
def test_zero_then_the_change_at_other_poses(make_server: Any, sdk_arm: Any, firmware: str) -> None:
    arm, st = start(make_server, sdk_arm, firmware=firmware)
    st.call(lambda: st.emulator.set_payload(PAYLOAD_MASS, PAYLOAD_COM))
    assert arm.set_ft_sensor_enable(1) == 0
    move(arm, POSES[0])
    assert arm.set_ft_sensor_zero() == 0
    code, data = arm.get_ft_sensor_data()
    assert code == 0 and np.allclose(data, 0.0, atol=1e-4)
    base = expected_gravity(st.emulator.model, POSES[0], PAYLOAD_MASS, PAYLOAD_COM)
    for q in POSES[1:3]:
        move(arm, q)
        change = expected_gravity(st.emulator.model, q, PAYLOAD_MASS, PAYLOAD_COM) - base
        data = np.array(arm.get_ft_sensor_data()[1])
        assert np.allclose(data[:3], change[:3], atol=0.05) and np.allclose(data[3:], change[3:], atol=0.005)
    if firmware == "2.7.103":  # the raw reading keeps the gravity; the report carries both
        raw = np.array(arm.get_ft_sensor_data(is_raw=True)[1])
        want = expected_gravity(st.emulator.model, POSES[2], PAYLOAD_MASS, PAYLOAD_COM)
        assert np.allclose(raw[:3], want[:3], atol=0.05)
        assert wait_for(lambda: np.allclose(arm.ft_ext_force, data, atol=1e-3)
                        and np.allclose(arm.ft_raw_force, raw, atol=1e-3), 3.0)
        assert arm.arm.ft_sensor_is_enable is True  # rich report byte 578
    code, config = arm.get_ft_sensor_config()
    assert code == 0 and config[1] == 1 and config[2] != 0  # started, a sensor type
    assert np.allclose(config[8][:3], base[:3], atol=0.05)  # the zero is the gravity it took off


@pytest.mark.parametrize("firmware", ("1.11.100", "2.7.103"))
def test_ft_sensor_identifies_its_load(make_server: Any, sdk_arm: Any, firmware: str) -> None:
    arm, st = start(make_server, sdk_arm, firmware=firmware)
    st.call(lambda: st.emulator.set_payload(PAYLOAD_MASS, PAYLOAD_COM))
    move(arm, POSES[0])
    assert arm.set_ft_sensor_enable(1) == 0
    code, result = arm.iden_ft_sensor_load_offset()
    assert code == 0 and len(result) == 10
    assert result[0] == pytest.approx(PAYLOAD_MASS, rel=0.01)
    com_sensor = np.asarray(PAYLOAD_COM) - np.array([0.0, 0.0, ft.SENSOR_HEIGHT])
    assert np.allclose(result[1:4], com_sensor, atol=1.0)  # mm (the SDK converts from m)
    assert np.allclose(result[4:], 0.0, atol=0.05)  # no bias on an exact sensor
    # Applied, the reading keeps only what is not the load: zero at every pose.
    assert arm.set_ft_sensor_load_offset(result) == 0
    for q in POSES[1:]:
        move(arm, q)
        data = np.array(arm.get_ft_sensor_data()[1])
        assert np.allclose(data[:3], 0.0, atol=0.05) and np.allclose(data[3:], 0.0, atol=0.005), (q, data)


def test_ft_identification_needs_the_sensor_switched_on(make_server: Any, sdk_arm: Any) -> None:
    arm, st = start(make_server, sdk_arm)
    code, _ = arm.iden_ft_sensor_load_offset()
    assert arm.get_err_warn_code()[1] == [0, 12]
    assert arm.clean_warn() == 0
    assert arm.set_ft_sensor_zero() == 0 and arm.get_err_warn_code()[1] == [0, 12]


@pytest.mark.parametrize("model", [6, "lite6", 7])
def test_iden_tcp_load_without_a_sensor(make_server: Any, sdk_arm: Any, model: Any) -> None:
    arm, st = start(make_server, sdk_arm, sensor=False, model=model)
    if model == 6:
        move(arm, [0, -20, -30, 0, 50, 0])
    st.call(lambda: st.emulator.set_payload(PAYLOAD_MASS, PAYLOAD_COM))
    code, load = arm.iden_tcp_load()
    assert code == 0 and len(load) == 4
    assert load[0] == pytest.approx(PAYLOAD_MASS, rel=0.03)
    assert np.allclose(load[1:], PAYLOAD_COM, atol=5.0), load
    assert arm.get_err_warn_code()[1] == [0, 0]


def test_iden_tcp_load_with_the_sensor_sees_sensor_and_payload(make_server: Any, sdk_arm: Any) -> None:
    arm, st = start(make_server, sdk_arm)
    st.call(lambda: st.emulator.set_payload(PAYLOAD_MASS, PAYLOAD_COM))
    code, load = arm.iden_tcp_load()
    total = PAYLOAD_MASS + ft.SENSOR_MASS
    com = (np.asarray(PAYLOAD_COM) * PAYLOAD_MASS + np.asarray(ft.SENSOR_COM) * ft.SENSOR_MASS) / total
    assert code == 0 and load[0] == pytest.approx(total, rel=0.03) and np.allclose(load[1:], com, atol=5.0)


def test_contact_plane_pushes_back_with_its_stiffness(make_server: Any, sdk_arm: Any) -> None:
    arm, st = start(make_server, sdk_arm, speed=5.0)
    assert arm.set_ft_sensor_enable(1) == 0
    assert arm.set_ft_sensor_zero() == 0
    x, y, z = arm.get_position()[1][:3]
    k = 10.0  # N/mm
    scene = contact.parse_scene({"plane": [{"name": "table", "point": [0, 0, z - 5.0], "normal": [0, 0, 1],
                                            "stiffness": k, "damping": 0.02}]})
    st.call(lambda: st.emulator.set_scene(scene))
    assert np.allclose(arm.get_ft_sensor_data()[1], 0.0, atol=1e-3)  # above the table: nothing
    assert arm.set_position(z=z - 7.0, speed=20, wait=True) == 0  # 2 mm into it
    time.sleep(0.05)
    data = np.array(arm.get_ft_sensor_data()[1])
    # The flange points down at this pose: the table's upward push is -z in the sensor frame.
    assert data[2] == pytest.approx(-k * 2.0, abs=0.1), data
    assert np.allclose(data[:2], 0.0, atol=0.05)
    wrench = st.call(lambda: ft.external_wrench(st.emulator.controller))
    assert wrench[2] == pytest.approx(k * 2.0, abs=0.1)
