"""A fleet in worker processes (`xarm-emu serve --fleet FILE --workers N`, server/workers.py): every
arm answers the unchanged SDK, a worker killed with SIGKILL comes back on its addresses with its
saved configuration while the other worker's arms keep their connections, SIGTERM stops them all."""

from __future__ import annotations

import contextlib
import logging
import os
import queue
import re
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest
from helpers import free_ports, wait_for
from helpers import run_cli as run

from xarm_emu.server.workers import STALE_WARN, ReportCounts, assign, describe_exit, report_counts_message

_WORKER = re.compile(r"fleet worker (\d+) \(pid (\d+)\): arms ([\d, ]+)")


def _bindable(port: int) -> bool:
    with socket.socket() as s:
        try:
            s.bind(("127.0.0.1", port))
        except OSError:
            return False
    return True


def _arm_ports() -> dict[str, int]:
    """Free command and report ports; the real-time report of firmware 2.x listens two below the
    rich port, so that one must be free too."""
    while True:
        cmd, normal, rich, develop = free_ports(4)
        if rich - 2 not in (cmd, normal, develop) and _bindable(rich - 2):
            return {"port": cmd, "normal_port": normal, "rich_port": rich, "develop_port": develop}


def _fleet_file(tmp_path: Path, arms: list[dict[str, Any]]) -> Path:
    text = 'config_dir = "cfg"\n'
    for arm in arms:
        text += "[[arm]]\n" + "".join(f"{k} = {v!r}\n" if isinstance(v, int) else f'{k} = "{v}"\n'
                                      for k, v in arm.items())
    path = tmp_path / "fleet.toml"
    path.write_text(text)
    return path


class Fleet:
    """`xarm-emu serve --fleet` in a child process; its output lines collected by a thread."""

    def __init__(self, path: Path, *args: str) -> None:
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "xarm_emu.cli", "serve", "--fleet", str(path), "--log-level", "INFO",
             *args], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
            env={**os.environ, "COLUMNS": "500"})
        self.lines: queue.Queue[str] = queue.Queue()
        self.seen: list[str] = []
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.put(line)

    def wait_line(self, pattern: re.Pattern[str], timeout: float = 30.0) -> re.Match[str]:
        """The next output line matching ``pattern`` (earlier ones are kept in :attr:`seen`)."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            try:
                line = self.lines.get(timeout=0.1)
            except queue.Empty:
                continue
            self.seen.append(line)
            m = pattern.search(line)
            if m:
                return m
        raise AssertionError(f"no line matching {pattern.pattern!r}; output: {''.join(self.seen)}")

    def workers(self, n: int) -> dict[int, tuple[int, list[int]]]:
        """Worker index -> (pid, arm numbers) of the next ``n`` worker start lines."""
        out = {}
        for _ in range(n):
            m = self.wait_line(_WORKER)
            out[int(m[1])] = (int(m[2]), [int(a) for a in m[3].split(",")])
        return out

    def stop(self) -> int:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
        try:
            return self.proc.wait(15)
        finally:
            if self.proc.poll() is None:
                self.proc.kill()
                self.proc.wait()


@contextlib.contextmanager
def fleet_running(path: Path, *args: str) -> Iterator[Fleet]:
    f = Fleet(path, *args)
    try:
        yield f
    finally:
        f.stop()


def _sdk(ports: dict[str, int]) -> Any:
    """The official XArmAPI connected to one arm's ports (rich report)."""
    from xarm.wrapper import XArmAPI

    from xarm_emu.testing import sdk_pointed_at

    server = SimpleNamespace(ports={"command": ports["port"], "normal": ports["normal_port"],
                                    "rich": ports["rich_port"], "develop": ports["develop_port"]})
    with sdk_pointed_at(server):  # type: ignore[arg-type]  # only its ports are read
        return XArmAPI("127.0.0.1", report_type="rich", forbid_uds=True)


def test_arms_are_split_evenly_and_exits_are_described() -> None:
    assert assign(5, 2) == [(0, 1, 2), (3, 4)]
    assert assign(4, 4) == [(0,), (1,), (2,), (3,)]
    assert assign(2, 8) == [(0,), (1,)]  # never an idle worker
    assert assign(7, 1) == [tuple(range(7))]
    assert describe_exit(-signal.SIGKILL) == "killed by signal SIGKILL"
    assert describe_exit(3) == "exit code 3"


@pytest.mark.parametrize("args, fragment", [
    (("--workers", "-1"), "--workers: a number of worker processes, 1 or more"),
    (("--workers", "2", "--view"), "--workers: --view serves a fleet's arms from this process"),
    (("--workers", "two"), "Invalid value for '--workers'"),
])
def test_bad_worker_counts_are_one_line_and_exit_2(tmp_path: Path, args: tuple[str, ...],
                                                   fragment: str) -> None:
    path = _fleet_file(tmp_path, [_arm_ports()])
    code, out = run("serve", "--fleet", str(path), "--config-dir", str(tmp_path), *args)
    assert code == 2 and fragment in " ".join(out.split()), out
    assert "Traceback" not in out
    code, out = run("serve", "--workers", "2", "--port", "0")
    assert code == 2 and "--workers: only with --fleet" in out


