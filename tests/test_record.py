"""Sessions recorded to Rerun (`serve --record`, `xarm-emu record`), read back with rerun-sdk's own
reader: the joints the reports carried, the commands sent, the errors raised, the arm's geometry."""

from __future__ import annotations

import math
import threading
import time
from pathlib import Path
from typing import Any

import pytest
from helpers import run_cli, wait_for

from xarm_emu.client import Client
from xarm_emu.client.admin import AdminClient
from xarm_emu.controller.emulator import Emulator
from xarm_emu.record import attach_recorder
from xarm_emu.server.app import ServerConfig, ServerThread
from xarm_emu.testing import running_emulator

rr_chunk = pytest.importorskip("rerun.chunk")


def read_back(path: Path) -> dict[str, dict[str, list[Any]]]:
    """Entity path -> {"time": seconds, "value": scalar or text, "level": ...}, through rerun-sdk."""
    out: dict[str, dict[str, list[Any]]] = {}
    for chunk in rr_chunk.RrdReader(str(path)).stream().collect().stream():
        batch = chunk.to_record_batch()
        names = batch.schema.names
        if "time" not in names:
            continue
        entry = out.setdefault(chunk.entity_path, {"time": [], "value": [], "level": []})
        entry["time"] += [ns / 1e9 for ns in batch.column("time").cast("int64").to_pylist()]
        if "Scalars:scalars" in names:
            entry["value"] += [v[0] for v in batch.column("Scalars:scalars").to_pylist()]
        elif "TextLog:text" in names:
            entry["value"] += [v[0] for v in batch.column("TextLog:text").to_pylist()]
            entry["level"] += [v[0] for v in batch.column("TextLog:level").to_pylist()]
        elif "LineStrips3D:strips" in names:
            entry["value"] += batch.column("LineStrips3D:strips").to_pylist()
        elif "Boxes3D:centers" in names:
            entry["value"] += batch.column("Boxes3D:centers").to_pylist()
            if "Boxes3D:colors" in names:  # the colours where the entity has them (a cell's belts)
                entry["level"] += batch.column("Boxes3D:colors").to_pylist()
    for entry in out.values():  # chunks come in any order
        order = sorted(range(len(entry["time"])), key=entry["time"].__getitem__)
        for key in ("time", "value", "level"):
            if entry[key]:
                entry[key] = [entry[key][i] for i in order]
    return out


def test_served_session_of_a_20_s_program_reads_back(tmp_path: Path) -> None:
    path = tmp_path / "session.rrd"
    cfg = ServerConfig(host="127.0.0.1", port=0, normal_port=0, rich_port=0, develop_port=0, speed=10.0,
                       admin=True)
    st = ServerThread(Emulator(6, config_dir=tmp_path / "config"), cfg,
                      compose=(lambda srv: attach_recorder(srv, path),)).start()
    try:
        with Client("127.0.0.1", st.ports["command"]) as c:
            c.motion_enable(True)
            c.set_mode(0)
            c.set_state(0)
            t0 = st.call(lambda: st.emulator.time)
            for target in (0.6, -0.6, 0.3):  # about 20 s of controller time in all
                c.call(23, joints=(target, -0.2, -0.3, 0, 0.5, 0, 0), speed=0.13, acc=2.0, mvtime=0.0)
            assert wait_for(lambda: c.get_cmdnum() == 0 and c.get_state() == 2, timeout=30.0)
            assert st.call(lambda: st.emulator.time) - t0 >= 20.0
            with AdminClient("127.0.0.1", st.ports["admin"]) as a:
                a.request("error", code="C31")
            assert wait_for(lambda: c.get_err_warn()[0] == 31)
            time.sleep(0.5)  # the rich report (5 Hz) carries the error
    finally:
        st.stop()
    rec = read_back(path)
    j1 = rec["/joints/j1"]
    assert j1["value"][-1] == pytest.approx(math.degrees(0.3), abs=0.05)
    # The turning points, sampled at 100 Hz of wall time while the controller runs ten times faster
    # (and a loaded machine skips frames, then delivers a few at once): never beyond them, and short
    # of them by no more than the joint moves (0.13 rad/s) in the controller time of the longest
    # pause in the recording's wall clock within five samples of the extreme.
    for extreme, turn in ((max, 0.6), (min, -0.6)):
        got = extreme(j1["value"])
        i = j1["value"].index(got)
        t = j1["time"]
        near = t[max(i - 5, 0):i + 6]
        gap = 10.0 * max(b - a for a, b in zip(near, near[1:], strict=False))
        assert abs(got) <= abs(math.degrees(turn)) + 0.05
        assert abs(got - math.degrees(turn)) <= math.degrees(0.13 * gap) + 0.05, (got, gap)
    assert len(j1["value"]) > 100  # the develop report at 100 Hz over about 2 s of wall time
    assert j1["time"] == sorted(j1["time"])
    assert rec["/error"]["value"][-1] == 31 and rec["/error"]["value"][0] == 0
    events = rec["/events"]
    assert any(text.startswith("error C31") for text in events["value"])
    assert events["level"][[t.startswith("error C31") for t in events["value"]].index(True)] == "ERROR"
    assert any(text.startswith("state 1") for text in events["value"])
    moves = [t for t in rec["/commands"]["value"] if t.startswith("23 MOVE_JOINT")]
    assert len(moves) == 3
    links = rec["/arm/links"]["value"][-1][0]  # one strip: base, then each joint origin
    assert links[0] == [0.0, 0.0, 0.0] and len(links) >= 7
    tcp_x = rec["/tcp/x"]["value"][-1]
    assert links[-1][0] == pytest.approx(tcp_x, abs=60.0)  # the last frame sits near the TCP


