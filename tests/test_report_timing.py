"""Report timing (manual 2.1.6): frames go out from one sender per process on an absolute schedule,
whatever the event loop is doing; a reader that falls behind gets whole frames; the sender's
sockets close with their connections and the sender stops with its last server."""

from __future__ import annotations

import logging
import os
import socket
import struct
import subprocess
import sys
import threading
import time

import pytest
from helpers import call, connect, joints7, read_frames, recv_frame, wait_for
from helpers import ready as emu_ready

from xarm_emu.protocol import reports
from xarm_emu.protocol.frame import encode_request
from xarm_emu.server import report_sender
from xarm_emu.server.app import ServerThread
from xarm_emu.server.report_sender import LATE_FRAMES, Reader, next_deadline

INTERVAL = 1.0 / reports.DEVELOP_RATE


def _sender_threads() -> list[threading.Thread]:
    return [t for t in threading.enumerate() if t.name == "xarm-emu-reports"]


def _socket_count() -> int:
    n = 0
    for fd in os.listdir("/proc/self/fd"):
        try:
            n += os.readlink(f"/proc/self/fd/{fd}").startswith("socket:")
        except OSError:
            pass
    return n


def _arrivals(sock: socket.socket, seconds: float, size: int = 87) -> list[float]:
    """Arrival time of each whole develop frame read for ``seconds``."""
    frames = read_frames(sock, seconds, poll=0.01)
    assert all(len(f) == size for _, f in frames)
    return [t for t, _ in frames]


def _drain(sock: socket.socket) -> bytes:
    sock.settimeout(0.2)
    got = b""
    while True:
        try:
            chunk = sock.recv(65536)
        except TimeoutError:
            return got
        got += chunk


def test_the_schedule_is_absolute_late_frames_do_not_drift_it() -> None:
    # a fake clock: each frame goes out late by a varying amount under one interval
    anchor = 1000.0
    deadline = anchor
    for k in range(1, 10_001):
        sent_at = deadline + (k % 7) * 0.13 * INTERVAL
        deadline, missed = next_deadline(deadline, INTERVAL, sent_at)
        assert missed == 0
    assert deadline == pytest.approx(anchor + 10_000 * INTERVAL, abs=1e-9)  # no accumulated drift
    # a few intervals behind (a CPU hiccup): the due frames still go out, at once
    assert next_deadline(anchor, INTERVAL, anchor + 5 * INTERVAL) == (anchor + INTERVAL, 0)


def test_far_behind_the_schedule_skips_ahead_on_the_same_grid_and_counts_the_missed() -> None:
    anchor = 50.0
    now = anchor + (LATE_FRAMES + 40.5) * INTERVAL  # the process was suspended
    nxt, missed = next_deadline(anchor, INTERVAL, now)
    assert now <= nxt < now + INTERVAL
    k = (nxt - anchor) / INTERVAL
    assert k == pytest.approx(round(k), abs=1e-6)  # still anchor + k * interval
    assert missed == round(k) - 1 == LATE_FRAMES + 40


def test_a_reader_that_falls_behind_gets_whole_frames_only() -> None:
    with socket.create_server(("127.0.0.1", 0)) as listener:
        b = socket.socket()
        b.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        b.connect(listener.getsockname())
        a, _ = listener.accept()
    try:
        a.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, 4096)
        reader = Reader(a)
        frames = [struct.pack(">I", 433) + bytes([k % 251]) * 429 for k in range(400)]
        taken = [reader.offer(f) for f in frames]
        assert not all(taken)  # the socket filled: frames were refused, not queued
        assert len(reader.rest) < 433  # at most the rest of one frame is held
        got = _drain(b)
        assert reader.offer(frames[0])  # the reader caught up: the held rest goes first, then the frame
        got += _drain(b)
        sent = [f for f, ok in zip(frames, taken, strict=True) if ok]
        assert got == b"".join(sent) + frames[0]  # in order, each complete
    finally:
        reader.sock.close()
        a.close()
        b.close()


