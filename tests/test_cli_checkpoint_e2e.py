"""Checkpoint and restore through the CLI, end to end: `xarm-emu serve --stepped --admin` in a child
process, commands on its command port, `xarm-emu checkpoint save/restore` and `xarm-emu step`; after a
restore the same commands give the same register replies and the same report frames, byte for byte."""

from __future__ import annotations

import socket
import struct
import subprocess
import sys
import time
from pathlib import Path

from helpers import free_ports, port_args, serve_subprocess

from xarm_emu.client import Client


def cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "xarm_emu.cli", *args], capture_output=True, text=True,
                          timeout=30)


def report_frame(port: int) -> bytes:
    """The first whole report frame on a new connection (u32 BE length first, manual 2.1.6)."""
    with socket.create_connection(("127.0.0.1", port), timeout=5) as s:
        buf = b""
        while len(buf) < 4 or len(buf) < struct.unpack(">I", buf[:4])[0]:
            chunk = s.recv(4096)
            assert chunk, "report port closed"
            buf += chunk
        return buf[: struct.unpack(">I", buf[:4])[0]]


def observe(c: Client, ports: tuple[int, int, int]) -> tuple[bytes, ...]:
    """Raw replies of state, cmdnum, error/warning, pose and joints, then one frame of each report."""
    replies = tuple(c.call(code).raw for code in (13, 14, 15, 41, 42))
    return replies + tuple(report_frame(p) for p in ports)


def test_checkpoint_restore_through_the_cli_replays_byte_for_byte(tmp_path: Path) -> None:
    cmd, normal, rich, develop, admin = free_ports(5)
    addr = ("--port", str(cmd), "--admin-port", str(admin))
    with serve_subprocess(tmp_path, *port_args(cmd, normal, rich, develop), "--stepped", "--admin",
                          "--admin-port", str(admin)):
        deadline = time.monotonic() + 20
        while cli("status", "--port", str(cmd), "--report-port", str(develop)).returncode != 0:
            assert time.monotonic() < deadline, "the emulator did not come up"
            time.sleep(0.2)
        with Client("127.0.0.1", cmd) as c:
            c.call(11, joint=8, enable=1)
            c.call(19, mode=0)
            c.call(12, state=0)
            c.call(23, joints=(1.0, -0.2, -0.3, 0.0, 0.5, 0.0, 0.0), speed=1.0, acc=10.0, mvtime=0.0)
            assert cli("step", "0.4s", *addr).returncode == 0
            saved = cli("checkpoint", "save", "mid-move", *addr)
            assert saved.returncode == 0, saved.stdout + saved.stderr

            def scenario() -> tuple[bytes, ...]:
                c.call(21, pose=(250.0, 50.0, 300.0, 3.1416, 0.0, 0.0), speed=100.0, acc=1000.0, mvtime=0.0)
                assert cli("step", "0.3s", *addr).returncode == 0
                return observe(c, (normal, rich, develop))

            first = scenario()
            assert cli("inject", "error", "C31", *addr).returncode == 0
            assert c.call(15).values["error"] == 31
            restored = cli("checkpoint", "restore", "mid-move", *addr)
            assert restored.returncode == 0, restored.stdout + restored.stderr
            assert c.call(15).values["error"] == 0
            again = scenario()
        assert again == first
        assert first[0] != b"" and len(first) == 8
        bad = cli("checkpoint", "restore", "no-such", *addr)
        assert bad.returncode == 2 and "no checkpoint" in bad.stdout + bad.stderr
