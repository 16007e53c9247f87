"""Develop-report timing under load: inter-frame jitter (|interval - 10 ms|: p50, p99,
max) of the 100 Hz develop report (manual 2.1.6) while 20 develop-report clients are connected and one
client streams servoj (register 29, mode 1) at 250 Hz. Target: p99 <= 1 ms and max <= 3 ms in at
least 4 of 5 runs.

Each run first measures the machine's floor: an idle child process on the server's CPU that only
sleeps to the same absolute 100 Hz deadlines (its jitter is what the operating system and the other
processes on the machine cost any sender). Then the server, in a child process as under
``xarm-emu serve``: its send times (what the server controls), each frame's lateness after its
deadline, and the arrival times at one of the 20 readers (adds this process's reader thread). The
runs are made with the server's default (the report sender at real-time priority where the system
allows it, ``report_sender.DEFAULT_PRIORITY``) and with normal scheduling (``--report-priority 0``).
Run: ``python -m bench reports``.
"""

from __future__ import annotations

import json
import math
import os
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
from xarm_emu.server.report_sender import DEFAULT_PRIORITY

SECONDS = 3.0
RUNS = 5
READERS = 20
SERVO_RATE = 250.0
TARGET_P99 = 1e-3
TARGET_MAX = 3e-3
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
            try:
                _call(s, (k % 60000) + 4, 29, joints=(q1, 0, 0, 0, 0, 0, 0), speed=0.0, acc=0.0, mvtime=0.0)
            except (AssertionError, OSError):
                break  # the server stopped first
            k += 1
            delay = t0 + k * period - time.perf_counter()
            if delay > 0:
                time.sleep(delay)
        return k


Jitter = tuple[float, float, float, int]


def _jitter(times: list[float], interval: float) -> Jitter:
    d = np.abs(np.diff(np.asarray(times)) - interval)
    return float(np.percentile(d, 50)), float(np.percentile(d, 99)), float(d.max()), len(times)


_CHILD = PIN_SERVER + """
import json, sys, time
from xarm_emu.controller.emulator import Emulator
from xarm_emu.server.app import ServerConfig, ServerThread
from xarm_emu.server.report_sender import tune_process
tune_process()  # as xarm-emu serve does
prio = None if sys.argv[2] == 'default' else int(sys.argv[2])
cfg = ServerConfig(port=0, normal_port=0, rich_port=0, develop_port=0, report_priority=prio)
st = ServerThread(Emulator(6), cfg, use_uvloop=sys.argv[1] == "1").start()
print(json.dumps(st.ports), flush=True)
sys.stdin.readline()
stream = st.server.reports.streams["develop"]
def arm():
    st.server.frame_times = {}
    stream.lateness = []
st.call(arm)
sys.stdin.readline()
print(json.dumps(st.call(lambda: (st.server.frame_times["develop"], list(stream.lateness),
                                  st.server.reports.frames_late["develop"]))), flush=True)
st.stop()
"""

#: The machine's floor: a process on the server's CPU that only sleeps to absolute deadlines.
_IDLE = PIN_SERVER + """
import json, sys, time
interval, n = float(sys.argv[1]), int(sys.argv[2])
t0 = time.perf_counter()
out = []
for k in range(1, n + 1):
    delay = t0 + k * interval - time.perf_counter()
    if delay > 0:
        time.sleep(delay)
    out.append(time.perf_counter())
print(json.dumps(out))
"""


def idle_floor() -> Jitter:
    """Jitter of an idle process sleeping to absolute 100 Hz deadlines on the server's CPU."""
    n = int(SECONDS / INTERVAL)
    out = subprocess.run([sys.executable, "-c", _IDLE, str(INTERVAL), str(n)], capture_output=True,
                         text=True, check=True, timeout=SECONDS + 30).stdout
    return _jitter(json.loads(out), INTERVAL)


def priority_allowed() -> bool:
    """Whether this system lets a process take real-time (SCHED_FIFO) priority."""
    code = f"import os; os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param({DEFAULT_PRIORITY}))"
    return subprocess.run([sys.executable, "-c", code], capture_output=True, timeout=30).returncode == 0


