"""The F/T sensor's faces: the admin channel (set-input ft, ft-error, ft-noise, payload, scene,
status), the CLI (set-input ft, inject ft-error, serve --ft-sensor / --scene), a fault schedule,
the fleet keys and running_emulator; bad input refused with one clear line."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from helpers import run_cli

from xarm_emu.client.admin import AdminClient, AdminRefused
from xarm_emu.controller.devices import ft_sensor as ft
from xarm_emu.controller.scene import contact
from xarm_emu.server.fleet import FleetError, parse_fleet
from xarm_emu.testing import running_emulator

TABLE = ('[[plane]]\nname = "table"\npoint = [0, 0, 100]\nnormal = [0, 0, 1]\nstiffness = 10.0\n'
         'damping = 0.05\n')


def admin_args(st: object) -> list[str]:
    ports = st.ports  # type: ignore[attr-defined]
    return ["--port", str(ports["command"]), "--admin-port", str(ports["admin"])]


def test_admin_and_cli_play_a_wrench_and_refuse_nan() -> None:
    with running_emulator(6, firmware="2.7.103", ft_sensor=True, ft_noise=False, admin=True,
                          stepped=True) as st, AdminClient("127.0.0.1", st.ports["admin"]) as a:
        ctl = st.emulator.controller
        a.request("set-input", kind="ft", wrench=[0, 0, 10, 0, 0, 0], frame="base", ramp=0.5)
        a.request("step", seconds=0.25)
        assert st.call(lambda: ft.external_wrench(ctl))[2] == pytest.approx(5.0, abs=0.05)
        a.request("step", seconds=0.5)
        assert st.call(lambda: ft.external_wrench(ctl))[2] == pytest.approx(10.0, abs=1e-6)
        for bad, words in [({"wrench": [float("nan"), 0, 0, 0, 0, 0]}, "finite"),
                           ({"wrench": [1, 2, 3]}, "6 numbers"),
                           ({"wrench": [0] * 6, "frame": "world"}, "frame"),
                           ({"wrench": [0] * 6, "for": 0}, "for")]:
            with pytest.raises(AdminRefused, match=words):
                a.request("set-input", kind="ft", **bad)
        assert st.call(lambda: ft.external_wrench(ctl))[2] == pytest.approx(10.0, abs=1e-6)  # unchanged
        # The CLI: a new wrench replaces the last one; NaN is one line and exit 2.
        code, out = run_cli("set-input", "ft", "0", "-3", "0", "0", "0", "0.5", "--frame", "tool", "--for",
                            "1", *admin_args(st))
        assert code == 0, out
        wrench = st.call(lambda: ft.external_wrench(ctl))
        assert np.linalg.norm(wrench[:3]) == pytest.approx(3.0, abs=1e-6)
        a.request("step", seconds=1.1)
        assert np.allclose(st.call(lambda: ft.external_wrench(ctl)), 0.0)
        for args in (["nan", "0", "0", "0", "0", "0"], ["1", "2"], ["0", "0", "inf", "0", "0", "0"]):
            code, out = run_cli("set-input", "ft", *args, *admin_args(st))
            assert code == 2 and out.strip().count("\n") == 0 and "set-input ft" in out, out
        code, out = run_cli("set-input", "ft", *["0"] * 6, "--ramp", "-1", *admin_args(st))
        assert code == 2 and "--ramp" in out
        code, out = run_cli("set-input", "cgpio", "3", "1", *admin_args(st))  # the other kinds as before
        assert code == 0 and st.call(lambda: st.emulator.io.cgpio.digital_inputs >> 3 & 1) == 1


def test_ft_error_noise_payload_scene_and_status() -> None:
    with running_emulator(6, firmware="2.7.103", ft_sensor=True, admin=True,
                          stepped=True) as st, AdminClient("127.0.0.1", st.ports["admin"]) as a:
        ctl = st.emulator.controller
        st.call(lambda: st.emulator.handle(201, b"\x01"))
        a.request("ft-noise", on=False)
        a.request("payload", mass=1.0, com=[0, 0, 52])
        a.request("step", seconds=0.02)
        status = json.loads(a.request("status"))
        assert status["ft_sensor"]["enabled"] is True
        assert status["ft_sensor"]["reading"][2] == pytest.approx(9.81, abs=0.01)
        with pytest.raises(AdminRefused, match="stiffness"):
            a.request("scene", scene={"plane": [{"point": [0, 0, 0], "normal": [0, 0, 1], "stiffness": 0}]})
        z = st.call(lambda: ctl.tcp_position[2])
        a.request("scene", scene={"plane": [{"point": [0, 0, z + 2], "normal": [0, 0, 1], "stiffness": 4}]})
        a.request("step", seconds=0.02)
        assert st.call(lambda: ft.external_wrench(ctl))[2] == pytest.approx(8.0, abs=1e-6)
        code, out = run_cli("inject", "ft-error", "7", *admin_args(st))
        assert code == 0, out
        assert st.call(lambda: (ft.error_register(ctl), ctl.error_code)) == (7, ft.C_FT_READ)
        code, out = run_cli("inject", "ft-error", "27", *admin_args(st))
        assert code == 2 and "refused" in out and "27" in out  # an argument the emulator refuses
        with pytest.raises(AdminRefused, match="mass"):
            a.request("payload", mass=-1, com=[0, 0, 0])
        a.request("clear")
        assert st.call(lambda: (ft.error_register(ctl), ctl.error_code)) == (ft.NO_SENSOR_ERROR, 0)
    with running_emulator(6, admin=True) as st, AdminClient("127.0.0.1", st.ports["admin"]) as a:
        with pytest.raises(AdminRefused, match="--ft-sensor"):
            a.request("ft-error", code=3)
        assert "ft_sensor" not in json.loads(a.request("status"))


def test_fault_schedule_plays_a_wrench(tmp_path: Path) -> None:
    faults = tmp_path / "faults.toml"
    faults.write_text('[[fault]]\nat = 0.5\ndo = "set-input"\nkind = "ft"\nwrench = [0, 0, 10, 0, 0, 0]\n'
                      'frame = "tool"\nfor = 0.5\n')
    with running_emulator(6, firmware="2.7.103", ft_sensor=True, ft_noise=False, admin=True, stepped=True,
                          faults=faults) as st, AdminClient("127.0.0.1", st.ports["admin"]) as a:
        ctl = st.emulator.controller
        st.call(lambda: st.emulator.handle(201, b"\x01"))
        a.request("step", seconds=0.4)
        assert np.allclose(st.call(lambda: ft.control_wrench(ctl)), 0.0, atol=1e-9)
        a.request("step", seconds=0.2)
        assert st.call(lambda: ft.control_wrench(ctl))[2] == pytest.approx(10.0, abs=1e-6)
        a.request("step", seconds=0.5)
        assert np.allclose(st.call(lambda: ft.control_wrench(ctl)), 0.0, atol=1e-9)
    bad = tmp_path / "bad.toml"
    bad.write_text('[[fault]]\nat = 0.5\ndo = "set-input"\nkind = "ft"\nwrench = [0, 0, "x", 0, 0, 0]\n')
    with pytest.raises(ValueError, match="wrench"), running_emulator(6, ft_sensor=True, faults=bad,
                                                                firmware="2.7.103"):
        pass


def test_serve_refuses_a_bad_scene_before_any_port_opens(tmp_path: Path) -> None:
    bad = tmp_path / "scene.toml"
    bad.write_text('[[plane]]\npoint = [0, 0, 0]\nnormal = [0, 0, 1]\n')  # no stiffness
    code, out = run_cli("serve", "--ft-sensor", "--scene", str(bad), "--port", "0", "--config-dir",
                        str(tmp_path))
    assert code == 2 and "stiffness" in out and out.strip().count("\n") == 0, out
    code, out = run_cli("serve", "--scene", str(tmp_path / "missing.toml"), "--config-dir", str(tmp_path))
    assert code == 2 and "missing.toml" in out


def test_fleet_keys_and_running_emulator_scene(tmp_path: Path) -> None:
    (tmp_path / "table.toml").write_text(TABLE)
    fleet = parse_fleet({"arm": [{"model": 6, "ft_sensor": True, "scene": "table.toml"},
                                 {"model": 7, "host": "127.0.0.2"}]},
                        base=tmp_path)
    assert fleet.arms[0].ft_sensor and fleet.arms[0].scene is not None
    assert fleet.arms[0].scene.shapes[0].stiffness == 10.0
    assert not fleet.arms[1].ft_sensor and fleet.arms[1].scene is None
    for arm, words in [({"ft_sensor": "yes"}, "ft_sensor"), ({"scene": "none.toml"}, "none.toml")]:
        with pytest.raises(FleetError, match=words):
            parse_fleet({"arm": [arm]}, base=tmp_path)
    with running_emulator(6, ft_sensor=True, scene=tmp_path / "table.toml", firmware="2.7.103") as st:
        assert st.call(lambda: ft.attached(st.emulator.controller))
        shapes = st.call(lambda: contact.scene_of(st.emulator.controller).shapes)
        assert len(shapes) == 1 and math.isclose(shapes[0].point[2], 100.0)


def test_3d_view_draws_the_sensor_and_the_contact_scene(make_server: object, tmp_path: Path) -> None:
    from helpers import wait_for

    from xarm_emu.controller.emulator import Emulator
    from xarm_emu.model import kinematics as kin
    from xarm_emu.viewer import scene as view_scene

    emu = Emulator(6, config_dir=tmp_path, ft_sensor=True, firmware="2.7.103",
                   scene=contact.parse_scene({"plane": [{"name": "table", "point": [0, 0, 50],
                                                         "normal": [0, 0, 1], "stiffness": 1}],
                                              "box": [{"name": "part", "min": [300, -50, 0],
                                                       "max": [400, 50, 100], "stiffness": 1}]}))
    (disc,) = view_scene.ft_sensor_parts(emu.model, np.zeros(6), ft.SENSOR_HEIGHT)
    assert disc.length == pytest.approx(ft.SENSOR_HEIGHT / 1000.0)
    assert np.allclose(disc.position, kin.fk(emu.model, np.zeros(6))[:3, 3] / 1000.0)
    table, part = view_scene.contact_parts(contact.scene_of(emu.controller).shapes)
    assert table.position == pytest.approx((0.0, 0.0, 0.05))
    assert part.half == pytest.approx((0.05, 0.05, 0.05))
    st = make_server(view=True, view_port=0, emulator=emu)  # type: ignore[operator]
    viewer = st.server.viewer
    assert wait_for(lambda: any("/devices/" in k and "ft_sensor" in k for k in viewer._handles))
    assert wait_for(lambda: sum("/contact/" in k for k in viewer._handles) == 2)
