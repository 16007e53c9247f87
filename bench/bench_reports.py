"""Develop-report timing under load: inter-frame jitter (|interval - 10 ms|: p50, p99,
max) of the 100 Hz develop report (manual 2.1.6) while 20 develop-report clients are connected and one
client streams servoj (register 29, mode 1) at 250 Hz. Target: p99 <= 1 ms.

Two figures per event loop: the server's send times (when each frame was written, what the server
controls) and the arrival times at one of the 20 readers (adds this process's reader thread). The
server runs in a child process, as it does under ``xarm-emu serve``.
Run: ``python -m bench reports``.
"""

from __future__ import annotations

import json
import math
import selectors
import socket
import subprocess
import sys
import threading
import time

import numpy as np

from bench.affinity import PIN_SERVER, pin_client, restore
from xarm_emu.protocol import reports
from xarm_emu.protocol.frame import encode_request
from xarm_emu.protocol.registers import REGISTERS

SECONDS = 3.0
READERS = 20
SERVO_RATE = 250.0
TARGET_P99 = 1e-3
INTERVAL = 1.0 / reports.DEVELOP_RATE


def _readers(port: int, stop: threading.Event, arrivals: list[float]) -> None:
    """Read 20 develop streams in one thread; log the arrival time of frames on the first one."""
    sel = selectors.DefaultSelector()
    socks = []
    for i in range(READERS):
        s = socket.create_connection(("127.0.0.1", port))
        s.setblocking(False)
        sel.register(s, selectors.EVENT_READ, i)
        socks.append(s)
    pending = 0
    try:
        while not stop.is_set():
            for key, _ in sel.select(0.05):
                data = key.fileobj.recv(65536)  # type: ignore[union-attr]
                if key.data == 0 and data:
                    now = time.perf_counter()
                    pending += len(data)
                    while pending >= 87:
                        arrivals.append(now)
                        pending -= 87
    finally:
        for s in socks:
            sel.unregister(s)
            s.close()
        sel.close()


def _call(sock: socket.socket, tid: int, code: int, **values: object) -> None:
    sock.sendall(encode_request(tid, code, REGISTERS[code].request.encode(values)))
    got = sock.recv(4096)
    assert got, "connection closed"


def _servo_stream(port: int, stop: threading.Event) -> int:
    """Enable, servo mode, then servoj at 250 Hz along a slow sine on joint 1; returns commands sent."""
    with socket.create_connection(("127.0.0.1", port)) as s:
        s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        _call(s, 1, 11, joint=8, enable=1)
        _call(s, 2, 19, mode=1)
        _call(s, 3, 12, state=0)
        period = 1.0 / SERVO_RATE
        t0 = time.perf_counter()
        k = 0
        while not stop.is_set():
            q1 = 0.2 * math.sin(2 * math.pi * 0.5 * k * period)
            _call(s, (k % 60000) + 4, 29, joints=(q1, 0, 0, 0, 0, 0, 0), speed=0.0, acc=0.0, mvtime=0.0)
            k += 1
            delay = t0 + k * period - time.perf_counter()
            if delay > 0:
                time.sleep(delay)
        return k


def _jitter(times: list[float], interval: float) -> tuple[float, float, float, int]:
    d = np.abs(np.diff(np.asarray(times)) - interval)
    return float(np.percentile(d, 50)), float(np.percentile(d, 99)), float(d.max()), len(times)


_CHILD = PIN_SERVER + """
import json, sys, time
from xarm_emu.controller.emulator import Emulator
from xarm_emu.server.app import ServerConfig, ServerThread
cfg = ServerConfig(port=0, normal_port=0, rich_port=0, develop_port=0)
st = ServerThread(Emulator(6), cfg, use_uvloop=sys.argv[1] == "1").start()
print(json.dumps(st.ports), flush=True)
sys.stdin.readline()
st.call(lambda: setattr(st.server, "frame_times", {}))
sys.stdin.readline()
print(json.dumps(st.call(lambda: st.server.frame_times["develop"])), flush=True)
st.stop()
"""


def measure(use_uvloop: bool) -> tuple[tuple[float, float, float, int], tuple[float, float, float, int], int]:
    """The server runs in a child process (its own GIL, as under ``xarm-emu serve``); the 20 readers and
    the servo client run here."""
    saved = pin_client()  # the readers and the servo client on another CPU than the server
    proc = subprocess.Popen([sys.executable, "-c", _CHILD, "1" if use_uvloop else "0"],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    assert proc.stdin is not None and proc.stdout is not None
    try:
        ports = json.loads(proc.stdout.readline())
        stop = threading.Event()
        arrivals: list[float] = []
        reader = threading.Thread(target=_readers, args=(ports["develop"], stop, arrivals))
        reader.start()
        sent = [0]
        servo = threading.Thread(target=lambda: sent.__setitem__(0, _servo_stream(ports["command"], stop)))
        servo.start()
        time.sleep(0.5)  # warm up: all clients connected, servo streaming
        proc.stdin.write("start\n")
        proc.stdin.flush()
        n0 = len(arrivals)
        time.sleep(SECONDS)
        proc.stdin.write("dump\n")
        proc.stdin.flush()
        times = json.loads(proc.stdout.readline())
        got = arrivals[n0:]
        stop.set()
        servo.join(5)
        reader.join(5)
    finally:
        proc.stdin.close()
        proc.wait(10)
        proc.stdout.close()
        restore(saved)
    return _jitter(times, INTERVAL), _jitter(got, INTERVAL), sent[0]


def run() -> list[str]:
    loops = [False]
    try:
        import uvloop  # type: ignore[import-not-found]  # noqa: F401

        loops.append(True)
    except ImportError:
        pass
    lines = []
    for use_uvloop in loops:
        name = "uvloop" if use_uvloop else "asyncio"
        server, client, servo = measure(use_uvloop)
        for where, (p50, p99, mx, n) in (("sent", server), ("received", client)):
            verdict = "ok" if p99 <= TARGET_P99 else f"above target {TARGET_P99 * 1e3:g} ms"
            lines.append(f"{name:7s} develop {where:8s}: jitter p50 {p50 * 1e3:.3f} ms, "
                         f"p99 {p99 * 1e3:.3f} ms, max {mx * 1e3:.3f} ms over {n} frames ({verdict})")
        lines.append(f"{name:7s} with {READERS} report clients and servoj at "
                     f"{servo / (SECONDS + 0.5):.0f}/s (target {SERVO_RATE:g})")
    return lines


if __name__ == "__main__":
    for line in run():
        print(line)
