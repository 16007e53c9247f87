"""Report ports (manual 2.1.6): frame sizes with the u32 BE length, rates, fields from
the live controller, slow readers, and scaled time."""

from __future__ import annotations

import math
import socket
import struct
import time

import pytest
from helpers import recv_exact

from xarm_emu.client import Client
from xarm_emu.protocol import reports
from xarm_emu.server.app import ServerThread

SIZES = {"develop": 87, "normal": 145, "rich": 433}
DECODERS = {"develop": reports.decode_develop, "normal": reports.decode_normal, "rich": reports.decode_rich}


def read_frames(sock: socket.socket, seconds: float) -> list[tuple[float, bytes]]:
    """Frames (arrival time, bytes) read for ``seconds``; each checked to start with its length."""
    out = []
    end = time.monotonic() + seconds
    buf = b""
    sock.settimeout(0.05)
    while time.monotonic() < end:
        try:
            chunk = sock.recv(65536)
        except TimeoutError:
            continue
        assert chunk, "report connection closed"
        now = time.monotonic()
        buf += chunk
        while len(buf) >= 4:
            (size,) = struct.unpack(">I", buf[:4])
            if len(buf) < size:
                break
            out.append((now, buf[:size]))
            buf = buf[size:]
    return out


@pytest.fixture
def srv(make_server) -> ServerThread:
    return make_server()


def test_frame_lengths_rates_and_fields(srv: ServerThread) -> None:
    socks = {k: socket.create_connection(("127.0.0.1", srv.ports[k]), timeout=2) for k in SIZES}
    try:
        time.sleep(0.05)
        t0 = time.monotonic()
        got = {k: [] for k in SIZES}
        # read all three streams for ~1 s, interleaved
        end = t0 + 1.0
        while time.monotonic() < end:
            for k, s in socks.items():
                got[k] += read_frames(s, 0.01)
        for kind, frames in got.items():
            assert frames, kind
            for _, f in frames:
                assert len(f) == SIZES[kind]
                assert struct.unpack(">I", f[:4])[0] == SIZES[kind]
        span = {k: v[-1][0] - v[0][0] for k, v in got.items()}
        develop_rate = (len(got["develop"]) - 1) / span["develop"]
        assert develop_rate == pytest.approx(100.0, rel=0.15)
        for kind in ("normal", "rich"):
            assert 4 <= len(got[kind]) <= 7, (kind, len(got[kind]))
            gaps = [b[0] - a[0] for a, b in zip(got[kind], got[kind][1:], strict=False)]
            assert sum(gaps) / len(gaps) == pytest.approx(0.2, abs=0.04)
        snap = DECODERS["rich"](got["rich"][-1][1])
        assert snap.state == 4 and snap.axis == 6
    finally:
        for s in socks.values():
            s.close()


def test_report_fields_follow_the_controller(srv: ServerThread) -> None:
    with Client("127.0.0.1", srv.ports["command"]) as c, \
            socket.create_connection(("127.0.0.1", srv.ports["develop"]), timeout=2) as dev:
        c.motion_enable(True)
        c.set_mode(0)
        c.set_state(0)
        target = (0.5, -0.2, -0.3, 0.1, 0.4, -0.6, 0.0)
        r = c.call(23, joints=target, speed=3.0, acc=20.0, mvtime=0.0)
        assert r.state == 0
        deadline = time.monotonic() + 5
        snap = None
        while time.monotonic() < deadline:
            snap = reports.decode_develop(read_frames(dev, 0.05)[-1][1])
            if snap.state == 2 and snap.joints[0] == pytest.approx(0.5, abs=1e-6):
                break
        assert snap is not None and snap.state == 2
        assert snap.joints[:6] == pytest.approx(target[:6], abs=1e-6)
        assert snap.pose == pytest.approx(c.get_position(), abs=1e-3)
        assert dev.getpeername()[1] == srv.ports["develop"]
    # the develop report has no error byte; the rich one does (bytes 89/90 of the common prefix)
    srv.call(lambda: srv.emulator.inject_error(31))
    with socket.create_connection(("127.0.0.1", srv.ports["rich"]), timeout=2) as rich:
        snap = reports.decode_rich(read_frames(rich, 0.25)[-1][1])
    assert (snap.error, snap.state) == (31, 4)
    assert snap.joints[:6] == pytest.approx(target[:6], abs=1e-6)


def test_slow_reader_does_not_slow_others(make_server) -> None:
    # rich frames at 500 Hz fill a reader's socket buffers within a second
    srv = make_server(report_rates={"develop": 100.0, "normal": 5.0, "rich": 500.0})
    slow = [socket.socket() for _ in range(3)]
    for s in slow:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        s.connect(("127.0.0.1", srv.ports["rich"]))  # never reads
    try:
        with socket.create_connection(("127.0.0.1", srv.ports["develop"]), timeout=2) as fast, \
                Client("127.0.0.1", srv.ports["command"]) as c:
            deadline = time.monotonic() + 5.0
            while srv.call(lambda: srv.server.frames_skipped["rich"]) < 3 * 20:
                read_frames(fast, 0.1)
                assert time.monotonic() < deadline, "slow readers never fell behind"
            frames = read_frames(fast, 1.0)  # while the slow readers are being skipped
            assert len(frames) >= 85
            gaps = [b[0] - a[0] for a, b in zip(frames, frames[1:], strict=False)]
            assert max(gaps) < 0.05
            t0 = time.perf_counter()
            for _ in range(200):
                c.get_state()
            assert (time.perf_counter() - t0) / 200 < 0.005
        # what a slow reader got is whole frames: it reads on from a frame boundary
        s = slow[0]
        s.settimeout(1.0)
        for _ in range(300):
            frame = recv_exact(s, 433)
            assert struct.unpack(">I", frame[:4])[0] == 433 and len(frame) == 433
            assert reports.decode_rich(frame).axis == 6
    finally:
        for s in slow:
            s.close()


def test_scaled_time_speed_10(make_server) -> None:
    srv = make_server(speed=10.0)
    with Client("127.0.0.1", srv.ports["command"]) as c:
        c.motion_enable(True)
        c.set_mode(0)
        c.set_state(0)
        time.sleep(0.05)
        # joint 1 by 2 rad at 1 rad/s with a high acceleration: a little over 2 s of controller time
        t0 = time.monotonic()
        r = c.call(23, joints=(2.0, 0, 0, 0, 0, 0, 0), speed=1.0, acc=20.0, mvtime=0.0)
        assert r.state == 0
        t_ctl0 = srv.call(lambda: srv.emulator.time)
        while c.get_state() == 1 or time.monotonic() - t0 < 0.02:
            time.sleep(0.002)
            assert time.monotonic() - t0 < 2.0
        wall = time.monotonic() - t0
        t_ctl = srv.call(lambda: srv.emulator.time) - t_ctl0
        assert c.get_joints()[0] == pytest.approx(2.0, abs=1e-6)
    # the move lasts a little over 2 s of controller time (acceleration ramps)
    assert 2.0 <= t_ctl <= 2.3 + 0.1
    assert wall == pytest.approx(0.2, abs=0.06)
    assert math.isfinite(wall)
