"""Fleets in worker processes (``xarm-emu serve --fleet FILE``, server/workers.py), three figures, each
measured in the same run:

- **arms per machine**: the largest fleet of xArm6 (searching upward through :data:`FLEET_SIZES`) for
  which every arm's develop-report reader (manual 2.1.6, 100 Hz) gets at least :data:`MIN_RATE`
  frames/s over :data:`SECONDS` s, the arms over the default workers (one per CPU), every reader in
  this process. Target: >= 60 on a 2-CPU machine. The rate alone counts late frames too (written
  more than a control period after their deadline, the worker too busy to make them in time), so
  each line also gives the share of late frames the workers counted, and the search ends with the
  largest fleet with at most ``STALE_WARN`` of them; and how long the fleet took to stop.
- **CPU per idle arm**: process CPU time of one worker serving :data:`IDLE_ARMS` arms nobody is
  connected to, against one worker serving one arm, both running at once; (difference / extra
  arms) as a share of one core. Target: < 0.2 %.
- **round trips through a worker**: command-port round trips (GET_STATE and GET_POSITION) to a
  one-arm fleet's worker against the minimal echo server of ``bench_roundtrip``, interleaved
  rounds, the worker placed on the CPUs the echo server runs on. Target: ratio >= 0.85.

Run: ``python -m bench fleet``.
"""

from __future__ import annotations

import contextlib
import os
import selectors
import socket
import struct
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from bench.affinity import pin_client, restore
from bench.bench_roundtrip import _finish, _spawn, round_trips
from xarm_emu.server.fairness import Limits
from xarm_emu.server.fleet import parse_fleet
from xarm_emu.server.workers import (
    STALE_WARN,
    ArmReady,
    LogSettings,
    Supervisor,
    WorkerPlan,
    default_workers,
    plans,
)

FLEET_SIZES = (20, 40, 60, 80, 100)
SECONDS = 10.0
MIN_RATE = 99.0
TARGET_ARMS = 60
IDLE_ARMS = 50
IDLE_SECONDS = 10.0
TARGET_IDLE = 0.2  # % of one core per idle arm
RT_CALLS = 1000
RT_REPEATS = 20
TARGET_RT = 0.85
#: Stop searching upward once the search has taken this long (s).
SEARCH_BUDGET = 90.0

_ZERO = {"port": 0, "normal_port": 0, "rich_port": 0, "develop_port": 0}


@contextmanager
def fleet(n: int, workers: int, use_uvloop: bool = False,
          **extra: object) -> Iterator[tuple[Supervisor, list[ArmReady]]]:
    """``n`` xArm6 arms on free ports over ``workers`` worker processes (``extra``: fleet-file keys
    of every arm); yields the supervisor and the arms as they report themselves."""
    arms: list[ArmReady] = []

    def ready(_plan: WorkerPlan, _starts: int, got: list[ArmReady]) -> None:
        arms.extend(got)

    with tempfile.TemporaryDirectory(prefix="xarm-emu-bench-fleet-") as cdir:
        spec = parse_fleet({"arm": [{"model": 6, **_ZERO, **extra} for _ in range(n)]})
        sup = Supervisor(plans(spec.arms, workers, Path(cdir), Limits(), LogSettings("WARNING"), use_uvloop),
                         ready)
        sup.start()
        try:
            yield sup, sorted(arms, key=lambda a: a.number)
        finally:
            sup.stop()


