"""The command port of a firmware 2.x box, bytes on the wire: protocol ids 2 and 3 echoed, the
heartbeat ignored, registers 253/254 and the unsolicited 21-byte 0xFF feedback frames."""

from __future__ import annotations

import socket
import struct
import time
from collections.abc import Iterator

import pytest

from xarm_emu.protocol.feedback import FeedbackCode, FeedbackType, decode_feedback, is_feedback
from xarm_emu.protocol.frame import HEADER, STATE_WARNING, encode_request
from xarm_emu.server.command_port import CommandProtocol
from xarm_emu.server.thread import ServerThread
from xarm_emu.testing import running_emulator

FW2 = "2.7.103"


class Raw:
    """A raw command-port connection: requests out, frames (replies and feedback) in, in order."""

    def __init__(self, port: int) -> None:
        self.sock = socket.create_connection(("127.0.0.1", port), timeout=5.0)
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.buf = b""

    def send(self, tid: int, register: int, params: bytes = b"", protocol: int = 2) -> None:
        self.sock.sendall(encode_request(tid, register, params, protocol))

    def frame(self, timeout: float = 5.0) -> bytes:
        self.sock.settimeout(timeout)
        while True:
            if len(self.buf) >= 6:
                n = 6 + HEADER.unpack_from(self.buf)[2]
                if len(self.buf) >= n:
                    out, self.buf = self.buf[:n], self.buf[n:]
                    return out
            chunk = self.sock.recv(65536)
            if not chunk:
                raise ConnectionError("closed")
            self.buf += chunk

    def ask(self, tid: int, register: int, params: bytes = b"", protocol: int = 2) -> bytes:
        """Send one request and return its reply; feedback frames read meanwhile are kept."""
        self.send(tid, register, params, protocol)
        while True:
            f = self.frame()
            if is_feedback(f):
                self.feedback.append(f)
                continue
            return f

    def frames_for(self, seconds: float) -> list[bytes]:
        """Every frame arriving within ``seconds``, the feedback kept earlier included."""
        out, self.feedback = list(self.feedback), []
        end = time.monotonic() + seconds
        while (left := end - time.monotonic()) > 0:
            try:
                out.append(self.frame(left))
            except TimeoutError:
                break
        return out

    feedback: list[bytes]

    def close(self) -> None:
        self.sock.close()


def _raw(port: int) -> Raw:
    r = Raw(port)
    r.feedback = []
    return r


@pytest.fixture
def fw2() -> Iterator[ServerThread]:
    with running_emulator(firmware=FW2) as st:
        yield st


def _ready(c: Raw) -> None:
    """Enable, position mode, state 0 (manual 2.1.3 registers 11, 19, 12)."""
    c.ask(1, 11, bytes([8, 1]))
    c.ask(2, 19, bytes([0, 0]))
    c.ask(3, 12, bytes([0]))


def _joint_move(j1: float, speed: float = 1.0) -> bytes:
    """Register 23 in its 2.x form: 7 joints, speed, acc, mvtime, only-check 0."""
    return struct.pack("<10f", j1, 0, 0, 0, 0, 0, 0, speed, 20.0, 0.0) + b"\x00"


def test_protocol_ids_2_and_3_are_echoed_and_the_heartbeat_is_ignored(fw2: ServerThread) -> None:
    c = _raw(fw2.ports["command"])
    try:
        r3 = c.ask(7, 13, protocol=3)
        c.send(8, 0, b"\x00", protocol=1)  # heartbeat: never answered
        r2 = c.ask(9, 13, protocol=2)
        r3b = c.ask(10, 13, protocol=3)
    finally:
        c.close()
    assert HEADER.unpack_from(r3) == (7, 3, 3)
    assert HEADER.unpack_from(r2)[:2] == (9, 2)
    assert HEADER.unpack_from(r3b)[:2] == (10, 3)
    assert r3[6] == 13 and r3[8] == r2[8]


def test_254_and_253_answer_empty_and_253_finishes_at_once_on_an_empty_queue(fw2: ServerThread) -> None:
    c = _raw(fw2.ports["command"])
    try:
        r254 = c.ask(20, 254, b"\x02", protocol=3)
        r253 = c.ask(21, 253, protocol=3)
        frames = c.frames_for(0.3)
    finally:
        c.close()
    assert r254[6:7] == b"\xfe" and len(r254) == 8 and not r254[7] & STATE_WARNING
    assert r253[6:7] == b"\xfd" and len(r253) == 8 and not r253[7] & STATE_WARNING
    fbs = [decode_feedback(f) for f in frames if is_feedback(f)]
    assert [(f.tid, f.protocol, f.kind, f.register, f.code) for f in fbs] == [
        (21, 3, FeedbackType.MOTION_FINISH, 253, FeedbackCode.SUCCESS)]


