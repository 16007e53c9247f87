"""`xarm-emu proxy`: the unchanged SDK drives an emulator through the recording proxy; every byte passes
unchanged both ways, the recording holds the frames decoded, and the added round trip is small."""

from __future__ import annotations

import socket
import statistics
import time
from pathlib import Path

import pytest

from xarm_emu.client import Client
from xarm_emu.protocol.firmware import SERVE_VERSION
from xarm_emu.server import xrec
from xarm_emu.testing import running_emulator, running_proxy, sdk_pointed_at


def _program(arm: object) -> None:
    """Moves, gripper and IO calls of the official SDK."""
    arm.motion_enable(True)  # type: ignore[attr-defined]
    arm.set_mode(0)  # type: ignore[attr-defined]
    arm.set_state(0)  # type: ignore[attr-defined]
    assert arm.set_servo_angle(angle=[20, -10, -5, 0, 15, 0], speed=60, wait=True) == 0  # type: ignore[attr-defined]
    assert arm.set_position(x=300, y=50, z=200, roll=180, pitch=0, yaw=0, speed=200, wait=True) == 0  # type: ignore[attr-defined]
    arm.set_gripper_enable(True)  # type: ignore[attr-defined]
    arm.set_gripper_position(400, wait=False)  # type: ignore[attr-defined]
    arm.set_cgpio_digital(2, 1)  # type: ignore[attr-defined]
    arm.get_cgpio_state()  # type: ignore[attr-defined]


@pytest.fixture(scope="module")
def session(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    from xarm.wrapper import XArmAPI

    d = tmp_path_factory.mktemp("proxy")
    rec, trace = d / "session.xrec", d / "trace.jsonl"
    with running_emulator(firmware=SERVE_VERSION, trace=trace) as st, running_proxy(st, rec) as px, \
            sdk_pointed_at(px):  # type: ignore[arg-type]
        arm = XArmAPI("127.0.0.1", is_radian=False)
        try:
            _program(arm)
        finally:
            arm.disconnect()
    return rec, trace


def test_replies_pass_byte_for_byte_and_are_decoded(session: tuple[Path, Path]) -> None:
    import json

    rec, trace = session
    records = list(xrec.read(rec))
    assert isinstance(records[0], xrec.Header) and records[0].format == xrec.FORMAT
    replies = [r for r in records if isinstance(r, xrec.Rep) and r.register != 0xFF]
    requests = [r for r in records if isinstance(r, xrec.Req)]
    traced = [json.loads(line) for line in trace.read_text().splitlines()]
    traced = [t for t in traced if "event" not in t]
    # what the box answered (its own trace) is what the proxy passed on, frame for frame
    assert len(replies) == len(traced) > 20
    for r, t in zip(replies, traced, strict=True):
        assert (r.tid, r.register, r.state) == (t["tid"], t["register"], t["state"])
        assert r.params.hex() == t["reply"]
    assert [q.params.hex() for q in requests if q.protocol != 1] == [t["params"] for t in traced]
    fw = [r for r in records if isinstance(r, xrec.Fw)]
    assert fw and fw[0].version.endswith(SERVE_VERSION)
    moves = [q for q in requests if q.name == "MOVE_JOINT"]
    assert moves and moves[0].values is not None and len(moves[0].values["joints"]) == 7
    kinds = {r.port for r in records if isinstance(r, xrec.Rpt)}
    assert 30002 in kinds  # the SDK reads the rich report


def test_report_frames_pass_byte_for_byte(tmp_path: Path) -> None:
    rec = tmp_path / "reports.xrec"
    with running_emulator(firmware=SERVE_VERSION) as st, running_proxy(st, rec) as px:
        with socket.create_connection(("127.0.0.1", px.ports["realtime"])) as s:
            s.settimeout(5.0)
            got = bytearray()
            while len(got) < 804 * 50:
                got += s.recv(65536)
    frames = b"".join(r.frame for r in xrec.read(rec) if isinstance(r, xrec.Rpt) and r.port == 30000)
    assert len(got) >= 804 * 50 and frames[:len(got)] == bytes(got)


def test_added_round_trip_is_small() -> None:
    """The median round trip of a register read through the proxy, against the same read direct."""
    with running_emulator(firmware=SERVE_VERSION) as st, running_proxy(st) as px:
        def median(port: int) -> float:
            with Client("127.0.0.1", port) as c:
                times = []
                for _ in range(400):
                    t0 = time.perf_counter()
                    c.get_state()
                    times.append(time.perf_counter() - t0)
            return statistics.median(times)

        direct, proxied = median(st.ports["command"]), median(px.ports["command"])
        lat = px.proxy.latency()
    added = proxied - direct
    print(f"round trip direct {direct * 1e3:.3f} ms, through the proxy {proxied * 1e3:.3f} ms, "
          f"added {added * 1e3:.3f} ms; time in the proxy median {lat['p50'] * 1e3:.4f} ms")
    assert added < 0.2e-3


def test_proxy_command_relays_records_and_prints_its_latency(tmp_path: Path) -> None:
    """`xarm-emu proxy` as a user runs it: shifted ports on both sides, Ctrl-C to stop."""
    import random
    import signal
    import subprocess
    import sys

    rec = tmp_path / "cli.xrec"
    # offsets whose ports all stay below the kernel's ephemeral range (32768 up), where the suite's
    # own client connections could hold one of them, and apart from each other
    listen, to = random.randrange(600, 1500), random.randrange(1600, 2700)
    ports = {"port": 502 + to, "realtime_port": 30000 + to, "normal_port": 30001 + to,
             "rich_port": 30002 + to, "develop_port": 30003 + to}
    with running_emulator(firmware=SERVE_VERSION, **ports) as st:
        proc = subprocess.Popen([sys.executable, "-m", "xarm_emu.cli", "proxy", "--to", "127.0.0.1",
                                 "--record", str(rec), "--port-offset", str(listen),
                                 "--to-port-offset", str(to)],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        try:
            deadline = time.monotonic() + 20
            while True:
                try:
                    with Client("127.0.0.1", 502 + listen) as c:
                        version = c.get_version()
                    break
                except OSError:
                    assert time.monotonic() < deadline and proc.poll() is None
                    time.sleep(0.1)
            assert st.ports["command"] == 502 + to
        finally:
            proc.send_signal(signal.SIGINT)
            out, err = proc.communicate(timeout=20)
    assert proc.returncode == 0, err
    assert "command chunks relayed; time in the proxy: median" in out
    reps = [r for r in xrec.read(rec) if isinstance(r, xrec.Rep) and r.register == 1]
    assert reps and reps[0].values is not None and reps[0].values["version"].strip("\0") == version


def test_proxy_refuses_bad_offsets_in_one_line(tmp_path: Path) -> None:
    from helpers import run_cli

    code, out = run_cli("proxy", "--to", "127.0.0.1", "--record", str(tmp_path / "x.xrec"),
                        "--port-offset", "40000")
    assert code == 2 and out.strip() == "--port-offset: the ports 40502..70003 are not all valid"
