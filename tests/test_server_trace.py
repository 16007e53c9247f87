"""The command-port trace (`serve --trace`): one JSON line per request with its reply, decoded
through the register table, plus connect/close events; written by the time the server closes.

A firmware 2.x box's trace: every register the box answers is named and decoded with the claimed
firmware's table, ``request_error`` appears only for what the box refused, standard Modbus requests
get lines of their own, and ``xarm-emu replay`` reads both kinds.
"""

from __future__ import annotations

import json
import math
import socket
import struct
import time
from pathlib import Path
from typing import Any

import pytest
from helpers import free_ports, port_args, run_cli, sdk_ready, serve_subprocess

from xarm_emu.client import Client
from xarm_emu.protocol.frame import encode_request
from xarm_emu.replay import replay
from xarm_emu.server.app import ServerThread
from xarm_emu.testing import running_emulator


def _no_constants(name: str) -> None:
    raise AssertionError(f"{name} is not strict JSON")


def lines(path: Path) -> list[dict]:
    """The trace's records, parsed as strict JSON (no bare NaN or Infinity)."""
    return [json.loads(line, parse_constant=_no_constants) for line in path.read_text().splitlines()]


def test_every_request_and_reply_is_traced(make_server, tmp_path: Path) -> None:
    path = tmp_path / "trace.jsonl"
    st: ServerThread = make_server(trace=path)
    with Client("127.0.0.1", st.ports["command"]) as c:
        c.get_state()
        c.get_state()  # a cached pure read is traced too
        c.call(36, mass=1.0, center=(400.0, 0.0, 200.0))  # manual 2.1.4 example
    with socket.create_connection(("127.0.0.1", st.ports["command"]), timeout=2.0) as s:
        s.sendall(encode_request(0x1234, 250))  # unknown register: warning 13
        assert s.recv(64)[7] & 0x20  # an 8-byte reply: header, register, state
        s.sendall(encode_request(0x1235, 36, struct.pack("<f", math.nan)))  # malformed: warning 12
        assert s.recv(64)[7] & 0x20
        s.sendall(encode_request(0x1236, 44, struct.pack("<7f", math.nan, math.inf, -math.inf, 0, 0, 0, 0)))
        assert s.recv(64)[7] & 0x20  # NaN joints: warning 12
    st.stop()
    recs = lines(path)
    events = [r["event"] for r in recs if "event" in r]
    assert events == ["start", "connect", "close", "connect", "close"]
    assert {k: v for k, v in recs[0].items() if k not in ("t", "wall")} == {  # the box that answered
        "event": "start", "model": "6", "firmware": str(st.emulator.firmware.version), "gripper": "xarm",
        "vacuum": False, "linear_track": None, "ft_sensor": False, "ft_noise": False,
        "robot_sn": st.emulator.controller.robot_sn, "box_sn": st.emulator.controller.box_sn, "saved": None,
        "calibration": None}
    cmds = [r for r in recs if "register" in r]
    assert [r["register"] for r in cmds] == [13, 13, 36, 250, 36, 44]
    assert cmds[0]["name"] == "GET_STATE" and cmds[0]["values"] == {"state": 4}
    load = cmds[2]
    assert load["params"] == "0000803f0000c843000000000000484" + "3"
    assert load["request"] == {"mass": 1.0, "center": [400.0, 0.0, 200.0]} and load["state"] == 0x10
    assert cmds[3]["name"] is None and cmds[3]["tid"] == 0x1234 and cmds[3]["state"] & 0x20
    assert "request_error" in cmds[4]
    assert cmds[5]["request"]["joints"][:4] == ["NaN", "Infinity", "-Infinity", 0.0]
    assert all(r["peer"].startswith("127.0.0.1:") for r in recs[1:])  # all but the start line
    ts = [r["t"] for r in recs]
    assert ts == sorted(ts)


def test_trace_appends_and_a_bad_path_is_a_clear_error(make_server, tmp_path: Path) -> None:
    path = tmp_path / "trace.jsonl"
    for _ in range(2):
        st = make_server(trace=path)
        with Client("127.0.0.1", st.ports["command"]) as c:
            c.get_version()
        st.stop()
    assert [r.get("register") for r in lines(path) if "register" in r] == [1, 1]
    with pytest.raises(ValueError, match="cannot open the trace file"):
        make_server(trace=tmp_path / "missing" / "trace.jsonl")


def test_serve_trace_from_the_cli(tmp_path: Path) -> None:
    path = tmp_path / "t.jsonl"
    cmd, normal, rich, develop = free_ports(4)
    with serve_subprocess(tmp_path, *port_args(cmd, normal, rich, develop), "--trace", str(path)) as proc:
        code, out = run_cli("status", "--json", "--wait", "30", "--port", str(cmd), "--report-port",
                            str(develop))
        assert code == 0, out
    assert proc.returncode == 0  # SIGTERM closes the emulator cleanly: the trace is complete
    names = [r.get("name") for r in lines(path) if "register" in r]
    assert names[:3] == ["GET_VERSION", "GET_STATE", "GET_ERROR"]