def cpu_seconds(pid: int) -> float:
    """User + system CPU time of process ``pid`` (Linux /proc)."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def pin_process(pid: int, cpus: set[int]) -> None:
    """Every thread of process ``pid`` onto ``cpus`` (``sched_setaffinity`` moves one thread)."""
    for tid in os.listdir(f"/proc/{pid}/task"):
        with contextlib.suppress(OSError):
            os.sched_setaffinity(int(tid), cpus)


def reader_rates(ports: list[int], seconds: float, warmup: float = 1.0) -> list[float]:
    """Frames/s each develop reader got over ``seconds`` (after ``warmup``), all read in one thread;
    frames are counted by the length each begins with (manual 2.1.6: a u32 total size)."""
    sel = selectors.DefaultSelector()
    socks = []
    counted = [0] * len(ports)
    size = [0] * len(ports)
    for i, port in enumerate(ports):
        s = socket.create_connection(("127.0.0.1", port))
        s.setblocking(False)
        sel.register(s, selectors.EVENT_READ, i)
        socks.append(s)
    t_start = time.perf_counter() + warmup
    t_end = t_start + seconds
    try:
        while True:
            now = time.perf_counter()
            if now >= t_end:
                break
            for key, _ in sel.select(0.05):
                data = key.fileobj.recv(1 << 16)  # type: ignore[union-attr]
                i = key.data
                if not size[i] and len(data) >= 4:
                    size[i] = struct.unpack(">I", data[:4])[0]
                if now >= t_start:
                    counted[i] += len(data)
    finally:
        for s in socks:
            sel.unregister(s)
            s.close()
        sel.close()
    return [c / max(1, sz) / seconds for c, sz in zip(counted, size, strict=True)]


def arms_per_machine() -> tuple[int, list[str]]:
    """The largest fleet size of :data:`FLEET_SIZES` whose every reader gets :data:`MIN_RATE`."""
    best, best_fresh, lines = 0, 0, []
    workers = default_workers()
    t0 = time.monotonic()
    for n in FLEET_SIZES:
        if time.monotonic() - t0 > SEARCH_BUDGET:
            lines.append(f"search stopped after {time.monotonic() - t0:.0f} s")
            break
        with fleet(n, workers) as (sup, arms):
            pids = [p for p in sup.pids().values() if p is not None]
            c0 = [cpu_seconds(p) for p in pids]
            rates = reader_rates([a.ports["develop"] for a in arms], SECONDS)
            cpu = [100 * (cpu_seconds(p) - c) / (SECONDS + 1.0) for p, c in zip(pids, c0, strict=True)]
            t_stop = time.perf_counter()
            sup.stop()
            t_stop = time.perf_counter() - t_stop
        counts = list(sup.report_counts.values())
        stale = sum(c.stale for c in counts) / max(1, sum(c.sent for c in counts))
        worst = min(rates)
        fresh = stale <= STALE_WARN and len(counts) == workers
        ok = worst >= MIN_RATE
        lines.append(f"{n:3d} arms over {workers} workers: slowest reader {worst:6.1f} frames/s, mean "
                     f"{sum(rates) / len(rates):6.1f}; {100 * stale:.1f} % of frames late; workers at "
                     + ", ".join(f"{c:.0f}" for c in cpu) + f" % of a core; stopped in {t_stop:.2f} s"
                     + ("" if worst >= MIN_RATE else " (below 99)")
                     + ("" if fresh else f" (over {100 * STALE_WARN:.0f} % late)"))
        if not ok:
            break
        best = n
        if fresh:
            best_fresh = n
    lines.append(f"largest fleet whose frames were also fresh (at most {100 * STALE_WARN:.0f} % late): "
                 f"{best_fresh}")
    return best, lines


def idle_cost() -> tuple[float, list[str]]:
    """% of one core per idle arm: one worker of IDLE_ARMS arms against one worker of one arm."""
    with fleet(IDLE_ARMS, 1) as (many, _), fleet(1, 1) as (one, _):
        p_many = next(p for p in many.pids().values() if p is not None)
        p_one = next(p for p in one.pids().values() if p is not None)
        time.sleep(2.0)  # past start-up
        c_many, c_one, t0 = cpu_seconds(p_many), cpu_seconds(p_one), time.perf_counter()
        time.sleep(IDLE_SECONDS)
        wall = time.perf_counter() - t0
        d_many, d_one = cpu_seconds(p_many) - c_many, cpu_seconds(p_one) - c_one
    per_arm = 100 * (d_many - d_one) / (IDLE_ARMS - 1) / wall
    verdict = "ok" if per_arm < TARGET_IDLE else f"above target {TARGET_IDLE} %"
    return per_arm, [f"idle: {IDLE_ARMS} arms {100 * d_many / wall:.2f} % of a core, 1 arm "
                     f"{100 * d_one / wall:.2f} %: {per_arm:.3f} % per idle arm ({verdict})"]


def worker_round_trips(use_uvloop: bool) -> list[str]:
    """Round trips to a one-arm fleet's worker against the echo server, interleaved rounds."""
    saved = pin_client()
    lines = []
    echo_proc, echo_port = _spawn("echo", use_uvloop)  # pinned to the highest CPU (bench/affinity.py)
    try:
        with fleet(1, 1, use_uvloop) as (sup, arms):
            pid = next(p for p in sup.pids().values() if p is not None)
            # Where the echo server runs (its child inherits the client's CPU before PIN_SERVER
            # picks the highest of those): the worker gets the same placement.
            pin_process(pid, os.sched_getaffinity(echo_proc.pid))
            port = arms[0].ports["command"]
            for reg, name in ((13, "get_state"), (41, "get_position")):
                worker, echo = [], []
                for _ in range(RT_REPEATS):
                    worker.append(round_trips(port, reg, RT_CALLS))
                    echo.append(round_trips(echo_port, reg, RT_CALLS))
                ratios = sorted(a / b for a, b in zip(worker, echo, strict=True))
                ratio = max(worker) / max(echo)
                verdict = "ok" if ratio >= TARGET_RT else f"below target {TARGET_RT}"
                loop_name = "uvloop" if use_uvloop else "asyncio"
                lines.append(f"{loop_name:7s} {name:12s}: worker {max(worker):8.0f}/s, echo "
                             f"{max(echo):8.0f}/s (best of {RT_REPEATS}), ratio {ratio:.2f} "
                             f"({verdict}); median round ratio {ratios[len(ratios) // 2]:.2f}")
    finally:
        _finish(echo_proc)
        restore(saved)
    return lines


def run() -> list[str]:
    lines = [f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs at start"]
    best, search = arms_per_machine()
    lines += search
    lines.append(f"arms per machine at full report rates: {best} "
                 + ("(ok)" if best >= TARGET_ARMS else f"(below target {TARGET_ARMS})"))
    lines += idle_cost()[1]
    loops = [False]
    try:
        import uvloop  # type: ignore[import-not-found]  # noqa: F401

        loops.insert(0, True)
    except ImportError:
        pass
    for use_uvloop in loops:
        lines += worker_round_trips(use_uvloop)
    lines.append(f"load average {os.getloadavg()[0]:.2f} at the end")
    return lines


if __name__ == "__main__":
    for line in run():
        print(line, flush=True)
