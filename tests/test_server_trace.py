"""The command-port trace (`serve --trace`): one JSON line per request with its reply, decoded
through the register table, plus connect/close events; written by the time the server closes."""

from __future__ import annotations

import json
import math
import socket
import struct
from pathlib import Path

import pytest
from helpers import free_ports, port_args, run_cli, serve_subprocess

from xarm_emu.client import Client
from xarm_emu.protocol.frame import encode_request
from xarm_emu.server.app import ServerThread


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
    assert events == ["connect", "close", "connect", "close"]
    cmds = [r for r in recs if "register" in r]
    assert [r["register"] for r in cmds] == [13, 13, 36, 250, 36, 44]
    assert cmds[0]["name"] == "GET_STATE" and cmds[0]["values"] == {"state": 4}
    load = cmds[2]
    assert load["params"] == "0000803f0000c843000000000000484" + "3"
    assert load["request"] == {"mass": 1.0, "center": [400.0, 0.0, 200.0]} and load["state"] == 0x10
    assert cmds[3]["name"] is None and cmds[3]["tid"] == 0x1234 and cmds[3]["state"] & 0x20
    assert "request_error" in cmds[4]
    assert cmds[5]["request"]["joints"][:4] == ["NaN", "Infinity", "-Infinity", 0.0]
    assert all(r["peer"].startswith("127.0.0.1:") for r in recs)
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