class _Budget(Reader):
    """A reader whose kernel takes ``budget`` bytes, then nothing until more is granted."""

    def __init__(self, sock: socket.socket) -> None:
        super().__init__(sock)
        self.budget = 0
        self.wire = b""

    def _send(self, data: bytes) -> int:
        n = min(self.budget, len(data))
        self.budget -= n
        self.wire += data[:n]
        return n


def test_a_frame_partly_taken_is_finished_before_the_next_and_the_frames_between_are_skipped() -> None:
    a, b = socket.socketpair()
    reader = _Budget(a)
    try:
        f1, f2, f3, f4 = (struct.pack(">I", 87) + bytes([k]) * 83 for k in range(4))
        reader.budget = 87 + 30
        assert reader.offer(f1) and reader.offer(f2)  # f2 only partly taken
        assert reader.rest == f2[30:]
        assert not reader.offer(f3)  # nothing more taken: f3 skipped, the rest still held
        reader.budget = 57
        assert not reader.offer(f3)  # the rest of f2 goes out, no room for f3: skipped
        assert reader.wire == f1 + f2
        reader.budget = 1000
        assert reader.offer(f4) and not reader.rest
        assert reader.wire == f1 + f2 + f4  # whole frames only, in order
    finally:
        reader.sock.close()
        a.close()
        b.close()


def _slow_move(srv: ServerThread) -> None:
    """A joint move of some seconds: an arm in motion, whose every frame differs from the last."""
    emu = srv.emulator

    def move() -> None:
        emu_ready(emu)
        call(emu, 23, joints=joints7(1.5), speed=0.2, acc=2.0, mvtime=0.0)

    srv.call(move)


def _hold_loop(srv: ServerThread, seconds: float) -> threading.Thread:
    """A thread that has the server's event loop sleep ``seconds`` (a handler that blocks the loop
    without touching the arm)."""
    done = threading.Event()

    def hold() -> None:
        time.sleep(seconds)
        done.set()

    t = threading.Thread(target=lambda: (srv.loop.call_soon_threadsafe(hold), done.wait(5)))
    t.start()
    return t


def test_frames_keep_their_schedule_and_stay_fresh_while_the_event_loop_is_blocked(make_server) -> None:  # type: ignore[no-untyped-def]
    """The sender makes every frame itself at its deadline: a loop held for 400 ms delays none of
    them, and each still shows the moving arm at its own instant (no frame repeats the last)."""
    srv: ServerThread = make_server()
    _slow_move(srv)
    with socket.create_connection(("127.0.0.1", srv.ports["develop"]), timeout=2) as dev:
        _arrivals(dev, 0.3)  # the stream runs
        t0 = time.monotonic()
        blocker = _hold_loop(srv, 0.4)
        frames = read_frames(dev, 0.4, poll=0.01)
        blocker.join()
    during = [(t, f) for t, f in frames if t - t0 < 0.38]
    gaps = [b[0] - a[0] for a, b in zip(during, during[1:], strict=False)]
    # 40 frames are due while the loop sleeps; on the loop they would all wait for it
    assert len(during) >= 30, len(during)
    assert max(gaps) < 0.05, max(gaps)
    assert all(a[1][12:] != b[1][12:] for a, b in zip(during, during[1:], strict=False))


def test_one_sender_serves_every_server_of_the_process_and_stops_with_the_last(make_server) -> None:  # type: ignore[no-untyped-def]
    if report_sender._shared is not None:  # another test's server still running in this process
        pytest.skip("a report sender is already running")
    sockets0 = _socket_count()
    first: ServerThread = make_server()
    second: ServerThread = make_server(7)
    assert len(_sender_threads()) == 1
    with socket.create_connection(("127.0.0.1", first.ports["develop"]), timeout=2) as a, \
            socket.create_connection(("127.0.0.1", second.ports["develop"]), timeout=2) as b:
        got_a = _arrivals(a, 0.5)
        got_b = _arrivals(b, 0.01)
        got_b += _arrivals(b, 0.5)
    assert len(got_a) >= 40 and len(got_b) >= 40
    # the readers are gone: the sender drops them and closes its duplicates of their sockets
    assert wait_for(lambda: not first.server.reports.streams["develop"].readers
                    and not second.server.reports.streams["develop"].readers)
    first.stop()
    assert len(_sender_threads()) == 1  # still serving the second
    second.stop()
    assert wait_for(lambda: not _sender_threads(), 3.0)
    assert wait_for(lambda: _socket_count() <= sockets0, 3.0)


