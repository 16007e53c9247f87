"""The F/T sensor and the contact scene in the controller, stepped: the interface force control
builds on (external and control wrenches, their frames), ramps and durations, inertial forces,
noise and drift, errors, checkpoints, and the scene's spring-damper and its file checks."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest

from xarm_emu.controller.devices import ft_sensor as ft
from xarm_emu.controller.emulator import Emulator
from xarm_emu.controller.scene import contact
from xarm_emu.model import kinematics as kin


def sensor_box(**kw: object) -> Emulator:
    emu = Emulator(6, firmware="2.7.103", ft_sensor=True, ft_noise=False, **kw)  # type: ignore[arg-type]
    emu.controller.strict = True
    assert emu.handle(201, b"\x01")[0] & 0x60 == 0
    return emu


def forces(emu: Emulator, raw: bool = False) -> np.ndarray:
    state, reply = emu.handle(200, b"\x01" if raw else b"")
    assert state & 0x60 == 0
    return np.array(struct.unpack("<6f", reply))


def flange_rotation(emu: Emulator) -> np.ndarray:
    return kin.fk(emu.model, emu.controller.q)[:3, :3]


def test_interface_shapes_and_no_sensor() -> None:
    emu = Emulator(6, firmware="2.7.103")
    ctl = emu.controller
    assert not ft.attached(ctl) and not ft.enabled(ctl)
    assert ft.external_wrench(ctl).shape == (6,) and ft.control_wrench(ctl).shape == (6,)
    state, _ = emu.handle(201, b"\x01")  # no sensor to switch on: warning 12
    assert state & 0x20 and ctl.warning_code == 12


def test_control_wrench_is_the_external_wrench_in_the_tool_frame() -> None:
    emu = sensor_box()
    ctl = emu.controller
    ctl.q = np.radians([10, -20, -30, 20, 60, -40])
    w_base = np.array([3.0, -4.0, 12.0, 0.2, -0.1, 0.3])
    emu.apply_wrench(w_base, frame="base")
    emu.step()
    R = flange_rotation(emu)
    want = np.concatenate([R.T @ w_base[:3], R.T @ w_base[3:]])
    assert np.allclose(ft.external_wrench(ctl), w_base, atol=1e-9)
    assert np.allclose(ft.control_wrench(ctl), want, atol=1e-6)
    # The reading of register 200 has its torques about the sensor origin: the force's moment
    # about the TCP point (here the flange + 0, as no TCP offset is set) moves them.
    r = (np.array(emu.controller.settings.tcp_offset[:3]) - [0, 0, ft.SENSOR_HEIGHT]) / 1000.0
    got = forces(emu)
    assert np.allclose(got[:3], want[:3], atol=1e-4)
    assert np.allclose(got[3:], want[3:] + np.cross(r, want[:3]), atol=1e-4)


def test_tool_frame_wrench_ramps_holds_and_ends() -> None:
    emu = sensor_box()
    ctl = emu.controller
    emu.apply_wrench([0, 0, 10, 0, 0, 0], frame="tool", ramp_s=0.4, duration_s=1.0)
    emu.advance(0.2)
    assert ft.control_wrench(ctl)[2] == pytest.approx(5.0, abs=0.05)
    emu.advance(0.4)
    assert ft.control_wrench(ctl)[2] == pytest.approx(10.0, abs=1e-6)
    R = flange_rotation(emu)
    assert np.allclose(ft.external_wrench(ctl)[:3], R @ [0, 0, 10], atol=1e-9)
    emu.advance(0.5)
    assert np.allclose(ft.external_wrench(ctl), 0.0) and np.allclose(ft.control_wrench(ctl), 0.0)
    emu.apply_wrench([1, 0, 0, 0, 0, 0])
    emu.clear_wrench()
    emu.step()
    assert np.allclose(ft.control_wrench(ctl), 0.0)


@pytest.mark.parametrize("bad", [[float("nan"), 0, 0, 0, 0, 0], [0, 0, float("inf"), 0, 0, 0], [1, 2, 3]])
def test_wrench_must_be_six_finite_numbers(bad: list[float]) -> None:
    emu = sensor_box()
    with pytest.raises(ValueError):
        emu.apply_wrench(bad)
    assert ft.state_of(emu.controller).wrenches == []


def test_inertial_force_of_the_load_during_motion() -> None:
    """A vertical acceleration of the flange adds m*a to what the load weighs on the sensor."""
    emu = sensor_box()
    ctl = emu.controller
    emu.set_payload(2.0, (0.0, 0.0, 40.0))
    q = np.zeros(6)
    ctl.q = q
    emu.advance(0.1)
    still = forces(emu, raw=True)[2]
    # Joint 2 accelerating from rest: the flange moves; compare with the load's own acceleration.
    dt = ctl.period
    positions = []
    for i in range(6):
        q = q.copy()
        q[1] += 0.5 * 20.0 * ((i + 1) * dt) ** 2 - 0.5 * 20.0 * (i * dt) ** 2  # 20 rad/s^2 on J2
        ctl.q = q
        emu.step()
        R, origin = ft._sensor_pose(ctl)
        positions.append(origin + R @ np.array([0.0, 0.0, 40.0 - ft.SENSOR_HEIGHT]))
    a = (positions[-1] - 2 * positions[-2] + positions[-3]) / dt**2 / 1000.0
    R = flange_rotation(emu)
    want = R.T @ (2.0 * (np.array([0.0, 0.0, -9.81]) - a))
    got = forces(emu, raw=True)
    assert np.linalg.norm(a) > 1.0  # a real acceleration, not rounding
    assert np.allclose(got[:3], want, atol=0.05)
    assert abs(got[2] - still) > 0.5


def test_noise_and_drift_on_by_default_and_repeatable() -> None:
    readings = []
    for _ in range(2):
        emu = Emulator(6, firmware="2.7.103", ft_sensor=True)
        emu.handle(201, b"\x01")
        samples = []
        for _ in range(200):
            emu.step()
            samples.append(forces(emu))
        readings.append(np.array(samples))
    a = readings[0]
    assert np.all(a.std(axis=0)[:3] > 0.005) and np.all(a.std(axis=0)[:3] < 0.2)
    assert np.array_equal(readings[0], readings[1])  # the same seed: the same run
    emu.set_ft_noise(False)
    emu.step()
    assert np.allclose(forces(emu), 0.0, atol=1e-6)


def test_ft_error_as_the_sdk_reads_it_and_c50() -> None:
    emu = sensor_box()
    ctl = emu.controller
    reply = emu.handle(102, bytes([8]) + (0x0010).to_bytes(2, "big"))[1]
    assert int.from_bytes(reply[:4], "big", signed=True) == ft.NO_SENSOR_ERROR
    emu.inject_ft_error(5)
    reply = emu.handle(102, bytes([8]) + (0x0010).to_bytes(2, "big"))[1]
    assert int.from_bytes(reply[:4], "big", signed=True) == 5
    assert ctl.error_code == ft.C_FT_READ
    emu.clear_faults()
    reply = emu.handle(102, bytes([8]) + (0x0010).to_bytes(2, "big"))[1]
    assert int.from_bytes(reply[:4], "big", signed=True) == ft.NO_SENSOR_ERROR
    with pytest.raises(ValueError):
        Emulator(6).inject_ft_error(5)


def test_checkpoint_restores_the_sensor() -> None:
    emu = Emulator(6, firmware="2.7.103", ft_sensor=True)
    emu.handle(201, b"\x01")
    emu.apply_wrench([0, 0, 5, 0, 0, 0])
    emu.advance(0.1)
    cp = emu.checkpoint()
    emu.advance(0.2)
    after = forces(emu)
    emu.clear_wrench()
    emu.restore(cp)
    emu.advance(0.2)
    assert np.array_equal(forces(emu), after)


def test_report_fields_match_the_registers() -> None:
    emu = sensor_box()
    emu.set_payload(1.0, (0.0, 10.0, 50.0))
    emu.advance(0.05)
    snap = emu.snapshot()
    assert np.allclose(snap.ft_ext_force, forces(emu)) and np.allclose(snap.ft_raw_force, forces(emu, True))
    assert snap.ft_enabled


# -- the contact scene --------------------------------------------------------------------------
def test_plane_and_box_spring_damper() -> None:
    plane = contact.Plane("table", (0.0, 0.0, 100.0), (0.0, 0.0, 1.0), stiffness=10.0, damping=0.5)
    p = np.array([300.0, 0.0, 98.0])
    assert np.allclose(contact.shape_force(plane, p, np.zeros(3)), [0, 0, 20.0])
    # Pressing deeper at 10 mm/s adds c * rate; leaving fast never pulls.
    assert np.allclose(contact.shape_force(plane, p, np.array([0, 0, -10.0])), [0, 0, 25.0])
    assert np.allclose(contact.shape_force(plane, p, np.array([0, 0, 100.0])), 0.0)
    assert np.allclose(contact.shape_force(plane, p + [0, 0, 3.0], np.zeros(3)), 0.0)
    box = contact.Box("block", (0.0, 0.0, 0.0), (100.0, 100.0, 50.0), stiffness=4.0)
    assert np.allclose(contact.shape_force(box, np.array([50.0, 50.0, 47.0]), np.zeros(3)), [0, 0, 12.0])
    assert np.allclose(contact.shape_force(box, np.array([1.0, 50.0, 20.0]), np.zeros(3)), [-4.0, 0, 0])
    sliding = contact.Plane("rough", (0.0, 0.0, 100.0), (0.0, 0.0, 1.0), stiffness=10.0, friction=0.5)
    f = contact.shape_force(sliding, p, np.array([20.0, 0.0, 0.0]))
    assert np.allclose(f, [-10.0, 0.0, 20.0])


def test_scene_file_read_and_refused(tmp_path: Path) -> None:
    good = tmp_path / "scene.toml"
    good.write_text('[[plane]]\nname = "table"\npoint = [0, 0, 0]\nnormal = [0, 0, 2]\nstiffness = 10\n'
                    '[[box]]\nmin = [0, 0, 0]\nmax = [1, 1, 1]\nstiffness = 1\ndamping = 0.1\n')
    scene = contact.load_scene(good)
    assert [type(s).__name__ for s in scene.shapes] == ["Plane", "Box"]
    assert scene.shapes[0].normal == (0.0, 0.0, 1.0)
    for text, words in [
        ('[[plane]]\npoint = [0, 0]\nnormal = [0, 0, 1]\nstiffness = 1\n', "point"),
        ('[[plane]]\npoint = [0, 0, 0]\nnormal = [0, 0, 0]\nstiffness = 1\n', "normal"),
        ('[[plane]]\npoint = [0, 0, 0]\nnormal = [0, 0, 1]\nstiffness = -1\n', "stiffness"),
        ('[[box]]\nmin = [0, 0, 0]\nmax = [1, -1, 1]\nstiffness = 1\n', "min must be below max"),
        ('[[sphere]]\n', "unknown key 'sphere'; known: plane, box, object"),
        ('[[plane]]\npoint = [0, 0, 0]\nnormal = [0, 0, 1]\nstiffness = 1\ncolour = 1\n', "unknown key"),
        ('[[plane]\n', r"^scene file \S+bad\.toml, line 1, column \d+: not valid TOML: "),
    ]:
        bad = tmp_path / "bad.toml"
        bad.write_text(text)
        with pytest.raises(ValueError, match=words) as info:
            contact.load_scene(bad)
        assert "\n" not in str(info.value)


def test_tcp_pressing_into_the_scene_feels_it_through_the_sensor() -> None:
    emu = sensor_box()
    ctl = emu.controller
    z = float(ctl.tcp_position[2])
    emu.set_scene(contact.parse_scene({"plane": [{"point": [0, 0, z + 3.0], "normal": [0, 0, 1],
                                                   "stiffness": 5.0}]}))
    emu.step()
    assert ft.external_wrench(ctl)[2] == pytest.approx(15.0, abs=1e-6)
    assert ft.control_wrench(ctl)[2] == pytest.approx(-15.0, abs=1e-6)  # the flange points down
