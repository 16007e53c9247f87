"""The pick-and-place through the unchanged official SDK on the real-time clock (sped up), and the
scene's admin commands: ``scene-objects``, ``scene-place``, ``scene-reset``, and the CLI's
``xarm-emu scene --json``."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

pytest.importorskip("mujoco")

from xarm_emu.client.admin import AdminClient, AdminRefused  # noqa: E402
from xarm_emu.testing import running_emulator, sdk_pointed_at  # noqa: E402

SCENE = {"plane": [{"name": "table", "point": [0, 0, -100], "normal": [0, 0, 1], "stiffness": 10.0}],
         "object": [{"name": "cube", "shape": "box", "size": [40, 40, 40], "mass": 0.1,
                     "position": [300, -100, -80]}]}
DOWN = dict(roll=180, pitch=0, yaw=0, speed=150, mvacc=2000, wait=True)


def start(arm, tcp_z: float) -> None:
    """The TCP offset of the tool, then enable, position mode, ready."""
    assert arm.set_tcp_offset([0, 0, tcp_z, 0, 0, 0]) == 0
    arm.motion_enable(True)
    arm.set_mode(0)
    arm.set_state(0)


def cube(st) -> dict:
    return st.call(lambda: st.emulator.scene_objects())[0]


def test_sdk_pick_and_place_with_the_xarm_gripper() -> None:
    from xarm.wrapper import XArmAPI

    with running_emulator(6, scene=SCENE, speed=4.0) as st, sdk_pointed_at(st):
        arm = XArmAPI("127.0.0.1")
        try:
            start(arm, 172)
            assert arm.set_gripper_enable(True) == 0
            assert arm.set_gripper_speed(3000) == 0
            assert arm.set_gripper_position(850, wait=True) == 0
            assert arm.set_position(300, -100, 50, **DOWN) == 0
            assert arm.set_position(300, -100, -85, **DOWN) == 0
            assert arm.set_gripper_position(0, wait=True) == 0
            code, pos = arm.get_gripper_position()
            assert code == 0 and pos * 0.1 == pytest.approx(40.0, abs=2.0)
            z0 = cube(st)["position"][2]
            assert cube(st)["held"]
            assert arm.set_position(300, -100, 15, **DOWN) == 0
            assert cube(st)["position"][2] - z0 == pytest.approx(100.0, abs=2.0)
            assert arm.set_position(300, 100, 15, **DOWN) == 0
            assert arm.set_position(300, 100, -84, **DOWN) == 0
            assert arm.set_gripper_position(850, wait=True) == 0
            assert arm.set_position(300, 100, 50, **DOWN) == 0
        finally:
            arm.disconnect()
        end = cube(st)
        assert not end["held"]
        assert end["position"][0] == pytest.approx(300.0, abs=3.0)
        assert end["position"][1] == pytest.approx(100.0, abs=3.0)
        assert end["position"][2] == pytest.approx(-80.0, abs=1.0)
        assert abs(end["rpy"][0]) < 2.0 and abs(end["rpy"][1]) < 2.0


def test_admin_scene_commands_and_the_cli() -> None:
    with running_emulator(6, scene=SCENE, admin=True) as st:
        port = st.ports["admin"]
        with AdminClient("127.0.0.1", port) as a:
            first = json.loads(a.request("scene-objects"))["objects"][0]
            assert first["name"] == "cube" and first["position"][:2] == pytest.approx([300, -100], abs=0.01)
            a.request("scene-place", name="cube", position=[250, 150, -80], rpy=[0, 0, 30])
            placed = json.loads(a.request("scene-objects"))["objects"][0]
            assert placed["position"] == pytest.approx([250, 150, -80], abs=0.5)
            assert placed["rpy"][2] == pytest.approx(30.0, abs=0.1)
            with pytest.raises(AdminRefused, match="no object 'ball'"):
                a.request("scene-place", name="ball", position=[0, 0, 0])
            with pytest.raises(AdminRefused, match="three numbers"):
                a.request("scene-place", name="cube", position=[0, 0])
            a.request("scene-reset")
        out = subprocess.run([sys.executable, "-m", "xarm_emu.cli", "scene", "--json", "--port",
                              str(st.ports["command"]), "--admin-port", str(port)],
                             capture_output=True, text=True, timeout=60)
        assert out.returncode == 0, out.stderr
        back = json.loads(out.stdout)["objects"][0]
        assert back["position"] == pytest.approx([300, -100, -80], abs=0.5)


def test_admin_scene_commands_without_objects_are_refused() -> None:
    with running_emulator(6, admin=True) as st:
        with AdminClient("127.0.0.1", st.ports["admin"]) as a:
            with pytest.raises(AdminRefused, match="no objects"):
                a.request("scene-objects")


def on_table(mass: float, friction: float, table_z: float) -> dict:
    """The scene with the table top at ``table_z`` (mm) and the cube of ``mass`` and ``friction`` on it
    at (300, -100)."""
    cube = {**SCENE["object"][0], "mass": mass, "friction": friction, "position": [300, -100, table_z + 20]}
    return {"plane": [{**SCENE["plane"][0], "point": [0, 0, table_z]}], "object": [cube]}


def _robotiq_pick(mass: float, friction: float, force: int, gripper: str = "robotiq-2f85",
                  tcp_z: float = 174.0, table_z: float = -100.0) -> tuple[dict, dict, int]:
    """The same task with a Robotiq gripper (the 2F-85 unless told) through the SDK's robotiq_*
    calls; returns the cube after the close, after the lift, and gOBJ after the close."""
    from xarm.wrapper import XArmAPI

    scene = on_table(mass, friction, table_z)
    with running_emulator(6, scene=scene, speed=4.0, gripper=gripper) as st, sdk_pointed_at(st):
        arm = XArmAPI("127.0.0.1")
        try:
            start(arm, tcp_z)
            assert arm.robotiq_reset()[0] == 0
            assert arm.robotiq_set_activate()[0] == 0
            assert arm.robotiq_open(speed=0xFF, force=force)[0] == 0
            assert arm.set_position(300, -100, table_z + 150, **DOWN) == 0
            assert arm.set_position(300, -100, table_z + 15, **DOWN) == 0
            assert arm.robotiq_close(speed=0xFF, force=force)[0] == 0
            assert arm.robotiq_get_status()[0] == 0
            gobj = arm.robotiq_status["gOBJ"]
            closed = cube(st)
            assert arm.set_position(300, -100, table_z + 115, **DOWN) == 0
            lifted = cube(st)
        finally:
            arm.disconnect()
    return closed, lifted, gobj


def test_sdk_robotiq_2f85_grips_the_cube_by_contact() -> None:
    closed, lifted, gobj = _robotiq_pick(0.1, 1.0, 0xFF)
    assert gobj == 2 and closed["held"]
    assert lifted["held"] and lifted["position"][2] - closed["position"][2] == pytest.approx(100.0, abs=2.0)


def test_sdk_robotiq_2f140_grips_the_cube_by_contact() -> None:
    """The 2F-140 (fingertips at its 244 mm tool length, so the table 200 mm below the mounting face)
    closes from its 140 mm stroke onto the cube: gOBJ 2 and the cube carried up 100 mm."""
    closed, lifted, gobj = _robotiq_pick(0.1, 1.0, 0xFF, "robotiq-2f140", 244.0, table_z=-200.0)
    assert gobj == 2 and closed["held"]
    assert lifted["held"] and lifted["position"][2] - closed["position"][2] == pytest.approx(100.0, abs=2.0)


def test_sdk_3kg_cube_slips_out_of_the_robotiq_2f85_at_its_lowest_force() -> None:
    closed, lifted, gobj = _robotiq_pick(3.0, 0.5, 0)
    assert gobj == 2
    assert not lifted["held"] and lifted["position"][2] < -75.0


def scene_json(st) -> dict:
    """``xarm-emu scene --json`` of the running emulator ``st`` (its admin channel), the CLI run in
    process."""
    from typer.testing import CliRunner

    from xarm_emu import cli

    out = CliRunner().invoke(cli.app, ["scene", "--json", "--port", str(st.ports["command"]),
                                       "--admin-port", str(st.ports["admin"])])
    assert out.exit_code == 0, out.output
    return json.loads(out.stdout)


def test_sdk_vacuum_gripper_seals_on_the_cube_top_and_carries_it() -> None:
    """The pressure input rises only while the cup lies on the cube's top face; the cube rides with
    the cup while the vacuum is on, reported held by ``xarm-emu scene --json``, and rests where it
    is let go, not held."""
    from xarm.wrapper import XArmAPI

    with running_emulator(6, scene=SCENE, speed=4.0, vacuum=True, admin=True) as st, sdk_pointed_at(st):
        arm = XArmAPI("127.0.0.1")
        try:
            start(arm, 126)
            assert arm.set_position(300, -100, 50, **DOWN) == 0
            # in the air: the pump runs, the pressure never becomes normal (the SDK's wait times out)
            assert arm.set_vacuum_gripper(True, wait=True, timeout=1) != 0
            assert arm.get_vacuum_gripper()[1] == 0
            assert arm.set_vacuum_gripper(False) == 0
            assert arm.set_position(300, -100, -60, **DOWN) == 0  # the cup on the top face (z -60)
            assert arm.set_vacuum_gripper(True, wait=True, timeout=3) == 0
            assert arm.get_vacuum_gripper()[1] == 1
            assert arm.set_position(300, -100, 40, **DOWN) == 0
            lifted = scene_json(st)["objects"][0]
            assert lifted["held"]
            assert lifted["position"][2] == pytest.approx(20.0, abs=2.0)
            assert arm.set_position(300, 100, 40, **DOWN) == 0
            assert arm.set_position(300, 100, -59.5, **DOWN) == 0
            assert arm.set_vacuum_gripper(False, wait=True, timeout=3) == 0
            assert arm.set_position(300, 100, 50, **DOWN) == 0
        finally:
            arm.disconnect()
        end = scene_json(st)["objects"][0]
        assert not end["held"]
        assert end["position"][:2] == pytest.approx([300, 100], abs=3.0)
        assert end["position"][2] == pytest.approx(-80.0, abs=1.0)


def test_sdk_bio_gripper_grips_a_block_by_contact() -> None:
    """The BIO gripper (fingertips at its 150 mm tool length, opening 71..150 mm) closes on an 80 mm
    block: its status says "object" (motion bits 2), its reported opening is the block's width, and
    the block rides 100 mm up with the hand."""
    from xarm.wrapper import XArmAPI

    scene = on_table(0.1, 1.0, -100.0)
    scene["object"][0]["size"] = [40, 80, 40]  # 80 mm across the fingers (flange y)
    with running_emulator(6, scene=scene, speed=4.0, gripper="bio", firmware="2.7.103") as st, \
            sdk_pointed_at(st):
        arm = XArmAPI("127.0.0.1")
        try:
            start(arm, 150)
            assert arm.set_bio_gripper_enable(True) == 0
            assert arm.open_bio_gripper(speed=2000) == 0
            assert arm.set_position(300, -100, 50, **DOWN) == 0
            assert arm.set_position(300, -100, -85, **DOWN) == 0
            assert arm.close_bio_gripper(speed=2000) == 0
            code, status = arm.get_bio_gripper_status()
            assert code == 0 and status & 0x03 == 2  # stopped on an object
            code, opening = arm.get_bio_gripper_g2_position()
            assert code == 0 and opening == pytest.approx(80.0, abs=2.0)
            closed = cube(st)
            assert closed["held"]
            assert arm.set_position(300, -100, 15, **DOWN) == 0
            lifted = cube(st)
        finally:
            arm.disconnect()
    assert lifted["held"] and lifted["position"][2] - closed["position"][2] == pytest.approx(100.0, abs=2.0)
