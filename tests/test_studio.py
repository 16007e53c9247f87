"""``serve --studio``: the Studio HTTP calls of the unchanged SDK answered from the emulator's own
configuration and trajectory files."""

from __future__ import annotations

import json
import socket
import time
import urllib.request
from typing import Any

import pytest
from helpers import sdk_ready, wait_for

from xarm_emu.server.app import ServerThread
from xarm_emu.server.studio import CODE_NOT_FOUND, STUDIO_PORT, attach_studio


def post(port: int, path: str, body: Any) -> Any:
    req = urllib.request.Request(f"http://127.0.0.1:{port}/{path}", json.dumps(body).encode())
    with urllib.request.urlopen(req, timeout=5) as r:
        return json.loads(r.read())


def start(tmp_path: Any, port: int = 0, firmware: str = "1.6.0") -> ServerThread:
    from xarm_emu.controller.emulator import Emulator
    from xarm_emu.protocol.firmware import profile_for
    from xarm_emu.server.app import ServerConfig

    emu = Emulator(6, config_dir=tmp_path / "config", firmware=profile_for(firmware))
    cfg = ServerConfig(host="127.0.0.1", port=0, normal_port=0, rich_port=0, develop_port=0)
    return ServerThread(emu, cfg, compose=(lambda s: attach_studio(s, "127.0.0.1", port),)).start()


def test_initial_point_is_kept_in_the_config_dir(tmp_path: Any) -> None:
    srv = start(tmp_path)
    try:
        port = srv.ports["studio"]
        assert post(port, "v2/api", {"cmd": "XArm.xarm_initial_point", "args": [], "kwargs": {}}) == \
            {"code": 0, "data": [0.0] * 7}
        point = [10, -20, 30, 0, 45, 0, 0]
        assert post(port, "v2/api", {"cmd": "Core.command.xarm_set_initial_point",
                                     "args": [{"point": point}], "kwargs": {}})["code"] == 0
        assert post(port, "v2/api", {"cmd": "XArm.xarm_initial_point", "args": []})["data"] == point
        bad = post(port, "v2/api", {"cmd": "Core.command.xarm_set_initial_point",
                                    "args": [{"point": ["x"]}]})
        assert bad["code"] != 0
    finally:
        srv.stop()
    again = start(tmp_path)
    try:
        assert post(again.ports["studio"], "v2/api", {"cmd": "XArm.xarm_initial_point"})["data"] == point
    finally:
        again.stop()


def test_trajectory_list_and_delete_follow_the_saved_files(tmp_path: Any) -> None:
    srv = start(tmp_path)
    try:
        def save() -> None:
            c = srv.emulator.controller
            from xarm_emu.controller.applications import trajectory

            trajectory.store_of(c).write("a.traj", [c.q.copy()] * 250, 0.01, 6)

        srv.call(save)
        port = srv.ports["studio"]
        assert post(port, "cmd", {"cmd": "xarm_list_trajs"}) == {"res": [0, [{"name": "a", "count": 250}]]}
        gone = post(port, "v2/api", {"cmd": "Core.command.xarm_delete_traj", "args": [{"filename": "a"}]})
        assert gone["code"] == 0
        assert not (tmp_path / "config" / "trajectories" / "a.traj").exists()
        assert post(port, "cmd", {"cmd": "xarm_list_trajs"}) == {"res": [0, []]}
        again = post(port, "v2/api", {"cmd": "Core.command.xarm_delete_traj", "args": [{"filename": "a"}]})
        assert again["code"] == CODE_NOT_FOUND
    finally:
        srv.stop()


def test_unknown_command_and_bad_body_get_an_answer(tmp_path: Any) -> None:
    srv = start(tmp_path)
    try:
        port = srv.ports["studio"]
        assert post(port, "v2/api", {"cmd": "XArm.nothing"})["code"] != 0
        req = urllib.request.Request(f"http://127.0.0.1:{port}/v2/api", b"not json")
        with urllib.request.urlopen(req, timeout=5) as r:
            assert json.loads(r.read())["code"] != 0
    finally:
        srv.stop()


def _studio_port_free() -> bool:
    with socket.socket() as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as the HTTP server binds
        try:
            s.bind(("127.0.0.1", STUDIO_PORT))
        except OSError:
            return False
    return True


def test_the_sdk_studio_calls(tmp_path: Any, sdk_arm: Any) -> None:
    if not _studio_port_free():
        pytest.skip("port 18333 (Studio) is in use: stop what holds it to run this test")
    srv = start(tmp_path, STUDIO_PORT, firmware="1.11.100")  # trajectory recording
    try:
        arm = sdk_arm(srv)
        sdk_ready(arm)
        assert arm.set_initial_point([1, 2, 3, 4, 5, 6, 0]) == 0
        assert arm.get_initial_point() == (0, [1, 2, 3, 4, 5, 6, 0])
        assert arm.set_mount_direction(90, 45) == 0
        code, (tilt, rotation) = arm.get_mount_direction()
        assert code == 0 and abs(tilt - 90) < 0.01 and abs(rotation - 45) < 0.01
        assert arm.set_mode(2) == 0 and arm.set_state(0) == 0
        ctl = srv.emulator.controller
        assert wait_for(lambda: ctl.mode == 2 and ctl.state == 2)
        assert arm.start_record_trajectory() == 0
        time.sleep(0.3)
        assert arm.stop_record_trajectory() == 0
        assert arm.save_record_trajectory("t1", wait=True, timeout=10) == 0
        code, trajs = arm.get_trajectories()
        assert code == 0 and [t["name"] for t in trajs] == ["t1"]
        assert arm.delete_trajectory("t1") == 0
        assert arm.get_trajectories() == (0, [])
        app = tmp_path / "config" / "blockly" / "demo"
        app.mkdir(parents=True)
        assert arm.delete_blockly_app("demo") == 0
        assert not app.exists()
    finally:
        srv.stop()