def test_served_pick_records_the_objects_poses(tmp_path: Path) -> None:
    """A cube picked and lifted 100 mm through the unchanged SDK under ``serve --record``: the
    recording has the cube where the physics world had it, on the table first, held and lifted last."""
    pytest.importorskip("mujoco")
    from xarm.wrapper import XArmAPI

    from xarm_emu.controller.scene import contact
    from xarm_emu.testing import sdk_pointed_at

    path = tmp_path / "pick.rrd"
    scene = contact.parse_scene({
        "plane": [{"name": "table", "point": [0, 0, -100], "normal": [0, 0, 1], "stiffness": 10.0}],
        "object": [{"name": "cube", "shape": "box", "size": [40, 40, 40], "mass": 0.1,
                    "position": [300, -100, -80]}]})
    cfg = ServerConfig(host="127.0.0.1", port=0, normal_port=0, rich_port=0, develop_port=0, speed=4.0)
    st = ServerThread(Emulator(6, config_dir=tmp_path / "config", scene=scene), cfg,
                      compose=(lambda srv: attach_recorder(srv, path),)).start()
    down = dict(roll=180, pitch=0, yaw=0, speed=150, mvacc=2000, wait=True)
    try:
        with sdk_pointed_at(st):
            arm = XArmAPI("127.0.0.1")
            try:
                assert arm.set_tcp_offset([0, 0, 172, 0, 0, 0]) == 0
                arm.motion_enable(True)
                arm.set_mode(0)
                arm.set_state(0)
                assert arm.set_gripper_enable(True) == 0
                assert arm.set_gripper_speed(3000) == 0
                assert arm.set_gripper_position(850, wait=True) == 0
                assert arm.set_position(300, -100, 50, **down) == 0
                assert arm.set_position(300, -100, -85, **down) == 0
                assert arm.set_gripper_position(0, wait=True) == 0
                assert arm.set_position(300, -100, 15, **down) == 0
                time.sleep(0.5)  # a few more geometry entries of the lifted cube
            finally:
                arm.disconnect()
        lifted = st.call(lambda: st.emulator.scene_objects())[0]
    finally:
        st.stop()
    rec = read_back(path)
    centres = [c[0] for c in rec["/objects/cube"]["value"]]
    assert len(centres) > 10
    assert centres[0] == pytest.approx([300.0, -100.0, -80.0], abs=0.5)  # resting on the table
    assert centres[-1] == pytest.approx(lifted["position"], abs=0.5)  # where the world has it
    assert centres[-1][2] == pytest.approx(20.0, abs=3.0)  # lifted 100 mm
    held = rec["/objects/cube/held"]["value"]
    assert held[0] == 0.0 and held[-1] == 1.0