def measure(use_uvloop: bool, priority: int | None = 0) -> tuple[Jitter, Jitter, int, float, int]:
    """The server runs in a child process (its own GIL, as under ``xarm-emu serve``); the 20 readers and
    the servo client run here. Returns the send and arrival jitter, servo commands sent, the p99 of
    the frames' lateness after their deadlines, and the frames sent with the previous state."""
    saved = pin_client()  # the readers and the servo client on another CPU than the server
    setting = "default" if priority is None else str(priority)
    proc = subprocess.Popen([sys.executable, "-c", _CHILD, "1" if use_uvloop else "0", setting],
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
        times, lateness, stale = json.loads(proc.stdout.readline())
        got = arrivals[n0:]
        stop.set()
        servo.join(5)
        reader.join(5)
    finally:
        proc.stdin.close()
        proc.wait(10)
        proc.stdout.close()
        restore(saved)
    late99 = float(np.percentile(lateness, 99)) if lateness else math.nan
    return _jitter(times, INTERVAL), _jitter(got, INTERVAL), sent[0], late99, stale


ARMS = 30

#: CPU cost per develop frame: ARMS servers in one event loop (as a fleet worker hosts them), first
#: idle, then with one develop reader each (a thread of the same process, whose reads are included).
_COST = PIN_SERVER + """
import asyncio, json, resource, selectors, socket, sys, threading, time
from xarm_emu.controller.emulator import Emulator
from xarm_emu.server.core import EmulatorServer, ServerConfig
n, seconds = int(sys.argv[1]), float(sys.argv[2])
loop = asyncio.new_event_loop()
servers = [EmulatorServer(Emulator(6), ServerConfig(port=0, normal_port=0, rich_port=0, develop_port=0))
           for _ in range(n)]
async def start():
    for s in servers:
        await s.start()
loop.run_until_complete(start())
threading.Thread(target=loop.run_forever, daemon=True).start()
def cpu():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime
c0 = cpu(); time.sleep(seconds); idle = cpu() - c0
socks = [socket.create_connection(("127.0.0.1", s.ports["develop"])) for s in servers]
stop = threading.Event()
def read():
    sel = selectors.DefaultSelector()
    for s in socks:
        s.setblocking(False)
        sel.register(s, selectors.EVENT_READ)
    while not stop.is_set():
        for key, _ in sel.select(0.05):
            key.fileobj.recv(65536)
t = threading.Thread(target=read); t.start(); time.sleep(0.3)
f0 = sum(s.frames_sent["develop"] for s in servers); c0 = cpu()
time.sleep(seconds)
busy = cpu() - c0; frames = sum(s.frames_sent["develop"] for s in servers) - f0
stop.set(); t.join()
print(json.dumps([idle / seconds, busy / seconds, frames / seconds]))
"""


def frame_cost() -> str:
    """CPU per develop frame with ARMS arms in one loop, each read at 100 Hz, against the same arms idle."""
    out = subprocess.run([sys.executable, "-c", _COST, str(ARMS), str(SECONDS)], capture_output=True,
                         text=True, check=True, timeout=120).stdout
    idle, busy, rate = json.loads(out)
    per = (busy - idle) / rate if rate else math.nan
    return (f"{ARMS} arms in one loop, a develop reader each: {rate:.0f} frames/s, {busy * 100:.0f} % of a "
            f"core (idle arms: {idle * 100:.1f} %), {per * 1e6:.0f} us per frame including the reader")


def _ms(j: Jitter) -> str:
    return f"p50 {j[0] * 1e3:.3f} p99 {j[1] * 1e3:.3f} max {j[2] * 1e3:.3f} ms"


def _ok(j: Jitter) -> bool:
    return j[1] <= TARGET_P99 and j[2] <= TARGET_MAX


def run() -> list[str]:
    loops = [False]
    try:
        import uvloop  # type: ignore[import-not-found]  # noqa: F401

        loops.append(True)
    except ImportError:
        pass
    default = (f"default: real-time priority {DEFAULT_PRIORITY}" if priority_allowed()
               else "default: normal priority (real-time refused here)")
    settings: list[tuple[str, int | None]] = [(default, None), ("--report-priority 0", 0)]
    lines = [f"jitter |interval - 10 ms| of the develop report; {READERS} readers + servoj at "
             f"{SERVO_RATE:g} Hz; target p99 <= {TARGET_P99 * 1e3:g} ms and max <= {TARGET_MAX * 1e3:g} ms "
             f"in 4 of {RUNS} runs; load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs"]
    for use_uvloop in loops:
        for setting, priority in settings if not use_uvloop else settings[:1]:
            name = ("uvloop" if use_uvloop else "asyncio") + f", {setting}"
            met = floor_met = 0
            ratios = []
            for k in range(RUNS if not use_uvloop else 2):
                floor = idle_floor()
                server, client, servo, late99, stale = measure(use_uvloop, priority)
                met += _ok(server)
                floor_met += _ok(floor)
                ratios.append(server[1] / max(floor[1], 1e-6))
                lines.append(f"{name} run {k + 1}: sent {_ms(server)}, lateness p99 {late99 * 1e3:.3f} ms, "
                             f"{stale} late; received {_ms(client)}; idle process {_ms(floor)}; "
                             f"servoj {servo / (SECONDS + 0.5):.0f}/s")
            runs = RUNS if not use_uvloop else 2
            lines.append(f"{name}: {met}/{runs} runs on target (idle process: {floor_met}/{runs}); "
                         f"send p99 / idle p99 median {float(np.median(ratios)):.2f}")
    lines.append(frame_cost())
    lines.append(f"load average after: {os.getloadavg()[0]:.2f}")
    return lines


if __name__ == "__main__":
    for line in run():
        print(line)