def test_a_stream_without_readers_sends_nothing_and_restarts_on_its_schedule(make_server) -> None:  # type: ignore[no-untyped-def]
    srv: ServerThread = make_server()
    stream = srv.server.reports.streams["develop"]
    time.sleep(0.1)
    assert srv.call(lambda: srv.server.frames_sent["develop"]) == 0
    with socket.create_connection(("127.0.0.1", srv.ports["develop"]), timeout=2) as dev:
        got = _arrivals(dev, 1.0)
    assert 95 <= len(got) <= 101
    assert wait_for(lambda: not stream.scheduled)  # the last reader gone: no more wake-ups
    sent = srv.call(lambda: srv.server.frames_sent["develop"])
    time.sleep(0.1)
    assert srv.call(lambda: srv.server.frames_sent["develop"]) == sent


def _fifo_allowed() -> bool:
    code = "import os; os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(3))"
    return subprocess.run([sys.executable, "-c", code], capture_output=True, timeout=30).returncode == 0


@pytest.mark.skipif(not hasattr(os, "sched_getscheduler"), reason="Linux scheduling")
def test_report_priority_runs_the_sender_at_real_time_priority_or_says_why_not(
        make_server, caplog: pytest.LogCaptureFixture) -> None:  # type: ignore[no-untyped-def]
    with caplog.at_level(logging.WARNING, "xarm_emu.server"):
        srv: ServerThread = make_server(report_priority=3)
    (sender,) = _sender_threads()
    assert sender.native_id is not None
    if _fifo_allowed():
        assert os.sched_getscheduler(sender.native_id) == os.SCHED_FIFO
        assert os.sched_getparam(sender.native_id).sched_priority >= 3
    else:
        assert any("real-time priority 3" in r.getMessage() for r in caplog.records)
    with socket.create_connection(("127.0.0.1", srv.ports["develop"]), timeout=2) as dev:
        assert len(_arrivals(dev, 0.5)) >= 40


@pytest.mark.skipif(not hasattr(os, "sched_getscheduler"), reason="Linux scheduling")
@pytest.mark.parametrize("asked", [None, 0])
def test_the_sender_takes_real_time_priority_by_default_where_allowed_and_quietly(
        make_server, caplog: pytest.LogCaptureFixture, asked: int | None) -> None:  # type: ignore[no-untyped-def]
    """Unless told otherwise the report sender runs at SCHED_FIFO ``DEFAULT_PRIORITY`` where the
    system allows it and at normal priority, with no warning, where it does not; 0 keeps normal
    scheduling."""
    assert not _sender_threads()  # a fresh sender: its priority only ever rises
    with caplog.at_level(logging.WARNING, "xarm_emu.server"):
        srv: ServerThread = make_server(report_priority=asked)
    (sender,) = _sender_threads()
    assert sender.native_id is not None
    real_time = asked is None and _fifo_allowed()
    assert os.sched_getscheduler(sender.native_id) == (os.SCHED_FIFO if real_time else os.SCHED_OTHER)
    if real_time:
        assert os.sched_getparam(sender.native_id).sched_priority == report_sender.DEFAULT_PRIORITY
    assert not [r for r in caplog.records if "priority" in r.getMessage()]
    with socket.create_connection(("127.0.0.1", srv.ports["develop"]), timeout=2) as dev:
        assert len(_arrivals(dev, 0.5)) >= 40


