"""Disk work off the event loop: a trace on a full disk stops with one log line and SIGTERM still
ends the process promptly; a save on a failing disk keeps the old file, answers warning 12 (a
failed save_conf, manual 2.1.3) and says why in the log and the admin ``status``; a client looping
save_conf does not slow the develop report (2.1.6) or the other clients."""

from __future__ import annotations

import errno
import json
import logging
import os
import signal
import socket
import struct
import threading
import time
from pathlib import Path
from typing import Any

import pytest
from helpers import accepts, connect, port_args, recv_exact, report_frames_in, serve_ports, wait_for

from xarm_emu.client.admin import AdminClient
from xarm_emu.controller.core import config as config_mod
from xarm_emu.controller.emulator import Emulator
from xarm_emu.protocol.frame import STATE_WARNING, encode_request
from xarm_emu.server.app import ServerConfig, ServerThread

SAVE_CONF = 40
GET_STATE = 13
SET_TCP_LOAD = 136


def _ask(s: socket.socket, tid: int, register: int, params: bytes = b"") -> bytes:
    s.sendall(encode_request(tid, register, params))
    head = recv_exact(s, 6)
    return head + recv_exact(s, struct.unpack(">H", head[4:6])[0])


def _serve(tmp_path: Path, *args: str) -> tuple[Any, list[int]]:
    import subprocess
    import sys

    ports, last = serve_ports()
    log_path = tmp_path / "serve.log"
    proc = subprocess.Popen([sys.executable, "-m", "xarm_emu.cli", "serve", *port_args(*ports),
                             "--config-dir", str(tmp_path / "cfg"), "--log-level", "INFO", *args],
                            stdout=open(log_path, "w"), stderr=subprocess.STDOUT,  # noqa: SIM115
                            env={**os.environ, "COLUMNS": "500"})
    assert wait_for(lambda: accepts(last), 15.0)
    return proc, ports


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full (Linux)")
def test_a_trace_on_a_full_disk_stops_once_and_sigterm_still_ends_the_process(tmp_path: Path) -> None:
    proc, ports = _serve(tmp_path, "--trace", "/dev/full")
    try:
        with connect(ports[0]) as s:
            for tid in range(3000):  # every request answered although no trace line can be written
                reply = _ask(s, tid & 0xFFFF, GET_STATE)
                assert struct.unpack(">H", reply[:2])[0] == tid & 0xFFFF
        time.sleep(0.1)
        t0 = time.monotonic()
        proc.send_signal(signal.SIGTERM)
        rc = proc.wait(5)
        took = time.monotonic() - t0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    log = (tmp_path / "serve.log").read_text()
    assert rc == 0
    assert took < 2.0
    stopped = [line for line in log.splitlines() if "trace" in line and "stopped" in line]
    assert len(stopped) == 1, log
    assert "disk full (ENOSPC)" in stopped[0]
    assert "Traceback" not in log


def test_a_save_on_a_failing_disk_keeps_the_old_file_and_names_the_cause(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture) -> None:
    cfg = ServerConfig(host="127.0.0.1", port=0, normal_port=0, rich_port=0, develop_port=0, admin=True,
                       admin_port=0)
    with ServerThread(Emulator(6, config_dir=tmp_path), cfg) as st, connect(st.ports["command"]) as s:
        reply = _ask(s, 1, SAVE_CONF)
        assert not reply[7] & STATE_WARNING
        path = st.server.config_store().path  # type: ignore[union-attr]
        before = path.read_bytes()

        def full(fd: int) -> None:
            raise OSError(errno.ENOSPC, "No space left on device")

        monkeypatch.setattr(config_mod.os, "fsync", full)
        with caplog.at_level(logging.WARNING, logger="xarm_emu"):
            reply = _ask(s, 2, SAVE_CONF)
            reply2 = _ask(s, 3, SAVE_CONF)
        assert reply[7] & STATE_WARNING and reply2[7] & STATE_WARNING  # the failed save answers warning 12
        assert st.emulator.controller.warning_code == 12
        assert path.read_bytes() == before
        assert len([r for r in caplog.records if "disk full (ENOSPC)" in r.getMessage()]) == 1
        assert not [r for r in caplog.records if r.exc_info]
        with AdminClient("127.0.0.1", st.ports["admin"]) as a:
            status = json.loads(a.request("status"))
        assert status["save_error"] == "disk full (ENOSPC)"
        monkeypatch.undo()
        _ask(s, 4, SAVE_CONF)  # the disk is back: the next save lands and the cause is cleared
        with AdminClient("127.0.0.1", st.ports["admin"]) as a:
            assert json.loads(a.request("status"))["save_error"] is None


def _p50(port: int, n: int = 300) -> float:
    times = []
    with connect(port) as s:
        for tid in range(n):
            t0 = time.perf_counter()
            _ask(s, tid, GET_STATE)
            times.append(time.perf_counter() - t0)
    return sorted(times)[n // 2]


def test_a_client_looping_save_conf_slows_neither_the_report_nor_the_others(tmp_path: Path) -> None:
    proc, ports = _serve(tmp_path)
    stop = threading.Event()
    saves = [0]

    def saver() -> None:
        with connect(ports[0]) as s:
            tid = 0
            while not stop.is_set():
                tid = (tid + 1) & 0xFFFF
                _ask(s, tid, SAVE_CONF)
                saves[0] += 1

    try:
        base = _p50(ports[0])
        th = threading.Thread(target=saver)
        th.start()
        try:
            time.sleep(0.3)
            frames = report_frames_in(ports[3], 3.0)
            p50 = _p50(ports[0])
        finally:
            stop.set()
            th.join(5)
    finally:
        proc.terminate()
        proc.wait(5)
    assert saves[0] > 30  # the saver really saved, over and over
    assert frames >= 3 * 99 - 3
    assert p50 < max(2 * base, 0.002)  # within 2x, or under 2 ms where the baseline is noise
