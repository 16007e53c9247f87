"""The wire trace of a firmware 2.x box: every register the box answers is named and decoded with the
claimed firmware's table, ``request_error`` appears only for what the box refused, standard Modbus
requests get lines of their own, and ``xarm-emu replay`` reads both kinds."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

from helpers import sdk_ready

from xarm_emu.replay import replay
from xarm_emu.testing import running_emulator

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
