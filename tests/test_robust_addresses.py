"""Addresses and delivery: ``--host ::`` serves IPv4 and IPv6 clients on one dual-stack socket per
port; every develop frame that is due (manual 2.1.6, 100 Hz) reaches every reader."""

from __future__ import annotations

import os
import socket
import struct
import threading
import time
from pathlib import Path

import pytest
from helpers import accepts, port_args, serve_ports, serve_subprocess, wait_for

from xarm_emu.controller.emulator import Emulator
from xarm_emu.protocol.frame import encode_request
from xarm_emu.server.app import ServerConfig, ServerThread

GET_STATE = 13
#: Seconds of the 10-reader soak: short in `make test`, ten minutes in `make stress`.
STRESS = os.environ.get("XARM_EMU_STRESS") == "1"
SOAK_SECONDS = 600.0 if STRESS else 3.0


def _has_ipv6_loopback() -> bool:
    try:
        with socket.socket(socket.AF_INET6) as s:
            s.bind(("::1", 0))
    except OSError:
        return False
    return True


def _get_state(host: str, port: int, tid: int) -> int:
    with socket.create_connection((host, port), timeout=3.0) as s:
        s.sendall(encode_request(tid, GET_STATE))
        head = s.recv(6)
        return int(struct.unpack(">H", head[:2])[0])


@pytest.mark.skipif(not _has_ipv6_loopback(), reason="no IPv6 loopback")
def test_host_double_colon_serves_ipv4_and_ipv6_clients() -> None:
    cfg = ServerConfig(host="::", port=0, normal_port=0, rich_port=0, develop_port=0)
    with ServerThread(Emulator(6), cfg) as st:
        assert _get_state("127.0.0.1", st.ports["command"], 4) == 4
        assert _get_state("::1", st.ports["command"], 6) == 6
        for host in ("127.0.0.1", "::1"):
            with socket.create_connection((host, st.ports["develop"]), timeout=3.0) as r:
                assert len(r.recv(4)) == 4


def _count_frames(sock: socket.socket, out: list[int], i: int, start: threading.Barrier) -> None:
    """Count the whole frames that reach one reader from its connection until the server closes it:
    every reader stops at the same frame, the last one the server sent."""
    with sock as s:
        start.wait(5)
        buf = b""
        got = 0
        while True:
            try:
                chunk = s.recv(65536)
            except ConnectionResetError:  # a stop that resets instead of closing ends it too
                chunk = b""
            if not chunk:
                break
            buf += chunk
            while len(buf) >= 4 and len(buf) >= struct.unpack(">I", buf[:4])[0]:
                buf = buf[struct.unpack(">I", buf[:4])[0]:]
                got += 1
        out[i] = got


def test_ten_develop_readers_each_get_every_due_frame(tmp_path: Path) -> None:
    """Against `xarm-emu serve` in its own process, as users run it. The bounded run asserts that
    the ten readers get the same frames and 90 % of those due (a machine shared with other jobs);
    the ten-minute soak of `make stress` asserts 99.9 % of those due. The readers read until the
    server stops, so they end on the same frame whatever the machine does to their threads."""
    seconds = SOAK_SECONDS
    ports, last = serve_ports()
    got = [0] * 10
    with serve_subprocess(tmp_path, *port_args(*ports)):
        assert wait_for(lambda: accepts(last), 15.0)
        start = threading.Barrier(11)
        # Connected one after another by this thread, so the server registers the ten within a
        # frame or so of each other (ten threads each connecting on a busy machine spread that over
        # several frames); the frames sent meanwhile wait in each socket's buffer.
        socks = [socket.create_connection(("127.0.0.1", ports[3]), timeout=30.0) for _ in range(10)]
        readers = [threading.Thread(target=_count_frames, args=(socks[i], got, i, start))
                   for i in range(10)]
        for t in readers:
            t.start()
        start.wait(5)
        time.sleep(seconds)
    for t in readers:  # the server has stopped: each reader has read to the end of its stream
        t.join(10)
    due = seconds * 100
    if STRESS:
        assert min(got) >= min(due - 2, 0.999 * due), got  # every due frame (slack at the ends)
    else:
        # every reader gets every frame sent (slack at the ends); the frames sent are those due,
        # less what a loaded 2-core machine makes the server miss (up to a few percent)
        assert min(got) >= max(got) - 3, got
        assert max(got) >= 0.9 * due, got
