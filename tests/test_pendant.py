"""The pendant's logic without a browser: its actions reach the emulator as the registers a client
sends, from viser's threads into the server's loop; the admin actions only with --admin; the status
text, the plot samples and the drawn end devices follow the state."""

from __future__ import annotations

import math
import threading
import time
import urllib.request

import numpy as np
import pytest
from helpers import free_ports, port_args, serve_subprocess, wait_for

from xarm_emu.client.sync import Client
from xarm_emu.controller.emulator import Emulator
from xarm_emu.model import kinematics as kin
from xarm_emu.protocol.reports import ReportSnapshot
from xarm_emu.viewer import pendant as pendant_mod
from xarm_emu.viewer import scene

pytest.importorskip("viser")


def in_thread(fn):  # type: ignore[no-untyped-def]
    """Run ``fn`` in another thread, as viser runs a button's callback; returns its result."""
    out: list[object] = []
    t = threading.Thread(target=lambda: out.append(fn()))
    t.start()
    t.join(10.0)
    return out[0]


def test_describe_state_gives_the_manual_handling_text() -> None:
    snap = ReportSnapshot(state=4, mode=0, error=35, warning=0, axis=6,
                          joints=(math.radians(10.0),) + (0.0,) * 6)
    text = pendant_mod.describe_state(snap)
    assert text["state"] == "4 stopped"
    assert text["error"].startswith("C35 ") and ":" in text["error"]  # label, name: handling
    assert text["warning"] == "no warning"
    assert text["joints"].startswith("10.00, 0.00")
    assert text["enabled"] == "bits 0x00"


def test_buttons_act_through_the_registers(make_server) -> None:  # type: ignore[no-untyped-def]
    st = make_server(view=True, view_port=0)
    p = st.server.viewer.pendant
    with Client("127.0.0.1", st.ports["command"]) as client:
        assert in_thread(p.enable) == "MOTION_EN (11): ok; SET_STATE (12): ok"
        assert client.get_state() == 2
        assert in_thread(lambda: p.jog_joint(1, -1)).endswith("ok")  # J2 by -5 deg (the default step)
        assert wait_for(lambda: abs(client.get_joints()[1] + math.radians(5.0)) < 1e-4, 10.0)
        assert wait_for(lambda: client.get_state() == 2, 10.0)
        x0 = client.get_position()[0]
        assert in_thread(lambda: p.jog_tcp(0, 1)).startswith("MOVE_LINE (21) X +10")
        assert wait_for(lambda: abs(client.get_position()[0] - (x0 + 10.0)) < 0.05, 10.0)
        in_thread(lambda: p.command(12, state=4))
        assert client.get_state() == 4


def test_admin_actions_need_admin(make_server) -> None:  # type: ignore[no-untyped-def]
    st = make_server(view=True, view_port=0)
    p = st.server.viewer.pendant
    assert in_thread(lambda: p.admin({"cmd": "error", "code": "C35"})).startswith("refused")
    with Client("127.0.0.1", st.ports["command"]) as client:
        assert client.get_err_warn() == (0, 0)


def test_admin_actions_go_through_the_admin_checks(make_server) -> None:  # type: ignore[no-untyped-def]
    st = make_server(view=True, view_port=0, admin=True, admin_port=0)
    p = st.server.viewer.pendant
    with Client("127.0.0.1", st.ports["command"]) as client:
        assert in_thread(lambda: p.admin({"cmd": "error", "code": "C35"})).startswith("injected C35")
        assert client.get_err_warn()[0] == 35
        bad = in_thread(lambda: p.admin({"cmd": "servo-error", "joint": 9, "code": "S23"}))
        assert bad.startswith("refused") and "joint 9" in bad
        assert p.last_message == bad
        in_thread(lambda: p.admin({"cmd": "clear"}))
        assert client.get_err_warn() == (0, 0)


def test_status_and_plot_follow_the_emulator(make_server) -> None:  # type: ignore[no-untyped-def]
    st = make_server(view=True, view_port=0, admin=True, admin_port=0)
    p = st.server.viewer.pendant
    in_thread(lambda: p.admin({"cmd": "error", "code": "C35"}))
    assert wait_for(lambda: "**Error:** C35" in p._status.content)
    assert wait_for(lambda: len(p.samples) >= 3)
    ts = [s[0] for s in p.samples]
    assert ts == sorted(ts) and ts[-1] - ts[0] <= pendant_mod.PLOT_SECONDS
    assert all(len(s[1]) == 6 and len(s[3]) == 6 for s in p.samples)


