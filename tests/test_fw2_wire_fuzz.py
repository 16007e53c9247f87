"""Bad input to a firmware 2.x box's feedback machinery: random masks, checks, moves, stops and
connections in any order never raise, every event is a well-formed 21-byte 0xFF frame for a request
that was sent, on the connection that sent it; and random frames on the command port (any
register, 0xFF included, protocol ids 2 and 3, heartbeats) leave the connection answering."""

from __future__ import annotations

import os
import socket
import struct

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from xarm_emu.controller.core.feedback import feedback_queue
from xarm_emu.controller.emulator import Emulator
from xarm_emu.protocol.feedback import FEEDBACK_SIZE, FeedbackType, decode_feedback, is_feedback
from xarm_emu.protocol.frame import HEADER, encode_request
from xarm_emu.testing import running_emulator

FW2 = "2.7.103"
SCALE = max(1, int(os.environ.get("XARM_EMU_FUZZ_SCALE", "1")))


def _joint_move(j1: float, speed: float) -> bytes:
    return struct.pack("<10f", j1, 0, 0, 0, 0, 0, 0, speed, 20.0, 0.0) + b"\x00"


_ACTIONS = st.one_of(
    st.tuples(st.just("mask"), st.integers(0, 2), st.binary(min_size=0, max_size=3)),
    st.tuples(st.just("check"), st.integers(0, 2), st.just(b"")),
    st.tuples(st.just("move"), st.integers(0, 2),
              st.sampled_from([_joint_move(0.2, 2.0), _joint_move(0.0, 2.0), _joint_move(-0.1, 3.0),
                               _joint_move(float("nan"), 1.0), _joint_move(0.1, 1.0)[:-1]])),
    st.tuples(st.just("load"), st.integers(0, 2), st.just(struct.pack("<4f", 0.3, 0, 0, 10))),
    st.tuples(st.just("stop"), st.integers(0, 2), st.sampled_from([b"\x04", b"\x03", b"\x00"])),
    st.tuples(st.just("close"), st.integers(0, 2), st.just(b"")),
    st.tuples(st.just("step"), st.integers(0, 2), st.sampled_from([b"\x01", b"\x20", b"\xff"])),
)
_REGISTER = {"mask": 254, "check": 253, "move": 23, "load": 36, "stop": 12}


@settings(max_examples=200 * SCALE, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(actions=st.lists(_ACTIONS, min_size=1, max_size=25))
def test_random_feedback_traffic_gives_only_well_formed_frames_to_their_senders(
        actions: list[tuple[str, int, bytes]]) -> None:
    emu = Emulator(6, firmware=FW2)
    ctl = emu.controller
    ctl.strict = True
    for code, params in ((11, bytes([8, 1])), (19, bytes([0, 0])), (12, b"\x00")):
        emu.handle(code, params)
    fq = feedback_queue(ctl)
    sent: dict[int, set[int]] = {1: set(), 2: set(), 3: set()}
    events = []
    tid = 0
    for kind, who, params in actions:
        client = who + 1
        if kind == "step":
            emu.step(params[0])
        elif kind == "close":
            fq.forget(client)
        else:
            tid += 1
            sent[client].add(tid)
            fq.begin(ctl, client, tid, 3, _REGISTER[kind])
            state, _ = emu.handle(_REGISTER[kind], params)
            fq.end(ctl, state)
            assert 0 <= state <= 0xFF
        events += fq.drain()
    emu.advance(3.0)
    events += fq.drain()
    for ev in events:
        frame = ev.encode()
        assert len(frame) == FEEDBACK_SIZE and is_feedback(frame)
        fb = decode_feedback(frame)
        assert fb.tid in sent[ev.client]
        assert fb.kind in (FeedbackType.MOTION_START, FeedbackType.MOTION_FINISH, FeedbackType.TRIGGER)
        assert 0 <= fb.time_us <= round(ctl.time * 1e6)
    assert ctl.state in (1, 2, 3, 4, 5)


_FRAMES = st.lists(st.tuples(st.integers(0, 0xFFFF), st.sampled_from([1, 2, 3]),
                             st.sampled_from([253, 254, 255, 21, 23, 25, 27, 42, 83, 0xFF, 13]),
                             st.binary(max_size=48)), min_size=1, max_size=10)


@settings(max_examples=25 * SCALE, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(frames=_FRAMES)
def test_random_frames_leave_the_command_connection_answering(
        frames: list[tuple[int, int, int, bytes]]) -> None:
    with running_emulator(firmware=FW2) as srv:
        with socket.create_connection(("127.0.0.1", srv.ports["command"]), timeout=5.0) as s:
            s.sendall(b"".join(encode_request(t, r, p, prot) for t, prot, r, p in frames))
            s.sendall(encode_request(0xBEEF, 13, b"", 3))
            buf = b""
            found = False
            while not found:
                chunk = s.recv(65536)
                assert chunk, "the connection closed"
                buf += chunk
                while len(buf) >= 6 and len(buf) >= 6 + HEADER.unpack_from(buf)[2]:
                    n = 6 + HEADER.unpack_from(buf)[2]
                    frame, buf = buf[:n], buf[n:]
                    tid, prot, _ = HEADER.unpack_from(frame)
                    assert prot in (2, 3)
                    if is_feedback(frame) and len(frame) == FEEDBACK_SIZE:
                        decode_feedback(frame)  # (a reply to a request for register 255 also has 0xFF there)
                    elif tid == 0xBEEF and frame[6] == 13:
                        found = True
                        assert frame[8] in (1, 2, 3, 4, 5)
