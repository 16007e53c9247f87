"""Admin requests, fault schedules and checkpoints against a small fake target (no EmulatorServer,
no sockets), and the admin wire's sans-IO line framing (protocol/admin.py)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from xarm_emu.controller.emulator import Emulator
from xarm_emu.protocol.admin import MAX_LINE, LineDecoder, LineTooLong, encode_answer
from xarm_emu.server.admin import AdminError, execute, prepare
from xarm_emu.server.faults import FaultScheduleError, schedule, schedule_file


class FakeTarget:
    """Just what admin needs of a server; records the knob calls."""

    def __init__(self, emulator: Any, stepped: bool = False) -> None:
        self.emulator, self.stepped, self.checkpoints = emulator, stepped, {}
        self.reply_delay, self.paused_for, self.calls = 0.0, 0.0, []

    def advance(self, seconds: float) -> int:
        self.calls.append(("advance", seconds))
        return 3

    def pause_reports(self, seconds: float) -> None:
        self.paused_for = seconds

    def reports_paused(self) -> bool:
        return self.paused_for > 0

    def set_reply_delay(self, seconds: float) -> None:
        self.reply_delay = seconds

    def clear_delays(self) -> None:
        self.reply_delay = self.paused_for = 0.0

    def drop_clients(self) -> int:
        return 2


class RecordingEmulator:
    """An emulator stand-in whose checkpoint pair records its calls."""

    def __init__(self) -> None:
        self.time, self.calls, self.n = 1.5, [], 0

    def checkpoint(self) -> object:
        self.n += 1
        token = ("state", self.n)
        self.calls.append(("checkpoint",))
        return token

    def restore(self, saved: object) -> None:
        self.calls.append(("restore", saved))


@pytest.fixture
def emu(tmp_path: Path) -> Emulator:
    return Emulator(6, config_dir=tmp_path)


def test_injection_and_knobs_reach_the_target(emu: Emulator) -> None:
    t = FakeTarget(emu)
    assert "C31" in execute(t, {"cmd": "error", "code": "C31"})
    assert emu.controller.error_code == 31
    execute(t, {"cmd": "reply-delay", "seconds": "50ms"})
    execute(t, {"cmd": "report-pause", "seconds": 2})
    assert (t.reply_delay, t.paused_for) == (pytest.approx(0.05), 2.0)
    assert json.loads(execute(t, {"cmd": "status"}))["reports_paused"] is True
    assert execute(t, {"cmd": "drop-clients"}) == "dropped 2 client connections"
    execute(t, {"cmd": "clear"})
    assert (t.reply_delay, t.paused_for, emu.controller.error_code) == (0.0, 0.0, 0)


def test_step_needs_a_stepped_target(emu: Emulator) -> None:
    with pytest.raises(AdminError, match="--stepped"):
        prepare(FakeTarget(emu), {"cmd": "step", "seconds": 1})
    t = FakeTarget(emu, stepped=True)
    assert execute(t, {"cmd": "step", "seconds": 0.5}).startswith("advanced 3 control periods")
    assert t.calls == [("advance", 0.5)]


def test_a_refused_request_changes_nothing(emu: Emulator) -> None:
    t = FakeTarget(emu)
    for bad in ({"cmd": "servo-error", "joint": 9, "code": "S23"}, {"cmd": "reply-delay", "seconds": -1},
                {"cmd": "nope"}):
        with pytest.raises(AdminError):
            prepare(t, bad)
    assert (t.reply_delay, emu.controller.error_code, emu.controller.servo_errors[0]) == (0.0, 0, 0)


def test_a_fault_schedule_checks_and_lands_on_a_fake_target(emu: Emulator, tmp_path: Path) -> None:
    t = FakeTarget(emu)
    path = tmp_path / "f.toml"
    path.write_text('[[fault]]\nat = 0.1\ndo = "reply-delay"\nseconds = "20ms"\n'
                    '[[fault]]\nat = 0.2\ndo = "warning"\ncode = 11\n')
    assert schedule_file(t, path) == 2
    emu.step(int(0.15 / 0.004))
    assert (t.reply_delay, emu.controller.warning_code) == (pytest.approx(0.02), 0)
    emu.step(int(0.1 / 0.004))
    assert emu.controller.warning_code == 11
    with pytest.raises(FaultScheduleError, match="fault 1 .*joint 9"):
        schedule(t, [{"at": 1.0, "do": "servo-error", "joint": 9, "code": "S23"}])
    assert schedule_file(t, None) == 0


def test_checkpoint_save_restore_and_list_call_the_emulator() -> None:
    rec = RecordingEmulator()
    t = FakeTarget(rec)
    assert json.loads(execute(t, {"cmd": "checkpoint-list"})) == []
    assert "'before'" in execute(t, {"cmd": "checkpoint-save", "name": "before"})
    execute(t, {"cmd": "checkpoint-save", "name": "after"})
    assert json.loads(execute(t, {"cmd": "checkpoint-list"})) == ["after", "before"]
    assert "restored" in execute(t, {"cmd": "checkpoint-restore", "name": "before"})
    assert rec.calls == [("checkpoint",), ("checkpoint",), ("restore", ("state", 1))]


@pytest.mark.parametrize("request_, fragment", [
    ({"cmd": "checkpoint-restore", "name": "never"}, "no checkpoint 'never'; saved: 'kept'"),
    ({"cmd": "checkpoint-save", "name": ""}, "non-empty"),
    ({"cmd": "checkpoint-save"}, "non-empty"),
    ({"cmd": "checkpoint-restore", "name": 3}, "non-empty"),
    ({"cmd": "checkpoint-save", "name": "x" * 65}, "longer than 64"),
])
def test_bad_checkpoint_requests_are_refused_without_a_call(request_: dict[str, Any], fragment: str) -> None:
    rec = RecordingEmulator()
    t = FakeTarget(rec)
    t.checkpoints["kept"] = "token"
    with pytest.raises(AdminError, match=fragment):
        prepare(t, request_)
    assert rec.calls == [] and list(t.checkpoints) == ["kept"]


def test_checkpoints_are_not_schedulable(emu: Emulator, tmp_path: Path) -> None:
    path = tmp_path / "f.toml"
    path.write_text('[[fault]]\nat = 1.0\ndo = "checkpoint-save"\nname = "a"\n')
    with pytest.raises(FaultScheduleError, match="fault 1: do is one of"):
        schedule_file(FakeTarget(emu), path)


def test_line_decoder_frames_requests_across_reads() -> None:
    d = LineDecoder()
    assert d.feed(b'{"cmd": "est') == []
    out = d.feed(b'op"}\n\n  \n[1, 2]\nnot json\n{"cmd": "clear"}')
    assert out[0] == {"cmd": "estop"}
    assert [str(e) for e in out[1:]] == ["not a JSON object line"] * 2
    assert d.feed(b"\n") == [{"cmd": "clear"}]


def test_line_decoder_bounds_the_line() -> None:
    d = LineDecoder()
    out = d.feed(b"x" * (MAX_LINE + 1))
    assert len(out) == 1 and isinstance(out[0], LineTooLong) and str(MAX_LINE) in str(out[0])
    assert d.closed and d.feed(b'{"cmd": "estop"}\n') == []
    assert LineDecoder().feed(b"y" * MAX_LINE) == []


def test_encode_answer_is_one_json_line() -> None:
    line = encode_answer({"ok": True, "message": "emergency stop: C1"})
    assert line == b'{"ok": true, "message": "emergency stop: C1"}\n'