# -- a firmware 2.x box ----------------------------------------------------------------------------------

FW2 = "2.7.103"


def _session(arm: Any) -> None:
    """What a program of firmware 2.x does: moves with wait=True, relative moves, velocity
    control, trajectories, the counter, reduced mode, the F/T sensor, standard Modbus."""
    sdk_ready(arm)
    assert arm.set_position(x=300, y=0, z=300, roll=180, pitch=0, yaw=0, speed=200, wait=True) == 0
    assert arm.set_position(x=10, relative=True, speed=200, wait=True) == 0
    assert arm.set_position_aa([0, 0, -10, 0, 0, 0], relative=True, speed=200, wait=True) == 0
    assert arm.set_servo_angle(angle=[5, 0, 0, 0, 0, 0], relative=True, speed=30, wait=True) == 0
    assert arm.move_circle([310, 10, 300, 180, 0, 0], [300, 20, 300, 180, 0, 0], 50, speed=100,
                           wait=True) == 0
    assert arm.set_counter_reset() == 0 and arm.set_counter_increase() == 0
    assert arm.set_reduced_max_tcp_speed(500) == 0 and arm.set_reduced_mode(True) == 0
    assert arm.set_reduced_mode(False) == 0
    assert arm.set_mode(4) == 0 and arm.set_state(0) == 0
    time.sleep(0.1)
    assert arm.vc_set_joint_velocity([2, 0, 0, 0, 0, 0], duration=0.2) == 0
    time.sleep(0.3)
    assert arm.set_mode(0) == 0 and arm.set_state(0) == 0
    assert arm.start_record_trajectory() == 0
    time.sleep(0.2)
    assert arm.stop_record_trajectory() == 0
    assert arm.save_record_trajectory("trace-test.traj", wait=True) == 0
    assert arm.ft_sensor_enable(1) == 0
    assert arm.get_ft_sensor_data()[0] == 0
    assert arm.ft_sensor_enable(0) == 0
    assert arm.read_holding_registers(32, 2)[0] == 0
    assert arm.write_single_holding_register(256, 42) == 0


def test_a_2x_session_leaves_a_trace_without_false_alarms(tmp_path: Path, sdk_arm: Any) -> None:
    path = tmp_path / "trace.jsonl"
    with running_emulator(firmware=FW2, ft_sensor=True, trace=path) as st:
        arm = sdk_arm(st)
        _session(arm)
        arm.disconnect()
    recs = [json.loads(line) for line in path.read_text().splitlines()]
    private = [r for r in recs if r.get("protocol") in (1, 2, 3) and "register" in r]
    assert len(private) > 50
    assert [r["register"] for r in private if r["name"] is None] == []
    assert [(r["register"], r["request_error"]) for r in private if "request_error" in r] == []
    long_moves = [r for r in private if r["register"] == 21 and len(r["params"]) // 2 >= 43]
    assert long_moves and all("only_check_type" in r["request"] for r in long_moves)
    circles = [r for r in private if r["register"] == 27]
    assert circles and all(len(r["params"]) // 2 == 67 and "coord" in r["request"] for r in circles)
    modbus = [r for r in recs if r.get("protocol") == 0]
    read, write = modbus[-2:]
    assert (read["function"], read["address"], read["count"], read["exception"]) == (3, 32, 2, None)
    assert read["read"] == [0, 2]
    assert (write["function"], write["address"], write["values"], write["exception"]) == (6, 256, [42], None)
    assert write["pdu"] == "06010000" + "2a" and write["reply"] == write["pdu"]


def test_replay_reads_modbus_lines(tmp_path: Path) -> None:
    path = tmp_path / "trace.jsonl"
    from helpers import connect, recv_frame

    with running_emulator(firmware=FW2, trace=path) as st, connect(st.ports["command"]) as s:
        s.sendall(bytes.fromhex("0001000000060106010000" + "07"))  # holding 256 = 7
        recv_frame(s)
        s.sendall(bytes.fromhex("000200000006010301000001"))  # read it back
        assert recv_frame(s).hex().endswith("03020007")
        s.sendall(bytes.fromhex("00030000000601060020" + "0003"))  # mode 3: exception 3
        assert recv_frame(s).hex().endswith("8603")
    recs = [json.loads(line) for line in path.read_text().splitlines() if "event" not in line]
    assert [(r["function"], r["exception"]) for r in recs] == [(6, None), (3, None), (6, 3)]
    assert recs[1]["read"] == [7]
    result = replay(path)
    assert result.requests == 3 and result.differences == []
    changed = tmp_path / "changed.jsonl"
    recs[1]["reply"] = "03020008"
    changed.write_text("".join(json.dumps(r) + "\n" for r in recs))
    diff = replay(changed).first
    assert diff is not None and diff.line == 2 and diff.field == "reply" and diff.replayed == "03020007"
