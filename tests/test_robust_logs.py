"""Bounded logs and traces: identical log lines repeated within the window are held back and
counted; the trace rotates at its size cap; controller errors and warnings (manual chapter 3) and
client connects and drops are logged at INFO."""

from __future__ import annotations

import json
import logging
import socket
import struct
import time
import types
from pathlib import Path

import pytest

from xarm_emu.controller.emulator import Emulator
from xarm_emu.protocol.frame import encode_request
from xarm_emu.server.app import ServerConfig, ServerThread
from xarm_emu.server.logs import RepeatFilter
from xarm_emu.server.trace import CommandTrace


def _record(msg: str, *args: object) -> logging.LogRecord:
    return logging.LogRecord("xarm_emu.server", logging.WARNING, __file__, 1, msg, args, None)


def test_identical_lines_are_held_back_and_counted(monkeypatch: pytest.MonkeyPatch) -> None:
    clock = [100.0]
    monkeypatch.setattr("xarm_emu.server.logs.time.monotonic", lambda: clock[0])
    f = RepeatFilter(window=10.0)
    assert f.filter(_record("cannot accept: %s", "EMFILE"))
    assert [f.filter(_record("cannot accept: %s", "EMFILE")) for _ in range(500)] == [False] * 500
    assert f.filter(_record("another line"))  # a different line passes at once
    clock[0] += 11.0
    rec = _record("cannot accept: %s", "EMFILE")
    assert f.filter(rec)
    assert rec.getMessage() == "cannot accept: EMFILE (repeated 500 more times in 11 s)"


def test_the_trace_rotates_at_its_size_cap(tmp_path: Path) -> None:
    path = tmp_path / "t.jsonl"
    trace = CommandTrace(path, max_bytes=2000)
    for i in range(100):
        trace.event(float(i), "127.0.0.1:1", "connect")
        trace.flush()
    trace.close()
    old = tmp_path / "t.jsonl.1"
    assert old.exists()
    assert 2000 <= old.stat().st_size < 2200
    assert path.stat().st_size < 2200
    lines = [json.loads(x) for x in (old.read_text() + path.read_text()).splitlines()]
    assert [x["t"] for x in lines] == sorted(x["t"] for x in lines)  # recent lines kept in order


def test_errors_warnings_and_clients_are_logged(caplog: pytest.LogCaptureFixture) -> None:
    cfg = ServerConfig(host="127.0.0.1", port=0, normal_port=0, rich_port=0, develop_port=0)
    with caplog.at_level(logging.INFO, logger="xarm_emu"), ServerThread(Emulator(6), cfg) as st:
        with socket.create_connection(("127.0.0.1", st.ports["command"]), timeout=3.0) as s:
            s.sendall(encode_request(1, 250))  # not a register of this firmware: warning 13
            head = s.recv(6)
            s.recv(struct.unpack(">H", head[4:6])[0])
        st.call(lambda: None)
    text = [r.getMessage() for r in caplog.records if r.levelno >= logging.INFO]
    assert "command client connected from 127.0.0.1" in text
    assert any(t.startswith("command client from 127.0.0.1 left") for t in text)
    assert "warning W13 Unknown command: Check the register of the command sent." in text


def test_an_error_raised_between_two_pure_reads_is_logged_at_the_second(
        caplog: pytest.LogCaptureFixture) -> None:
    """Lockstep time, so that no control period runs: a repeated state read is answered from the
    reply made for the first, yet an error injected between them shows in the log at the second."""
    cfg = ServerConfig(host="127.0.0.1", port=0, normal_port=0, rich_port=0, develop_port=0,
                       stepped=True, admin=True, admin_token="t")
    emu = Emulator(6)

    def get_state(s: socket.socket) -> bytes:
        s.sendall(encode_request(1, 13))
        head = s.recv(6)
        return head + s.recv(struct.unpack(">H", head[4:6])[0])

    with caplog.at_level(logging.INFO, logger="xarm_emu"), ServerThread(emu, cfg) as st, \
            socket.create_connection(("127.0.0.1", st.ports["command"]), timeout=3.0) as s:
        first = get_state(s)
        assert get_state(s) == first  # the same reply again: nothing changed
        caplog.clear()
        st.call(lambda: emu.inject_error(22))
        after = get_state(s)
        st.call(lambda: None)
    assert after[7] & 0x40  # the status byte's error bit (manual 2.1.2)
    text = [r.getMessage() for r in caplog.records]
    assert any(t.startswith("error C22") for t in text), text


def test_state_changes_are_never_folded_and_stay_in_order(monkeypatch: pytest.MonkeyPatch) -> None:
    """A move, a stop, a move again within the window: each change has its line, in order."""
    from xarm_emu.server.logs import CodeWatch

    monkeypatch.setattr("xarm_emu.server.logs.time.monotonic", lambda: 100.0)  # all within the window
    passed: list[str] = []
    logger = logging.getLogger("xarm_emu.test_fold")
    handler = logging.Handler()
    handler.addFilter(RepeatFilter(window=10.0))
    handler.emit = lambda record: passed.append(record.getMessage())  # type: ignore[method-assign]
    logger.addHandler(handler)
    logger.setLevel(logging.INFO)
    logger.propagate = False
    try:
        watch = CodeWatch(logger)
        ctl = types.SimpleNamespace(state=2, mode=0, error_code=0, warning_code=0)
        for state in (2, 1, 2, 1, 2, 1, 2):
            ctl.state = state
            watch.check(ctl)
        logger.info("cannot accept: EMFILE")
        logger.info("cannot accept: EMFILE")  # no change in it: held back
    finally:
        logger.removeHandler(handler)
    states = [m for m in passed if m.startswith("state ")]
    assert states == ["state 2 (sleep (ready))", "state 1 (in motion)"] * 3 + ["state 2 (sleep (ready))"]
    assert passed.count("cannot accept: EMFILE") == 1


def test_report_clients_and_shutdown_are_logged(caplog: pytest.LogCaptureFixture) -> None:
    cfg = ServerConfig(host="127.0.0.1", port=0, normal_port=0, rich_port=0, develop_port=0)
    with caplog.at_level(logging.INFO, logger="xarm_emu"), ServerThread(Emulator(6), cfg) as st:
        with socket.create_connection(("127.0.0.1", st.ports["develop"]), timeout=3.0) as s:
            s.recv(4)
            st.call(lambda: None)
        deadline = time.monotonic() + 5.0
        while time.monotonic() < deadline and not any(
                r.getMessage() == "develop report client from 127.0.0.1 left" for r in caplog.records):
            time.sleep(0.02)
    text = [r.getMessage() for r in caplog.records]
    assert "develop report client connected from 127.0.0.1" in text
    assert "develop report client from 127.0.0.1 left" in text
    assert text.index("develop report client connected from 127.0.0.1") < text.index(
        "shutting down: closing the ports and every connection") < text.index("stopped")