def test_a_closing_server_prepares_no_more_frames(make_server) -> None:  # type: ignore[no-untyped-def]
    """Closing starts by quiescing the report streams: from then on the sender gets no new frame
    from this server, so in a worker with many arms the frames of arms still closing do not keep
    the event loop busy (before, 50 arms with readers that never read took over 10 s to stop)."""
    srv: ServerThread = make_server()
    sock = socket.create_connection(("127.0.0.1", srv.ports["develop"]))
    try:
        assert wait_for(lambda: srv.server.reports.frames_sent["develop"] >= 10)
        srv.call(srv.server.reports.quiesce)
        time.sleep(0.05)  # a frame already prepared may still go out
        before = srv.server.reports.frames_sent["develop"]
        time.sleep(0.3)  # 30 deadlines of the 100 Hz develop report
        assert srv.server.reports.frames_sent["develop"] == before
    finally:
        sock.close()


class _FrameCursor:
    """Whole develop frames read from a report socket, each with the stream offset it starts at."""

    def __init__(self, sock: socket.socket) -> None:
        self.sock, self.buf, self.base = sock, bytearray(), 0

    def received(self) -> int:
        """Take every byte already arrived; returns the stream offset after them."""
        self.sock.setblocking(False)
        try:
            while True:
                chunk = self.sock.recv(65536)
                if not chunk:
                    break
                self.buf += chunk
        except BlockingIOError:
            pass
        finally:
            self.sock.settimeout(2)
        return self.base + len(self.buf)

    def first_frame_from(self, offset: int) -> bytes:
        """The first whole frame that starts at or after stream ``offset`` (waits for it)."""
        while True:
            while len(self.buf) >= 4:
                (size,) = struct.unpack_from(">I", self.buf)
                if len(self.buf) < size:
                    break
                frame = bytes(self.buf[:size])
                start = self.base
                del self.buf[:size]
                self.base += size
                if start >= offset:
                    return frame
            chunk = self.sock.recv(65536)
            assert chunk, "the report connection closed"
            self.buf += chunk


def test_no_frame_after_a_reply_shows_the_state_from_before_its_command(make_server) -> None:  # type: ignore[no-untyped-def]
    """A command answered between two frames is never undone by the next one: a client that reads
    set_state's reply and then the report sees the new state (the sender makes and writes each
    frame under the arm's lock, which the command also takes)."""
    srv: ServerThread = make_server()
    srv.call(lambda: emu_ready(srv.emulator))
    with connect(srv.ports["command"]) as cmd, \
            socket.create_connection(("127.0.0.1", srv.ports["develop"]), timeout=2) as dev:
        frames = _FrameCursor(dev)
        frames.first_frame_from(0)
        for tid in range(1, 41):
            time.sleep((tid * 0.37) % 1.0 * INTERVAL)  # the commands fall anywhere between frames
            cmd.sendall(encode_request(tid, 12, bytes([4 if tid % 2 else 0])))  # set_state
            assert recv_frame(cmd)[6] == 12
            cmd.sendall(encode_request(tid, 13))  # get_state
            state = recv_frame(cmd)[8]
            assert state == 4 if tid % 2 else state in (0, 1, 2)
            got = frames.first_frame_from(frames.received())
            assert got[4] & 0x0F == state, (tid, got[4] & 0x0F, state)


def test_frames_are_made_by_the_sender_not_by_the_event_loop(make_server) -> None:  # type: ignore[no-untyped-def]
    """No report frame is encoded on the event loop: a loop that was held has no frames to work
    through when it is free (a saturated fleet worker once fell seconds behind that way)."""
    srv: ServerThread = make_server()
    emu = srv.emulator
    threads: list[int] = []
    snapshot = emu.snapshot

    def recorded():  # type: ignore[no-untyped-def]
        threads.append(threading.get_ident())
        return snapshot()

    _slow_move(srv)
    srv.call(lambda: setattr(emu, "snapshot", recorded))
    loop_thread = srv.call(threading.get_ident)
    with socket.create_connection(("127.0.0.1", srv.ports["develop"]), timeout=2) as dev:
        _hold_loop(srv, 0.2).join()
        got = _arrivals(dev, 0.3)
    assert len(got) >= 25
    assert len(threads) >= 25 and loop_thread not in threads


