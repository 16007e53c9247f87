"""Command-port round trips per second: a blocking raw-socket client
sends GET_STATE (13) and GET_POSITION (41) one at a time, against the emulator server and against a
minimal asyncio-protocol echo server started in the same run (it answers every request frame with a
fixed reply of the same size, TCP_NODELAY, one write). Target: emulator / echo >= 0.85.

Each server runs in a child process of its own, on the standard event loop and on uvloop; the
client runs here, on another CPU than the servers (``bench/affinity.py``).
Run: ``python -m bench roundtrip``.
"""

from __future__ import annotations

import asyncio
import socket
import struct
import subprocess
import sys
import threading
import time
from pathlib import Path

from bench.affinity import PIN_SERVER, pin_client, restore
from xarm_emu.controller.emulator import Emulator
from xarm_emu.protocol.frame import encode_reply, encode_request
from xarm_emu.server.app import new_event_loop

CALLS = 1000
REPEATS = 30  # short interleaved rounds; the best of each is what the server can do undisturbed
TARGET = 0.85


class _EchoProtocol(asyncio.Protocol):
    """Frames requests (u16 BE length at bytes 4-5) and answers each with a canned reply."""

    def __init__(self, replies: dict[int, bytes]) -> None:
        self.replies = replies
        self.buf = b""
        self.transport: asyncio.Transport | None = None

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        self.transport = transport  # type: ignore[assignment]
        transport.get_extra_info("socket").setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)

    def data_received(self, data: bytes) -> None:
        buf = self.buf + data
        out = []
        while len(buf) >= 7:
            end = 6 + struct.unpack_from(">H", buf, 4)[0]
            if len(buf) < end:
                break
            out.append(self.replies[buf[6]])
            buf = buf[end:]
        self.buf = buf
        if out and self.transport is not None:
            self.transport.write(out[0] if len(out) == 1 else b"".join(out))


class EchoServer:
    """The echo server on a thread of its own."""

    def __init__(self, replies: dict[int, bytes], use_uvloop: bool = True) -> None:
        self.loop = new_event_loop(use_uvloop)
        self.replies = replies
        self.port = 0
        self._ready = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True, name="echo-server")

    def _run(self) -> None:
        asyncio.set_event_loop(self.loop)
        srv = self.loop.run_until_complete(
            self.loop.create_server(lambda: _EchoProtocol(self.replies), "127.0.0.1", 0))
        self.port = srv.sockets[0].getsockname()[1]
        self._srv = srv
        self._ready.set()
        self.loop.run_forever()
        srv.close()
        self.loop.run_until_complete(srv.wait_closed())
        self.loop.close()

    def __enter__(self) -> EchoServer:
        self._thread.start()
        self._ready.wait(5)
        return self

    def __exit__(self, *exc: object) -> None:
        self.loop.call_soon_threadsafe(self.loop.stop)
        self._thread.join(5)


def round_trips(port: int, register: int, calls: int = CALLS) -> float:
    """Blocking raw-socket round trips per second of one register."""
    with socket.create_connection(("127.0.0.1", port)) as s:
        s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        s.settimeout(5)
        frame = encode_request(1, register)
        s.sendall(frame)
        head = s.recv(6)
        size = 6 + struct.unpack(">H", head[4:6])[0]
        rest = size - len(head)
        while rest:
            rest -= len(s.recv(rest))
        t0 = time.perf_counter()
        for _ in range(calls):
            s.sendall(frame)
            got = len(s.recv(size))
            while got < size:
                got += len(s.recv(size - got))
        return calls / (time.perf_counter() - t0)


def canned_replies(emu: Emulator) -> dict[int, bytes]:
    """The emulator's own reply for each benchmarked register, frozen (same sizes on the wire)."""
    out = {}
    for reg in (13, 41):
        state, params = emu.handle(reg, b"")
        out[reg] = encode_reply(1, 2, reg, state, params)
    return out


_CHILD = PIN_SERVER + """
import json, sys
from bench.bench_roundtrip import EchoServer, canned_replies
from xarm_emu.controller.emulator import Emulator
from xarm_emu.server.app import ServerConfig, ServerThread
uv = sys.argv[2] == "1"
if sys.argv[1] == "emulator":
    cfg = ServerConfig(port=0, normal_port=0, rich_port=0, develop_port=0)
    with ServerThread(Emulator(6), cfg, use_uvloop=uv) as st:
        print(st.ports["command"], flush=True)
        sys.stdin.readline()
else:
    with EchoServer(canned_replies(Emulator(6)), use_uvloop=uv) as echo:
        print(echo.port, flush=True)
        sys.stdin.readline()
"""


def _spawn(kind: str, use_uvloop: bool) -> tuple[subprocess.Popen[str], int]:
    """A server in a child process of its own (its own GIL, as under ``xarm-emu serve``)."""
    root = str(Path(__file__).resolve().parent.parent)
    proc = subprocess.Popen([sys.executable, "-c", _CHILD, kind, "1" if use_uvloop else "0"], cwd=root,
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    return proc, int(proc.stdout.readline())


def _finish(proc: subprocess.Popen[str]) -> None:
    assert proc.stdin is not None and proc.stdout is not None
    proc.stdin.write("\n")
    proc.stdin.close()
    proc.wait(10)
    proc.stdout.close()


def measure(use_uvloop: bool) -> dict[str, tuple[float, float, float]]:
    """Per register: best emulator rate, best echo rate, median of the per-round ratios."""
    results: dict[str, tuple[float, float, float]] = {}
    saved = pin_client()
    emu_proc, emu_port = _spawn("emulator", use_uvloop)
    echo_proc, echo_port = _spawn("echo", use_uvloop)
    try:
        for reg, name in ((13, "get_state"), (41, "get_position")):
            emu_rates, echo_rates = [], []
            for _ in range(REPEATS):  # interleaved rounds: both servers see the same machine load
                emu_rates.append(round_trips(emu_port, reg))
                echo_rates.append(round_trips(echo_port, reg))
            ratios = sorted(a / b for a, b in zip(emu_rates, echo_rates, strict=True))
            results[name] = (max(emu_rates), max(echo_rates), ratios[len(ratios) // 2])
    finally:
        _finish(emu_proc)
        _finish(echo_proc)
        restore(saved)
    return results


def run() -> list[str]:
    lines = []
    loops = [False]
    try:
        import uvloop  # type: ignore[import-not-found]  # noqa: F401

        loops.insert(0, True)
    except ImportError:
        pass
    for use_uvloop in loops:
        loop_name = "uvloop" if use_uvloop else "asyncio"
        for name, (emu_rate, echo_rate, median) in measure(use_uvloop).items():
            ratio = emu_rate / echo_rate
            verdict = "ok" if ratio >= TARGET else f"below target {TARGET}"
            lines.append(f"{loop_name:7s} {name:12s}: emulator {emu_rate:8.0f}/s, "
                         f"echo {echo_rate:8.0f}/s (best of {REPEATS}), ratio {ratio:.2f} ({verdict}); "
                         f"median round ratio {median:.2f}")
    return lines


if __name__ == "__main__":
    for line in run():
        print(line)