def test_motion_start_and_finish_carry_the_move_tid_and_controller_microseconds(fw2: ServerThread) -> None:
    c = _raw(fw2.ports["command"])
    try:
        _ready(c)
        c.ask(30, 254, bytes([FeedbackType.MOTION_START | FeedbackType.MOTION_FINISH]))
        t_before = fw2.emulator.time
        reply = c.ask(31, 23, _joint_move(0.3))
        frames = [f for f in c.frames_for(2.0) if is_feedback(f)]
    finally:
        c.close()
    assert reply[6] == 23 and len(reply) == 11  # cmdnum u16 and the 2.x check-result byte
    start, finish = (decode_feedback(f) for f in frames)
    assert (start.tid, start.kind, start.register) == (31, FeedbackType.MOTION_START, 23)
    assert (finish.tid, finish.kind, finish.register, finish.code) == (
        31, FeedbackType.MOTION_FINISH, 23, FeedbackCode.SUCCESS)
    assert start.task_id == finish.task_id
    assert t_before * 1e6 <= start.time_us < finish.time_us <= fw2.emulator.time * 1e6
    # 0.3 rad at 1 rad/s with 20 rad/s^2: at least the cruise time
    assert finish.time_us - start.time_us >= 0.3e6
    assert len(frames[0]) == 21 and frames[0][4:6] == b"\x00\x0f" and frames[0][6] == 0xFF


def test_the_mask_taken_is_the_one_current_when_the_task_arrived(fw2: ServerThread) -> None:
    """The SDK sets 254 [02], sends the move, restores 254 [00]: the move still reports its finish,
    and a move queued after the restore reports nothing."""
    c = _raw(fw2.ports["command"])
    try:
        _ready(c)
        c.ask(40, 254, b"\x02")
        c.ask(41, 23, _joint_move(0.2))
        c.ask(42, 254, b"\x00")
        c.ask(43, 23, _joint_move(0.0))
        frames = [decode_feedback(f) for f in c.frames_for(1.5) if is_feedback(f)]
    finally:
        c.close()
    assert [(f.tid, f.kind) for f in frames] == [(41, FeedbackType.MOTION_FINISH)]


def test_two_connections_with_different_masks_each_get_only_their_own_frames(fw2: ServerThread) -> None:
    a = _raw(fw2.ports["command"])
    b = _raw(fw2.ports["command"])
    watcher = _raw(fw2.ports["command"])
    try:
        _ready(a)
        a.ask(50, 254, bytes([FeedbackType.MOTION_START]))
        b.ask(60, 254, bytes([FeedbackType.MOTION_FINISH]))
        watcher.ask(70, 254, bytes([0xFF]))  # asks for everything, sends no move
        a.ask(51, 23, _joint_move(0.2))
        b.ask(61, 23, _joint_move(0.0))
        fa = [decode_feedback(f) for f in a.frames_for(1.5) if is_feedback(f)]
        fb = [decode_feedback(f) for f in b.frames_for(0.1) if is_feedback(f)]
        fw = [f for f in watcher.frames_for(0.1) if is_feedback(f)]
    finally:
        a.close()
        b.close()
        watcher.close()
    assert [(f.tid, f.kind) for f in fa] == [(51, FeedbackType.MOTION_START)]
    assert [(f.tid, f.kind) for f in fb] == [(61, FeedbackType.MOTION_FINISH)]
    assert fw == []


def test_253_finishes_once_every_earlier_move_has_finished(fw2: ServerThread) -> None:
    c = _raw(fw2.ports["command"])
    try:
        _ready(c)
        c.ask(80, 254, b"\x02")
        c.ask(81, 23, _joint_move(0.3))
        c.ask(82, 23, _joint_move(0.0))
        c.ask(83, 253)
        frames = [decode_feedback(f) for f in c.frames_for(2.5) if is_feedback(f)]
    finally:
        c.close()
    assert [(f.tid, f.register) for f in frames] == [(81, 23), (82, 23), (83, 253)]
    assert frames[2].time_us >= frames[1].time_us


def test_moves_discarded_by_a_stop_finish_with_code_2(fw2: ServerThread) -> None:
    c = _raw(fw2.ports["command"])
    try:
        _ready(c)
        c.ask(90, 254, b"\x02")
        c.ask(91, 23, _joint_move(0.5))
        c.ask(92, 23, _joint_move(0.0))
        time.sleep(0.1)
        c.ask(93, 12, bytes([4]))  # stop: the buffer is discarded
        frames = [decode_feedback(f) for f in c.frames_for(1.5) if is_feedback(f)]
    finally:
        c.close()
    codes = {f.tid: f.code for f in frames}
    assert codes[92] == FeedbackCode.DISCARDED
    assert 91 in codes


def test_register_36_is_triggered_when_the_mask_asks_for_trigger(fw2: ServerThread) -> None:
    c = _raw(fw2.ports["command"])
    try:
        c.ask(100, 254, bytes([FeedbackType.TRIGGER]))
        c.ask(101, 36, struct.pack("<4f", 0.5, 0.0, 0.0, 30.0))
        frames = [decode_feedback(f) for f in c.frames_for(0.3) if is_feedback(f)]
    finally:
        c.close()
    assert [(f.tid, f.kind, f.register) for f in frames] == [(101, FeedbackType.TRIGGER, 36)]