def test_served_cell_records_the_belt_the_beam_and_the_parts(tmp_path: Path) -> None:
    """The conveyor cell of examples/08 under ``serve --record``, its belt switched on and off through
    CO0: the recording has the belt's box with its running state, the photo-eye's beam with its
    interrupted state, and the part the feeder placed riding the belt toward the beam."""
    pytest.importorskip("mujoco")
    from xarm_emu.controller.scene import contact

    path = tmp_path / "cell.rrd"
    scene = contact.load_scene(Path(__file__).parents[1] / "examples" / "conveyor_cell.toml")
    cfg = ServerConfig(host="127.0.0.1", port=0, normal_port=0, rich_port=0, develop_port=0, speed=4.0)
    st = ServerThread(Emulator(6, config_dir=tmp_path / "config", scene=scene), cfg,
                      compose=(lambda srv: attach_recorder(srv, path),)).start()

    def cell() -> dict[str, Any]:
        return st.call(lambda: st.emulator.physics.cell.status())  # type: ignore[union-attr, return-value]

    try:
        with Client("127.0.0.1", st.ports["command"]) as c:
            time.sleep(0.3)  # a few entries of the stopped belt and the clear beam
            c.call(134, digital=0x0101)  # CO0 on (CGPIO_SET_DIGIT: enable bit 0, value 1)
            # a generous bound: a busy machine runs the engine's periods slower than the wall clock
            assert wait_for(lambda: cell()["sensors"][0]["interrupted"], timeout=60.0)
            c.call(134, digital=0x0100)  # CO0 off
            assert wait_for(lambda: not cell()["conveyors"][0]["running"], timeout=30.0)
            time.sleep(0.3)
        placed = st.call(lambda: st.emulator.scene_objects())[0]
    finally:
        st.stop()
    rec = read_back(path)
    running = rec["/cell/belts/belt/running"]["value"]
    assert running[0] == 0.0 and 1.0 in running and running[-1] == 0.0
    cut = rec["/cell/sensors/eye/interrupted"]["value"]
    assert cut[0] == 0.0 and cut[-1] == 1.0
    belt = rec["/cell/belts/belt"]
    assert belt["value"][-1][0] == pytest.approx([380.0, 300.0, -80.0])  # the belt's box
    assert len(set(map(tuple, belt["level"]))) == 2  # grey stopped, green running
    assert "/cell/sensors/eye" in rec
    xs = [v[0][0] for v in rec["/objects/part-1"]["value"]]
    # placed at the belt's far end (x 520; an entry every 0.1 s of wall time is 80 mm of belt at
    # speed 4), carried toward the arm, stopped in the beam
    assert xs[0] > 430.0 and xs[-1] < 340.0
    assert all(b <= a + 0.1 for a, b in zip(xs, xs[1:], strict=False))  # never back (0.1 mm: settling)
    assert rec["/objects/part-1"]["value"][-1][0] == pytest.approx(placed["position"], abs=0.5)


def test_record_command_against_a_running_box(tmp_path: Path) -> None:
    path = tmp_path / "box.rrd"
    with running_emulator(speed=5.0) as st:
        with Client("127.0.0.1", st.ports["command"]) as c:
            c.motion_enable(True)
            c.set_mode(0)
            c.set_state(0)
            result: list[tuple[int, str]] = []
            th = threading.Thread(target=lambda: result.append(run_cli(
                "record", str(path), "--port", str(st.ports["command"]), "--develop-port",
                str(st.ports["develop"]), "--rich-port", str(st.ports["rich"]), "--duration", "1.5")))
            th.start()
            # the recorder reads the develop port before the move starts (a busy machine starts the
            # command's process in well over a second)
            assert wait_for(lambda: bool(st.server.reports.streams["develop"].readers), timeout=30.0)
            time.sleep(0.1)
            c.call(23, joints=(-0.4, 0, 0, 0, 0, 0, 0), speed=1.0, acc=10.0, mvtime=0.0)
            th.join(10)
    code, out = result[0]
    assert code == 0 and f"rerun {path}" in out
    rec = read_back(path)
    assert rec["/joints/j1"]["value"][0] == pytest.approx(0.0, abs=1e-3)
    assert rec["/joints/j1"]["value"][-1] == pytest.approx(math.degrees(-0.4), abs=0.05)
    assert "/joints/j7" not in rec  # an xArm6: six joints
    assert rec["/events"]["value"][0].startswith("recording 127.0.0.1: 6,6,")


def test_record_unreachable_box_is_one_line(tmp_path: Path) -> None:
    code, out = run_cli("record", str(tmp_path / "x.rrd"), "--port", "1")
    assert code == 1 and out.startswith("cannot reach the control box at 127.0.0.1:1")


def test_serve_record_writes_a_recording_that_sigterm_completes(tmp_path: Path) -> None:
    from helpers import free_ports, port_args, serve_subprocess

    path = tmp_path / "served.rrd"
    cmd, normal, rich, develop = free_ports(4)
    with serve_subprocess(tmp_path, *port_args(cmd, normal, rich, develop), "--speed", "5",
                          "--record", str(path)) as proc:
        assert run_cli("status", "--wait", "20", "--port", str(cmd))[0] == 0
        with Client("127.0.0.1", cmd) as c:
            c.motion_enable(True)
            c.set_mode(0)
            c.set_state(0)
            c.call(23, joints=(0.4, 0, 0, 0, 0, 0, 0), speed=1.0, acc=10.0, mvtime=0.0)
            assert wait_for(lambda: c.get_state() == 2)
        time.sleep(0.3)
        proc.terminate()
        out, _ = proc.communicate(timeout=10)
    assert proc.returncode == 0
    assert f"recording to {path}; open it with: rerun {path}" in out.replace("\n", " ")
    rec = read_back(path)
    assert rec["/joints/j1"]["value"][-1] == pytest.approx(math.degrees(0.4), abs=0.05)
    assert any(t.startswith("23 MOVE_JOINT from 127.0.0.1:") for t in rec["/commands"]["value"])
