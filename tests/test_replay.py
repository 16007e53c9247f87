"""`xarm-emu replay`: a recorded command trace sent into a fresh emulator in stepped time; the same
program gives the same replies, a changed one shows its first differing reply."""

from __future__ import annotations

import json
import struct
import time
from pathlib import Path

import pytest
from helpers import run_cli, wait_for

from xarm_emu.client import Client
from xarm_emu.replay import replay
from xarm_emu.testing import running_emulator


@pytest.fixture(scope="module")
def trace(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The trace of a program that moves joint 1 and reads joints and pose while it moves."""
    path = tmp_path_factory.mktemp("replay") / "wire.jsonl"
    with running_emulator(speed=5.0, trace=path) as st:
        with Client("127.0.0.1", st.ports["command"]) as c:
            c.get_version()
            c.motion_enable(True)
            c.set_mode(0)
            c.set_state(0)
            c.call(23, joints=(0.7, -0.2, 0, 0, 0.3, 0, 0), speed=1.0, acc=5.0, mvtime=0.0)
            for _ in range(30):
                c.get_joints()
                c.get_position()
                time.sleep(0.01)
            assert wait_for(lambda: c.get_state() == 2)
            c.get_joints()
    return path


def test_unchanged_program_replays_without_difference(trace: Path) -> None:
    result = replay(trace)
    assert result.requests > 60 and result.differences == []
    code, out = run_cli("replay", str(trace))
    assert code == 0 and out.strip() == f"{result.requests} requests replayed: every reply is the same"


def test_changed_program_shows_its_first_differing_reply(trace: Path, tmp_path: Path) -> None:
    lines = [json.loads(line) for line in trace.read_text().splitlines()]
    move = next(r for r in lines if r.get("register") == 23)
    params = bytearray.fromhex(move["params"])
    params[0:4] = struct.pack("<f", 0.5)  # the program now moves joint 1 to 0.5 rad
    move["params"] = params.hex()
    changed = tmp_path / "changed.jsonl"
    changed.write_text("".join(json.dumps(r) + "\n" for r in lines))
    first_read = next(n for n, r in enumerate(lines, start=1)
                      if r.get("register") == 42 and r["t"] > move["t"] + 0.02)
    result = replay(changed)
    diff = result.first
    # the first reply that shows where the arm is (joints or TCP pose) after the changed move
    read = {("GET_JOINT_POS", "joints"), ("GET_TCP_POSE", "pose")}
    assert diff is not None and (diff.name, diff.field) in read
    assert diff.t >= move["t"] and diff.line <= first_read
    assert diff.replayed != diff.recorded and len(diff.replayed) == len(diff.recorded)
    code, out = run_cli("replay", str(changed))
    assert code == 1 and f"first difference: line {diff.line}," in out
    assert f"register {diff.register} ({diff.name}): {diff.field} was" in out


def test_other_arm_differs_at_the_version_reply(trace: Path) -> None:
    diff = replay(trace, model=7).first
    assert diff is not None and diff.name == "GET_VERSION"


def test_bad_trace_is_one_line(tmp_path: Path) -> None:
    bad = tmp_path / "bad.jsonl"
    bad.write_text('{"t": 0.1, "register": 13}\n')
    code, out = run_cli("replay", str(bad))
    assert code == 2
    assert out.strip() == (f"{bad} line 1: a request line needs t, tid, protocol, register, params and "
                           "reply (unit and pdu for protocol 0)")