def test_gripper_fingers_open_with_the_position() -> None:
    model = Emulator(6).model
    q = np.array([0.3, -0.2, -0.3, 0.0, 0.5, 0.1])
    axis_y = kin.fk(model, q)[:3, 1]

    def gap(position: float) -> float:
        a, b = scene.gripper_parts(model, q, position)
        return float(np.dot(np.array(a.position) - np.array(b.position), axis_y))

    assert gap(850.0) - gap(0.0) == pytest.approx(scene.GRIPPER_STROKE, abs=1e-9)
    assert gap(425.0) - gap(0.0) == pytest.approx(scene.GRIPPER_STROKE / 2, abs=1e-9)
    assert gap(2000.0) == pytest.approx(gap(850.0))


def test_vacuum_cup_hangs_from_the_flange() -> None:
    model = Emulator(6).model
    q = np.zeros(6)
    (cup,) = scene.vacuum_parts(model, q)
    np.testing.assert_allclose(cup.position, kin.fk(model, q)[:3, 3] / 1000.0, atol=1e-12)


def test_devices_are_drawn_when_attached(make_server, tmp_path) -> None:  # type: ignore[no-untyped-def]
    st = make_server(view=True, view_port=0, emulator=Emulator(6, vacuum=True, config_dir=tmp_path))
    viewer = st.server.viewer
    assert wait_for(lambda: any(k.startswith("/devices/") and "cup" in k for k in viewer._handles))


def test_the_scene_draws_a_falling_object_where_the_world_has_it(make_server, tmp_path) -> None:  # type: ignore[no-untyped-def]
    """A cube let go 100 mm above the table: its node follows the physics world down to the table,
    turned as the world turns it, in the scene file's colour."""
    pytest.importorskip("mujoco")
    from xarm_emu.controller.scene import contact

    sc = contact.parse_scene({"plane": [{"point": [0, 0, 0], "normal": [0, 0, 1], "stiffness": 10.0}],
                              "object": [{"name": "cube", "shape": "box", "size": [40, 40, 40], "mass": 0.1,
                                          "position": [250, 0, 20], "color": "#2080f0"}]})
    st = make_server(view=True, view_port=0, emulator=Emulator(6, scene=sc, config_dir=tmp_path))
    viewer = st.server.viewer
    st.call(lambda: st.emulator.place_object("cube", (250, 0, 120), (0, 0, 30)))
    key = "/objects/object_cube"
    heights = []

    def seen() -> bool:
        n = viewer.updates
        assert wait_for(lambda: viewer.updates > n)
        handle = st.call(lambda: viewer._handles[key])
        heights.append(float(handle.position[2]))
        return st.call(lambda: st.emulator.physics.world.state.settled)

    assert wait_for(seen, timeout=20.0)
    assert seen()
    handle = st.call(lambda: viewer._handles[key])
    pose = st.call(lambda: st.emulator.scene_objects()[0])
    assert heights[-1] == pytest.approx(0.020, abs=1e-3)  # on the table (m)
    assert tuple(handle.position) == pytest.approx([v / 1000 for v in pose["position"]], abs=1e-4)
    expected = scene.object_parts([("cube", "box", (40, 40, 40))], [pose])[0].wxyz
    # turned 30 degrees about z; the drawn node is the world of the last update, and a cube at rest
    # still creeps by about 1e-6 between two reads: 1e-4 is 0.01 degrees
    assert tuple(handle.wxyz) == pytest.approx(expected, abs=1e-4)
    assert tuple(handle.color) == (0x20, 0x80, 0xF0)


@pytest.mark.parametrize(("extra", "expected"),
                         [((), "127.0.0.2"), (("--view-host", "127.0.0.1"), "127.0.0.1")])
def test_the_view_follows_host_unless_view_host_says(  # type: ignore[no-untyped-def]
        tmp_path, extra, expected) -> None:
    cmd, normal, rich, develop, view = free_ports(5)
    args = (*port_args(cmd, normal, rich, develop), "--host", "127.0.0.2", "--view", "--view-port", str(view),
            *extra)
    with serve_subprocess(tmp_path, *args) as proc:
        assert proc.stdout is not None
        lines = []
        for line in proc.stdout:
            lines.append(line)
            if "3D view on" in line:
                break
        assert f"3D view on http://{expected}:{view}/" in "".join(lines)
        with urllib.request.urlopen(f"http://{expected}:{view}/", timeout=5) as r:
            assert r.status == 200