def test_an_arm_at_rest_is_encoded_once_and_a_change_shows_in_the_next_frames(make_server) -> None:  # type: ignore[no-untyped-def]
    """While nothing changes but the clock, the develop frame is encoded once and sent again at
    every deadline; a command that changes the box (a TCP offset, register 35) shows in the frames
    that follow its reply."""
    srv: ServerThread = make_server()
    emu = srv.emulator
    calls = [0]
    snapshot = emu.snapshot

    def counted():  # type: ignore[no-untyped-def]
        calls[0] += 1
        return snapshot()

    srv.call(lambda: setattr(emu, "snapshot", counted))
    with connect(srv.ports["command"]) as cmd, \
            socket.create_connection(("127.0.0.1", srv.ports["develop"]), timeout=2) as dev:
        frames = _FrameCursor(dev)
        first = frames.first_frame_from(0)
        before = calls[0]
        seen = [frames.first_frame_from(frames.received() + 1) for _ in range(30)]  # 30 later frames
        assert all(f == first for f in seen)
        assert calls[0] - before <= 3  # the thermal model's step (once a second) may change it
        offset = struct.pack("<6f", 0.0, 0.0, 55.0, 0.0, 0.0, 0.0)
        cmd.sendall(encode_request(1, 35, offset))
        assert recv_frame(cmd)[6] == 35
        got = frames.first_frame_from(frames.received())
    z_before, z_after = reports.decode_develop(first).pose[2], reports.decode_develop(got).pose[2]
    assert z_after == pytest.approx(z_before - 55.0, abs=1e-3)  # the TCP 55 mm below the flange


def test_an_arm_at_rest_needs_no_loop_for_its_frames_and_a_change_still_shows(make_server) -> None:  # type: ignore[no-untyped-def]
    """A loop held for 400 ms delays no frame of an arm at rest; a change made through the loop
    (an injected error) shows in the next frames as state 4 (develop report byte 4, manual 2.1.6)."""
    srv: ServerThread = make_server()
    emu = srv.emulator
    srv.call(lambda: emu_ready(emu))
    with socket.create_connection(("127.0.0.1", srv.ports["develop"]), timeout=2) as dev:
        frames = _FrameCursor(dev)
        frames.first_frame_from(0)
        time.sleep(0.2)
        sent0 = srv.server.reports.frames_sent["develop"]
        _hold_loop(srv, 0.4).join()  # the loop held: frames go on, from the sender alone
        assert srv.server.reports.frames_sent["develop"] - sent0 >= 30
        assert frames.first_frame_from(frames.received())[4] & 0x0F == 2  # ready, at rest
        srv.call(lambda: emu.inject_error(22))
        got = frames.first_frame_from(frames.received())
    assert got[4] & 0x0F == 4


def test_a_library_user_s_process_keeps_its_interpreter_settings() -> None:
    """Importing the package, making an ``Emulator`` and serving it with a report reader (as a
    user's test suite that embeds the emulator does) changes no interpreter-wide setting: the
    switch interval, the garbage collector's frozen objects and the sender's scheduling stay as they
    were; only ``tune_process`` (which ``serve`` calls) changes them. The baseline is the same
    process's own before the import: an interpreter may start with objects frozen (3.12 has 375)."""
    code = """
import gc, os, socket, sys, time
before, frozen = sys.getswitchinterval(), gc.get_freeze_count()
from xarm_emu.controller.emulator import Emulator
from xarm_emu.server.app import ServerConfig, ServerThread
from xarm_emu.server import report_sender
st = ServerThread(Emulator(6), ServerConfig(port=0, normal_port=0, rich_port=0, develop_port=0)).start()
with socket.create_connection(("127.0.0.1", st.ports["develop"])) as s:
    s.recv(87)
    (t,) = [t for t in __import__("threading").enumerate() if t.name == "xarm-emu-reports"]
    policy = os.sched_getscheduler(t.native_id) if hasattr(os, "sched_getscheduler") else 0
    print(sys.getswitchinterval() == before, gc.get_freeze_count() - frozen, policy)
st.stop()
report_sender.tune_process()
print(sys.getswitchinterval() < before, gc.get_freeze_count() > frozen)
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    first, second = out.stdout.split("\n")[:2]
    assert first == f"True 0 {getattr(os, 'SCHED_OTHER', 0)}", first
    assert second == "True True", second