def test_a_closed_connection_takes_its_mask_and_pending_reports_along(fw2: ServerThread) -> None:
    a = _raw(fw2.ports["command"])
    _ready(a)
    a.ask(110, 254, b"\x02")
    a.ask(111, 23, _joint_move(0.4))
    a.close()
    time.sleep(0.3)
    fq = fw2.server.feedback
    assert fq is not None
    assert fw2.call(lambda: (fq.masks, fq.pending)) == ({}, 0)


def test_firmware_1_6_0_answers_253_and_254_with_warning_13_and_sends_no_frames() -> None:
    with running_emulator() as st:
        c = _raw(st.ports["command"])
        try:
            r = c.ask(1, 254, b"\x02")
            frames = c.frames_for(0.2)
        finally:
            c.close()
        assert st.server.feedback is None
    assert r[7] & STATE_WARNING and frames == []


class _StuckTransport:
    """A transport whose peer does not read: its write buffer is full."""

    def __init__(self) -> None:
        self.written: list[bytes] = []

    def is_closing(self) -> bool:
        return False

    def get_write_buffer_size(self) -> int:
        return 1 << 20

    def write(self, data: bytes) -> None:
        self.written.append(data)


def test_feedback_to_a_reader_that_does_not_keep_up_is_dropped_and_counted(fw2: ServerThread) -> None:
    proto = CommandProtocol(fw2.server)
    stuck = _StuckTransport()
    proto.transport = stuck  # type: ignore[assignment]
    assert proto.send_feedback(b"\x00" * 21) is False
    assert stuck.written == [] and proto.feedback_dropped == 1


def test_a_client_that_never_reads_does_not_slow_the_others(fw2: ServerThread) -> None:
    """One connection sets a mask and floods requests without reading a byte; another connection's
    move still reports its finish in time, and the flood's frames are dropped, not queued."""
    flood = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    flood.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)  # before connecting: a small window
    flood.connect(("127.0.0.1", fw2.ports["command"]))
    good = _raw(fw2.ports["command"])
    try:
        # a move of its own, then replies it never reads (register 2, 48 bytes each) fill the socket:
        # the move's feedback frames find it full (the server also stops reading the flood)
        _ready(good)
        flood.sendall(encode_request(1, 254, bytes([0xFF])) + encode_request(2, 23, _joint_move(-0.1))
                      + encode_request(3, 2) * 120000)
        good.ask(120, 254, b"\x02")
        t0 = time.monotonic()
        good.ask(121, 23, _joint_move(0.1))
        frames = [decode_feedback(f) for f in good.frames_for(1.5) if is_feedback(f)]
        elapsed = time.monotonic() - t0
    finally:
        flood.close()
        good.close()
    assert [(f.tid, f.kind) for f in frames] == [(121, FeedbackType.MOTION_FINISH)]
    assert elapsed < 3.0
    assert fw2.server.feedback_dropped > 0


def test_feedback_events_fall_on_the_control_periods_of_the_move() -> None:
    """In process: the start is stamped with the first control period of the move, the finish with
    the period it reaches its target, both in microseconds of controller time."""
    from xarm_emu.controller.core.feedback import feedback_queue
    from xarm_emu.controller.emulator import Emulator

    emu = Emulator(6, firmware=FW2)
    ctl = emu.controller
    for code, params in ((11, bytes([8, 1])), (19, bytes([0, 0])), (12, b"\x00")):
        emu.handle(code, params)
    fq = feedback_queue(ctl)
    fq.begin(ctl, 7, 1, 3, 254)
    emu.handle(254, b"\x03")
    fq.end(ctl)
    emu.advance(0.1)
    t_queued = ctl.time
    fq.begin(ctl, 7, 2, 3, 23)
    emu.handle(23, _joint_move(0.2))
    fq.end(ctl)
    assert fq.drain() == []
    finish_step = None
    for _ in range(1000):
        emu.step()
        if ctl.executor.current is None and finish_step is None:
            finish_step = ctl.time
            break
    events = fq.drain()
    assert [(e.client, e.feedback.tid, e.feedback.kind) for e in events] == [
        (7, 2, FeedbackType.MOTION_START), (7, 2, FeedbackType.MOTION_FINISH)]
    assert events[0].feedback.time_us == round((t_queued + ctl.period) * 1e6)
    assert finish_step is not None and events[1].feedback.time_us == round(finish_step * 1e6)
    assert float(ctl.q[0]) == pytest.approx(0.2, abs=1e-6)
    fq.begin(ctl, 7, 3, 3, 63)
    origin = fq.capture()
    fq.end(ctl)
    assert fq.finish_other(origin, 63, ctl.time, ok=False) is False  # the mask lacks OTHER_FINISH
    fq.begin(ctl, 7, 4, 3, 254)
    emu.handle(254, bytes([FeedbackType.OTHER_FINISH]))
    fq.end(ctl)
    fq.begin(ctl, 7, 5, 3, 64)
    origin = fq.capture()
    fq.end(ctl)
    assert fq.finish_other(origin, 64, ctl.time, ok=False) is True
    (ev,) = fq.drain()
    assert (ev.feedback.tid, ev.feedback.kind, ev.feedback.register, ev.feedback.code) == (
        5, FeedbackType.OTHER_FINISH, 64, FeedbackCode.FAILURE)