def test_fleet_view_lists_and_draws_every_arm(tmp_path) -> None:  # type: ignore[no-untyped-def]
    from xarm_emu.server.core import EmulatorServer, ServerConfig
    from xarm_emu.viewer.app import FleetView

    servers = [EmulatorServer(Emulator(6, config_dir=tmp_path / "a"), ServerConfig(port=5020)),
               EmulatorServer(Emulator(7, config_dir=tmp_path / "b"), ServerConfig(host="127.0.0.2"))]
    servers[1].emulator.inject_error(35)
    view = FleetView(servers, "127.0.0.1", 0)
    try:
        view.update()
        listing = view.listing().splitlines()
        assert len(listing) == 2
        assert "xArm6 on 127.0.0.1:5020" in listing[0] and "error no error" in listing[0]
        assert "xArm7 on 127.0.0.2:502" in listing[1] and "error C35" in listing[1]
        first, second = view.viewers
        assert any(k.startswith("/arm1/arm/") for k in first._handles)
        assert sum(k.startswith("/arm2/arm/") for k in second._handles) > sum(
            k.startswith("/arm1/arm/") for k in first._handles)  # seven joints, more links
        assert first.pendant is not None and second.pendant is not None
        assert "C35" in second.pendant._status.content and "C35" not in first.pendant._status.content
    finally:
        view.stop()


def test_serve_fleet_view(tmp_path) -> None:  # type: ignore[no-untyped-def]
    ports = free_ports(9)
    arms = "".join(f'[[arm]]\nmodel = 6\nport = {ports[4 * i]}\nnormal_port = {ports[4 * i + 1]}\n'
                   f'rich_port = {ports[4 * i + 2]}\ndevelop_port = {ports[4 * i + 3]}\n\n' for i in range(2))
    fleet = tmp_path / "fleet.toml"
    fleet.write_text(arms)
    with serve_subprocess(tmp_path, "--fleet", str(fleet), "--view", "--view-port", str(ports[8])) as proc:
        assert proc.stdout is not None
        lines = []
        for line in proc.stdout:
            lines.append(line)
            if "3D view on" in line:
                break
        assert f"3D view on http://127.0.0.1:{ports[8]}/" in "".join(lines)
        with urllib.request.urlopen(f"http://127.0.0.1:{ports[8]}/", timeout=5) as r:
            assert r.status == 200


def test_move_to_pose_is_a_linear_move(make_server) -> None:  # type: ignore[no-untyped-def]
    st = make_server(view=True, view_port=0)
    p = st.server.viewer.pendant
    with Client("127.0.0.1", st.ports["command"]) as client:
        in_thread(p.enable)
        reply = in_thread(lambda: p.move_to_pose((250.0, 50.0, 200.0), (180.0, 0.0, 0.0)))
        assert reply == "MOVE_LINE (21): ok"
        assert wait_for(lambda: np.allclose(client.get_position()[:3], (250.0, 50.0, 200.0), atol=0.05), 15.0)


def test_the_status_never_shows_negative_zero() -> None:
    snap = ReportSnapshot(axis=6, joints=(-1e-9,) * 7, pose=(-1e-9, 0.0, 100.0, -1e-9, 0.0, 0.0))
    text = pendant_mod.describe_state(snap)
    assert "-0.0" not in text["joints"] and "-0.0" not in text["pose"]


def test_admin_speed_scales_time_from_now_on(make_server) -> None:  # type: ignore[no-untyped-def]
    st = make_server(view=True, view_port=0, admin=True, admin_port=0)
    p = st.server.viewer.pendant
    assert in_thread(lambda: p.set_speed(0.0)).startswith("refused")
    assert in_thread(lambda: p.set_speed(4.0)) == "speed x4"
    t0, w0 = st.call(lambda: st.emulator.time), time.monotonic()
    time.sleep(0.5)
    t1, w1 = st.call(lambda: st.emulator.time), time.monotonic()
    assert (t1 - t0) / (w1 - w0) == pytest.approx(4.0, rel=0.25)
