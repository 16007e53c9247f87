"""Admittance and force control through the unchanged official SDK (``XArmAPI``) against a box with
the F/T sensor mounted (noise off), claiming firmware 2.7.103, on lockstep time: the SDK's F/T
application functions return 0 and the arm moves as the laws say; bad parameters get warning 12."""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from helpers import sdk_ready

from xarm_emu.controller.emulator import Emulator
from xarm_emu.controller.scene.contact import Plane, Scene
from xarm_emu.server.app import ServerThread
from xarm_emu.testing import sdk_pointed_at

FW2 = "2.7.103"
START_DEG = [0.0, -28.6, -51.6, 0.0, 80.2, 0.0]
M = [1.0] * 3 + [0.005] * 3


@pytest.fixture
def arm(make_server: Any, tmp_path: Path) -> Iterator[tuple[Any, ServerThread]]:
    from xarm.wrapper import XArmAPI

    emu = Emulator(6, firmware=FW2, ft_sensor=True, ft_noise=False, config_dir=tmp_path / "box")
    st = make_server(emulator=emu, stepped=True, admin=True)
    with contextlib.ExitStack() as stack:
        stack.enter_context(sdk_pointed_at(st))
        api = XArmAPI("127.0.0.1", report_type="rich", forbid_uds=True)
        stack.callback(api.disconnect)
        sdk_ready(api)
        assert api.set_servo_angle(angle=START_DEG, speed=60, wait=False) == 0
        advance(st, 3.0)
        yield api, st


def advance(st: ServerThread, seconds: float) -> None:
    st.call(lambda: st.server.advance(seconds))


def position(api: Any) -> np.ndarray:
    code, pos = api.get_position()
    assert code == 0
    return np.asarray(pos, dtype=float)


def test_admittance_yields_to_a_push_along_tool_z_as_the_law_says(arm: tuple[Any, ServerThread]) -> None:
    api, st = arm
    emu = st.emulator
    assert api.set_ft_sensor_admittance_parameters(M, [0.0] * 6, [40.0] * 3 + [1.0] * 3) == 0  # 210
    assert api.set_ft_sensor_admittance_parameters(1, [0, 0, 1, 0, 0, 0]) == 0  # 211: tool frame, z
    code, cfg = api.get_ft_sensor_config()
    assert code == 0 and cfg[9] == 1 and cfg[10] == [0, 0, 1, 0, 0, 0]
    assert cfg[11] == pytest.approx(M) and cfg[13] == pytest.approx([40.0] * 3 + [1.0] * 3)
    assert api.set_ft_sensor_enable(1) == 0
    assert api.set_ft_sensor_mode(1) == 0
    assert api.get_ft_sensor_mode() == (0, 1)
    assert api.set_state(0) == 0
    advance(st, 0.1)
    code, cfg = api.get_ft_sensor_config()
    assert code == 0 and cfg[0] == 1  # register 212's application status: admittance
    p0 = position(api)
    st.call(lambda: emu.apply_wrench([0, 0, 10.0, 0, 0, 0], frame="tool"))
    advance(st, 0.3)
    p1 = position(api)
    advance(st, 0.2)
    p2 = position(api)
    tau, v_end = 1.0 / 40.0, 10.0 / 40.0  # s, m/s

    def law(t: float) -> float:  # mm along tool z; the law acts from one period after the push
        t -= 0.004
        return 1000.0 * v_end * (t - tau * (1 - math.exp(-t / tau)))

    # the tool points down: tool z is base -z
    assert p0[2] - p1[2] == pytest.approx(law(0.3), rel=0.02)
    assert (p1[2] - p2[2]) / 0.2 == pytest.approx((law(0.5) - law(0.3)) / 0.2, rel=0.02)  # mm/s
    assert p2[:2] == pytest.approx(p0[:2], abs=1e-3)
    st.call(emu.clear_wrench)
    advance(st, 0.5)
    p3 = position(api)
    advance(st, 0.5)
    assert position(api) == pytest.approx(p3, abs=1e-3)  # stopped
    assert api.set_ft_sensor_mode(0) == 0
    assert api.get_ft_sensor_mode() == (0, 0)
    assert api.set_ft_sensor_enable(0) == 0
    assert api.get_err_warn_code() == (0, [0, 0])


def test_force_control_presses_on_a_table_plane(arm: tuple[Any, ServerThread]) -> None:
    api, st = arm
    table_z = float(position(api)[2]) - 5.0
    st.call(lambda: st.emulator.set_scene(Scene((Plane("table", (0, 0, table_z), (0, 0, 1), 10.0),))))
    assert api.set_ft_sensor_force_parameters([0.005] * 6, [0.00005] * 6, [0.05] * 6,
                                              [200.0] * 3 + [0.35] * 3) == 0  # 208
    assert api.set_ft_sensor_force_parameters(1, [0, 0, 1, 0, 0, 0], [0, 0, 20.0, 0, 0, 0], [0] * 6) == 0
    assert api.set_ft_sensor_enable(1) == 0
    assert api.set_ft_sensor_zero() == 0
    assert api.set_ft_sensor_mode(2) == 0
    assert api.set_state(0) == 0
    advance(st, 4.0)
    code, forces = api.get_ft_sensor_data()
    assert code == 0 and -forces[2] == pytest.approx(20.0, abs=0.5)  # the table pushes back
    assert table_z - position(api)[2] == pytest.approx(2.0, abs=0.05)  # 20 N at 10 N/mm
    assert api.set_ft_sensor_mode(0) == 0
    assert api.get_err_warn_code() == (0, [0, 0])


def test_parameters_outside_the_ranges_get_warning_12_and_change_nothing(
        arm: tuple[Any, ServerThread]) -> None:
    api, _ = arm
    _, before = api.get_ft_sensor_config()
    bad_m = [0.01] * 3 + [0.001] * 3  # below 0.02 kg
    assert api.set_ft_sensor_admittance_parameters(bad_m, [0.0] * 6, [0.0] * 6, params_limit=False) == 0
    assert api.get_err_warn_code() == (0, [0, 12])  # the SDK returns 0 on a warning; the box says 12
    assert api.clean_warn() == 0
    assert api.set_ft_sensor_force_parameters([0.1] * 6, [0.0] * 6, [0.0] * 6, [100.0] * 6,
                                              params_limit=False) == 0
    assert api.get_err_warn_code() == (0, [0, 12])
    assert api.clean_warn() == 0
    assert api.set_ft_sensor_force_parameters(1, [0, 0, 1, 0, 0, 0], [0, 0, 250.0, 0, 0, 0], [0] * 6,
                                              params_limit=False) == 0
    assert api.get_err_warn_code() == (0, [0, 12])
    assert api.get_ft_sensor_config() == (0, before)


def test_an_application_needs_the_sensor_switched_on(arm: tuple[Any, ServerThread]) -> None:
    api, _ = arm
    assert api.set_ft_sensor_mode(1) == 10  # the box could not carry it out
    assert api.get_ft_sensor_mode() == (0, 0)
    assert api.get_err_warn_code() == (0, [0, 0])