def test_a_killed_worker_comes_back_with_its_saved_configuration_and_spares_the_others(
        tmp_path: Path) -> None:
    ports = [_arm_ports() for _ in range(3)]
    path = _fleet_file(tmp_path, [{**ports[0], "model": 6}, {**ports[1], "model": 7},
                                  {**ports[2], "model": 6}])
    arms: list[Any] = []
    with fleet_running(path, "--workers", "2") as fleet:
        workers = fleet.workers(2)
        assert {w: a for w, (_, a) in workers.items()} == {1: [1, 2], 2: [3]}
        arms = [_sdk(p) for p in ports]
        assert [a.axis for a in arms] == [6, 7, 6]
        assert [a.get_robot_sn()[1] for a in arms] == ["XI1300", "XS1300", "XI1301"]
        # Each arm saves its own TCP offset (registers 35 and 40, manual 2.1.3).
        for arm, z in zip(arms, (50.0, 60.0, 70.0), strict=True):
            assert arm.set_tcp_offset([0, 0, z, 0, 0, 0], wait=False) == 0
            assert arm.save_conf() == 0
        survivor = arms[2]
        stream = survivor._arm._stream  # the survivor's command connection, which must stay the same
        assert stream is not None
        killed_pid = workers[1][0]
        os.kill(killed_pid, signal.SIGKILL)
        t_kill = time.monotonic()
        death = fleet.wait_line(re.compile(r"fleet worker 1 \(pid \d+; arms 1, 2\) died: killed by "
                                           r"signal SIGKILL"))
        assert death
        again = fleet.workers(1)
        assert again[1][1] == [1, 2] and again[1][0] != killed_pid
        back = []
        for p in ports[:2]:
            with socket.create_connection(("127.0.0.1", p["port"]), timeout=2):
                back.append(time.monotonic() - t_kill)
        assert max(back) < 2.0, back
        # The other worker's arm never noticed: same connection, answering, its offset as saved.
        assert survivor.connected and survivor._arm._stream is stream
        code, pos = survivor.get_position()
        assert code == 0 and len(pos) == 6
        assert wait_for(lambda: list(survivor.tcp_offset) == pytest.approx([0, 0, 70, 0, 0, 0], abs=1e-3))
        # The restarted arms loaded what they saved before the kill.
        for arm in arms[:2]:
            arm.disconnect()
        arms = [_sdk(p) for p in ports[:2]] + [survivor]
        for arm, z in zip(arms[:2], (50.0, 60.0), strict=True):
            assert wait_for(lambda a=arm, z=z: list(a.tcp_offset) == pytest.approx([0, 0, z, 0, 0, 0],
                                                                                   abs=1e-3))
            assert arm.get_position()[0] == 0
        for arm in arms:
            arm.disconnect()
        arms = []
        t_stop = time.monotonic()
        code = fleet.stop()
        stopped_in = time.monotonic() - t_stop
    for arm in arms:
        arm.disconnect()
    assert code == 0 and stopped_in < 10.0, "".join(fleet.seen)
    while not fleet.lines.empty():
        fleet.seen.append(fleet.lines.get())
    assert "Traceback" not in "".join(fleet.seen)
    assert sorted(p.name for p in (tmp_path / "cfg").glob("config-*.json")) == [
        "config-XI1300.json", "config-XI1301.json", "config-XS1300.json"]


def test_a_port_taken_stops_every_worker_with_one_line_and_exit_1(tmp_path: Path) -> None:
    ports = [_arm_ports() for _ in range(2)]
    path = _fleet_file(tmp_path, ports)
    with socket.socket() as taken:
        taken.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        taken.bind(("127.0.0.1", ports[1]["develop_port"]))
        taken.listen()
        proc = subprocess.run([sys.executable, "-m", "xarm_emu.cli", "serve", "--fleet", str(path),
                               "--workers", "2", "--log-level", "WARNING"], capture_output=True, text=True,
                              timeout=60, env={**os.environ, "COLUMNS": "500"})
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert "a port of the fleet file is already in use" in proc.stderr
    assert "Traceback" not in proc.stderr
    for p in ports[0].values():  # the other worker's arm was closed again
        assert _bindable(p)


def test_a_stopped_worker_reports_its_frames_and_warns_when_it_was_saturated(tmp_path: Path) -> None:
    ports = _arm_ports()
    path = _fleet_file(tmp_path, [ports])
    with fleet_running(path, "--workers", "1") as fleet:
        fleet.workers(1)
        with socket.create_connection(("127.0.0.1", ports["develop_port"]), timeout=3) as dev:
            t0 = time.monotonic()
            got = 0
            while time.monotonic() - t0 < 0.6:
                got += len(dev.recv(65536))
        assert got >= 87 * 30  # 100 Hz develop frames of 87 bytes (manual 2.1.6)
        assert fleet.stop() == 0
        m = fleet.wait_line(re.compile(r"fleet worker 1 \(arms 1\): (\d+) report frames sent, "
                                       r"([\d.]+) % late by over a control period, (\d+) missed"))
    assert int(m[1]) >= 30 and float(m[2]) <= 100 * STALE_WARN and int(m[3]) == 0, m[0]
    # the line's verdict follows the counts
    level, text = report_counts_message(2, "5, 6", ReportCounts(sent=1000, stale=80, missed=0))
    assert level == logging.WARNING and "8.0 %" in text and "saturated" in text
    level, text = report_counts_message(2, "5, 6", ReportCounts(sent=1000, stale=10, missed=0))
    assert level == logging.INFO and "saturated" not in text
    assert report_counts_message(0, "1", ReportCounts(sent=10, stale=0, missed=3))[0] == logging.WARNING
