"""`xarm-emu replay` of a run in which something changed the emulator from outside the protocol: the
trace writes each fault schedule entry as it fires and each admin change as it is carried out, at
its control period, and the replay carries it out again there (server/trace.py, replay.py)."""

from __future__ import annotations

import json
import signal
import threading
import time
from collections.abc import Callable
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest
from helpers import accepts, port_args, run_cli, sdk_ready, serve_ports, serve_subprocess, wait_for

from xarm_emu.client import Client
from xarm_emu.client.admin import AdminClient
from xarm_emu.replay import OUTSIDE, read_requests, replay
from xarm_emu.testing import running_emulator, sdk_pointed_at

#: The README's CI recipe with one fault: C31 one second (controller time) into the first move.
SCHEDULE = '[[fault]]\nafter = "motion"\nat = 1.0\ndo = "error"\ncode = "C31"\n'


def _lines(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def _without_outside(path: Path) -> list[dict]:
    return [r for r in _lines(path) if r.get("event") != OUTSIDE]


def _write(path: Path, lines: list[dict]) -> Path:
    path.write_text("".join(json.dumps(r) + "\n" for r in lines))
    return path


@pytest.fixture(scope="module")
def recipe(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The trace of the README's CI recipe: ``serve --speed 5 --trace --faults --config-dir`` in its
    own process, ``status --wait`` as the readiness probe, the unchanged SDK moving (the fault lands
    in the move), reading the state and codes, clearing, moving again; SIGTERM."""
    from xarm.wrapper import XArmAPI

    tmp = tmp_path_factory.mktemp("recipe")
    faults = tmp / "faults.toml"
    faults.write_text(SCHEDULE)
    path = tmp / "wire.jsonl"
    (cmd, normal, rich, develop), last = serve_ports()
    ports = {"command": cmd, "normal": normal, "rich": rich, "develop": develop}
    with serve_subprocess(tmp / "emu-config", "--speed", "5", "--trace", str(path), "--faults", str(faults),
                          *port_args(cmd, normal, rich, develop)) as proc:
        assert run_cli("status", "--port", str(cmd), "--wait", "20")[0] == 0
        assert wait_for(lambda: accepts(last))
        with sdk_pointed_at(SimpleNamespace(ports=ports)):  # type: ignore[arg-type]
            arm = XArmAPI("127.0.0.1", is_radian=False, forbid_uds=True)
            try:
                sdk_ready(arm)
                arm.set_position(300, 100, 200, 180, 0, 0, speed=50, wait=True)  # 1.6 s: the fault stops it
                assert arm.get_state() == (0, 4) and arm.get_err_warn_code()[1] == [31, 0]
                arm.clean_error()
                arm.motion_enable(True)
                arm.set_state(0)
                arm.set_position(250, 0, 250, 180, 0, 0, speed=200, wait=True)
                arm.get_position()
            finally:  # its sockets close at once; its threads notice about a second later
                threading.Thread(target=arm.disconnect, name="sdk-disconnect", daemon=True).start()
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(10) == 0
    return path


def test_recipe_with_a_fault_schedule_replays_without_difference(recipe: Path) -> None:
    outside = [r for r in _lines(recipe) if r.get("event") == OUTSIDE]
    assert len(outside) == 1
    fault = outside[0]
    assert fault["source"] == "schedule" and fault["request"] == {"cmd": "error", "code": "C31"}
    assert fault["message"].startswith("injected C31")
    assert fault["t"] == pytest.approx(fault["period"] * 0.004)
    result = replay(recipe)
    assert result.differences == [] and result.outside == 1 and result.requests > 20
    code, out = run_cli("replay", str(recipe))
    assert code == 0, out
    assert out.strip() == (f"{result.requests} requests replayed with 1 changes from outside the protocol "
                           "(faults, inputs): every reply is the same")


def test_a_changed_fault_in_the_trace_names_the_first_differing_reply(recipe: Path, tmp_path: Path) -> None:
    lines = _lines(recipe)
    n_fault = next(n for n, r in enumerate(lines, start=1) if r.get("event") == OUTSIDE)
    lines[n_fault - 1]["request"]["code"] = "C22"  # the schedule's fault now another code
    changed = _write(tmp_path / "changed.jsonl", lines)
    # C22 stops the arm as C31 does (state 4, the error bit): the first reply that differs is the
    # first that shows the code, get_err_warn_code (manual 2.1.3 register 15)
    first_code = next(n for n, r in enumerate(lines, start=1) if n > n_fault and r.get("register") == 15)
    diff = replay(changed).first
    assert diff is not None and diff.line == first_code
    assert (diff.register, diff.field, diff.recorded, diff.replayed) == (15, "error", 31, 22)
    code, out = run_cli("replay", str(changed))
    assert code == 1
    assert f"first difference: line {diff.line}, t = {diff.t:.3f} s, register {diff.register} " in out


def test_a_trace_without_outside_lines_replays_as_before(recipe: Path, tmp_path: Path) -> None:
    """A trace of a version that did not write them: read and compared, the fault not carried out,
    so the first reply after it differs (the state byte's error bit, manual 2.1.3)."""
    lines = _lines(recipe)
    n_fault = next(n for n, r in enumerate(lines, start=1) if r.get("event") == OUTSIDE)
    old = _write(tmp_path / "old.jsonl", [r for r in lines if r.get("event") != OUTSIDE])
    assert len(read_requests(old)) == len(read_requests(recipe))
    result = replay(old)
    first = result.first
    assert first is not None and result.outside == 0 and first.field == "state"
    assert first.recorded & 0x40 and not first.replayed & 0x40  # the error bit, recorded only
    assert first.line >= n_fault  # one line fewer before it: the first reply after the fault


def test_admin_injections_mid_program_replay_exactly(tmp_path: Path) -> None:
    """An input and an error injected through the admin channel while a move runs, a payload set,
    the program reading them: the same replies in the replay, every change carried out again."""
    path = tmp_path / "wire.jsonl"
    with running_emulator(speed=5.0, trace=path, admin=True) as st, \
            Client("127.0.0.1", st.ports["command"]) as c, AdminClient("127.0.0.1", st.ports["admin"]) as a:
        c.get_version()
        c.motion_enable(True)
        c.set_mode(0)
        c.set_state(0)
        c.call(23, joints=(0.9, -0.3, 0, 0, 0.3, 0, 0), speed=0.5, acc=5.0, mvtime=0.0)
        time.sleep(0.05)
        a.request("set-input", kind="cgpio", index=2, value=0)
        for _ in range(5):
            c.get_joints()
            c.call(131)  # the control box's digital inputs (get_cgpio_digital)
        a.request("payload", mass=1.5, com=[0, 0, 40])
        a.request("error", code="C31")
        a.request("status")  # a query: not written
        assert wait_for(lambda: c.get_state() == 4)
        c.get_joints()
        c.call(15)
        a.request("clear")
        c.call(16)
        c.get_joints()
    outside = [r for r in _lines(path) if r.get("event") == OUTSIDE]
    assert [r["request"]["cmd"] for r in outside] == ["set-input", "payload", "error", "clear"]
    assert all(r["source"] == "admin" and "token" not in r["request"] for r in outside)
    result = replay(path)
    assert result.differences == [] and result.outside == 4
    without = replay(_write(tmp_path / "without.jsonl", _without_outside(path)))
    assert without.first is not None and without.first.register == 131  # the input, first seen there


def test_checkpoint_restore_replays_back_in_time(tmp_path: Path) -> None:
    """Lockstep with checkpoints: the replay saves and restores its own at the same periods, so the
    trace's time going back tells the same story."""
    path = tmp_path / "wire.jsonl"
    with running_emulator(trace=path, admin=True, stepped=True) as st, \
            Client("127.0.0.1", st.ports["command"]) as c, AdminClient("127.0.0.1", st.ports["admin"]) as a:
        c.get_version()
        c.motion_enable(True)
        c.set_mode(0)
        c.set_state(0)
        a.request("step", seconds=0.2)
        a.request("checkpoint-save", name="before")
        c.call(23, joints=(0.5, 0, 0, 0, 0, 0, 0), speed=1.0, acc=5.0, mvtime=0.0)
        a.request("step", seconds=0.3)
        moved = c.get_joints()
        a.request("checkpoint-restore", name="before")
        a.request("step", seconds=0.1)
        assert c.get_joints() != moved
    result = replay(path)
    assert result.differences == [] and result.outside == 2
    without = replay(_write(tmp_path / "without.jsonl", _without_outside(path)))
    assert without.first is not None and without.first.name == "GET_JOINT_POS"


def test_an_outside_change_the_replay_refuses_is_a_difference(tmp_path: Path) -> None:
    trace = _write(tmp_path / "wire.jsonl", [
        {"event": OUTSIDE, "t": 0.2, "period": 50, "source": "admin",
         "request": {"cmd": "scene-place", "name": "cube", "position": [300, 0, 10]},
         "message": "cube at (300, 0, 10) mm"}])
    result = replay(trace)
    diff = result.first
    assert diff is not None and diff.field == OUTSIDE and diff.line == 1
    code, out = run_cli("replay", str(trace))
    assert code == 1
    assert ("line 1, t = 0.200 s, admin scene-place: was 'cube at (300, 0, 10) mm', now refused: the scene "
            "has no objects") in out


def test_a_bad_outside_line_is_one_line(tmp_path: Path) -> None:
    bad = _write(tmp_path / "bad.jsonl", [{"event": OUTSIDE, "t": 0.1, "request": "estop"}])
    code, out = run_cli("replay", str(bad))
    assert code == 2
    assert out.strip() == (f"{bad} line 1: an outside line needs t, period and request (an admin "
                           "request with its cmd)")


def test_the_pendants_buttons_are_in_the_trace_and_replay(make_server: Any, tmp_path: Path) -> None:
    """The 3D view's pendant changes the arm from outside any connection: its commands are request
    lines (peer "pendant"), its admin actions outside lines, and the replay tells the same story."""
    pytest.importorskip("viser")
    path = tmp_path / "wire.jsonl"
    st = make_server(view=True, view_port=0, admin=True, admin_port=0, trace=path, speed=5.0)
    p = st.server.viewer.pendant
    with Client("127.0.0.1", st.ports["command"]) as c:
        c.get_version()
        assert _in_thread(p.enable) == "MOTION_EN (11): ok; SET_STATE (12): ok"
        assert _in_thread(lambda: p.jog_joint(1, -1)).endswith("ok")
        assert wait_for(lambda: c.get_state() == 2)
        assert _in_thread(lambda: p.admin({"cmd": "warning", "code": 11})).startswith("injected warning 11")
        c.get_joints()
        c.call(15)
    st.stop()
    lines = _lines(path)
    assert [r["register"] for r in lines if r.get("peer") == "pendant"] == [11, 12, 23]
    assert [r["request"]["cmd"] for r in lines if r.get("event") == OUTSIDE] == ["warning"]
    result = replay(path)
    assert result.differences == [] and result.outside == 1
    assert result.requests == sum("event" not in r for r in lines)


def _in_thread(fn: Callable[[], object]) -> object:
    """Run ``fn`` on another thread, as viser runs a button's callback; returns its result."""
    out: list[object] = []
    t = threading.Thread(target=lambda: out.append(fn()))
    t.start()
    t.join(10.0)
    return out[0]


def _short_program(port: int) -> None:
    with Client("127.0.0.1", port) as c:
        c.get_version()
        c.motion_enable(True)
        c.set_mode(0)
        c.set_state(0)
        c.call(23, joints=(0.3, -0.1, 0, 0, 0.2, 0, 0), speed=2.0, acc=10.0, mvtime=0.0)
        assert wait_for(lambda: c.get_state() == 2)
        c.get_joints()


def test_the_trace_says_which_box_answered_and_each_run_replays_on_its_own(tmp_path: Path) -> None:
    """Two runs appended to one file, an xArm 7 with the vacuum gripper then a Lite 6: the replay
    builds each box from its start line, fresh, without being told."""
    path = tmp_path / "wire.jsonl"
    with running_emulator(7, trace=path, vacuum=True, speed=5.0) as st:
        _short_program(st.ports["command"])
    with running_emulator("lite6", trace=path, speed=5.0) as st:
        _short_program(st.ports["command"])
    starts = [r for r in _lines(path) if r.get("event") == "start"]
    assert [(r["model"], r["vacuum"]) for r in starts] == [("7", True), ("lite6", False)]
    result = replay(path)
    assert result.differences == [] and result.requests == sum("register" in r for r in _lines(path))
    code, out = run_cli("replay", str(path))
    assert code == 0, out
    # told otherwise, the first reply that shows the arm differs
    diff = replay(path, model=6).first
    assert diff is not None and diff.name == "GET_VERSION"


def test_plot_draws_the_outside_changes_with_the_errors_and_warnings(recipe: Path) -> None:
    from xarm_emu.plot import read_trace

    events = read_trace(recipe).events
    fault = [e for e in events if e[2].startswith("fault schedule: ")]
    assert [(level, text) for _, level, text in fault] == [
        ("ERROR", "fault schedule: injected C31 Collision caused abnormal current")]
    start = _lines(recipe)[0]
    assert events[0][2] == f"emulator started: xArm 6, firmware {start['firmware']}"


def test_a_saved_configuration_the_box_started_with_replays(tmp_path: Path) -> None:
    """The recipe's --config-dir: a first run sets a TCP offset and saves it (register 40), a second
    run starts with it; the trace's start line carries it, so the replay's second box has it too."""
    path, config = tmp_path / "wire.jsonl", tmp_path / "emu-config"
    with running_emulator(trace=path, config_dir=config) as st, Client("127.0.0.1", st.ports["command"]) as c:
        c.get_version()
        c.call(35, pose=(0.0, 0.0, 120.0, 0.0, 0.0, 0.0))
        c.call(40)
    with running_emulator(trace=path, config_dir=config) as st, Client("127.0.0.1", st.ports["command"]) as c:
        c.get_version()
        c.get_position()
    starts = [r for r in _lines(path) if r.get("event") == "start"]
    assert starts[0]["saved"] is None and starts[1]["saved"]["tcp_offset"][2] == pytest.approx(120.0)
    assert replay(path).differences == []
    # a trace without what the box loaded: its second run starts without the offset and differs
    for r in starts:
        r.pop("saved")
    lines = [r if r.get("event") != "start" else starts.pop(0) for r in _lines(path)]
    diff = replay(_write(tmp_path / "old.jsonl", lines)).first
    assert diff is not None and diff.name == "GET_TCP_POSE"


def test_a_calibrated_box_replays_with_its_constants(tmp_path: Path) -> None:
    from xarm_emu.model.calibration import Calibration

    path = tmp_path / "wire.jsonl"
    cal = Calibration(model="6", torque_offsets=(0.0, 0.3, -0.2, 0.0, 0.1, 0.0))
    with running_emulator(trace=path, calibration=cal) as st, Client("127.0.0.1", st.ports["command"]) as c:
        c.get_version()
        c.call(TAU)
    start = _lines(path)[0]
    assert start["calibration"] == {"model": "6", "torque_offsets": [0.0, 0.3, -0.2, 0.0, 0.1, 0.0]}
    assert replay(path).differences == []
    start["calibration"] = None
    diff = replay(_write(tmp_path / "plain.jsonl", [start, *_lines(path)[1:]])).first
    assert diff is not None and diff.register == TAU


#: GET_JOINT_TAU (manual 2.1.3): the joint torques, which a calibration's offsets move.
TAU = 55
