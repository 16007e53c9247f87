"""Bytes on the command port (manual 2.1.2, and the SDK's reading of it): replies echo the
transaction and protocol ids, heartbeats get no reply, an unsupported standard Modbus function gets
"illegal function", each reply is one write on a TCP_NODELAY socket, and bad input closes only the
offending connection."""

from __future__ import annotations

import os
import socket
import struct
import time

import pytest
from helpers import connect, recv_frame
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from xarm_emu.protocol.frame import FrameDecoder, Reply, encode_request
from xarm_emu.protocol.registers import REGISTERS
from xarm_emu.server.app import ServerThread


def reply(s: socket.socket) -> Reply:
    frames = FrameDecoder(replies=True).feed(recv_frame(s))
    assert len(frames) == 1
    return frames[0]  # type: ignore[return-value]


def get_state(s: socket.socket, tid: int = 7) -> Reply:
    s.sendall(encode_request(tid, 13))
    r = reply(s)
    assert (r.tid, r.register) == (tid, 13)
    return r


def assert_closed(s: socket.socket, timeout: float = 2.0) -> None:
    s.settimeout(timeout)
    try:
        while s.recv(4096):
            pass
    except ConnectionResetError:
        pass


@pytest.fixture(params=["asyncio", "uvloop"])
def srv(make_server, request: pytest.FixtureRequest) -> ServerThread:
    """The server on the standard event loop and on uvloop (what `xarm-emu serve` uses)."""
    if request.param == "uvloop":
        pytest.importorskip("uvloop")
    return make_server(use_uvloop=request.param == "uvloop")


@pytest.mark.parametrize("protocol", [2, 3])
@pytest.mark.parametrize("tid", [1, 0x1234, 0xFFFF])
def test_reply_echoes_tid_and_protocol(srv: ServerThread, protocol: int, tid: int) -> None:
    with connect(srv.ports["command"]) as s:
        s.sendall(encode_request(tid, 13, b"", protocol))
        raw = recv_frame(s)
    # tid, protocol, length = 2 + 1 (register, state, u8 state value: manual 2.1.3 register 13)
    assert raw[:6] == struct.pack(">HHH", tid, protocol, 3)
    assert raw[6] == 13
    assert raw[8] == 4  # power-on state: stop


def test_heartbeat_protocol_1_gets_no_reply(srv: ServerThread) -> None:
    with connect(srv.ports["command"]) as s:
        s.sendall(bytes.fromhex("0000000100020000"))  # the SDK's heartbeat frame (note 1.1)
        s.sendall(encode_request(9, 13))
        raw = recv_frame(s)
        assert struct.unpack(">H", raw[:2])[0] == 9  # the first bytes back answer the GET_STATE
        s.settimeout(0.1)
        with pytest.raises(TimeoutError):
            s.recv(1)


def test_standard_modbus_gets_illegal_function(srv: ServerThread) -> None:
    with connect(srv.ports["command"]) as s:
        # Modbus TCP diagnostics (function 0x08, not in the box's map): unit 1, sub-function 0, data 2
        s.sendall(struct.pack(">HHHBBHH", 0x0102, 0, 6, 1, 0x08, 0, 2))
        raw = recv_frame(s)
    assert raw == struct.pack(">HHHBBB", 0x0102, 0, 3, 1, 0x88, 0x01)


def test_accepted_socket_has_nodelay_and_reply_is_one_segment(srv: ServerThread) -> None:
    with connect(srv.ports["command"]) as s:
        local = s.getsockname()

        def nodelay_of_accepted() -> int:
            for c in srv.server.command_clients:
                sock = c.transport.get_extra_info("socket")
                if sock.getpeername() == local:
                    return sock.getsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY)
            return -1

        get_state(s)
        assert srv.call(nodelay_of_accepted) != 0
        # 41 (GET_POSITION): 6 + 2 + 24 bytes. A single write arrives whole in one recv.
        for tid in range(1, 51):
            s.sendall(encode_request(tid, 41))
            data = s.recv(4096)
            assert len(data) == 32, "reply split over several segments"
            assert data[:2] == struct.pack(">H", tid)


def test_several_requests_in_one_segment_get_all_replies(srv: ServerThread) -> None:
    with connect(srv.ports["command"]) as s:
        s.sendall(b"".join(encode_request(t, 13) for t in (1, 2, 3)) + encode_request(4, 41)[:5])
        assert [reply(s).tid for _ in range(3)] == [1, 2, 3]
        s.sendall(encode_request(4, 41)[5:])
        r = reply(s)
        assert (r.tid, r.register, len(r.params)) == (4, 41, 24)


def test_requests_before_a_half_close_are_all_answered_then_the_connection_closes(srv: ServerThread) -> None:
    """A client that sends its requests and then closes its sending side (shutdown(SHUT_WR)) gets
    every reply, in order, before the server closes: the bytes before the end of the stream are
    read and answered as a box reading its socket to the end does, however many turns they take."""
    frames = [encode_request(t & 0xFFFF, 13, b"", 2 + t % 2) for t in range(3000)]
    frames.append(encode_request(3000, 41)[:5])  # a cut frame at the end: dropped with the close
    with connect(srv.ports["command"]) as s:
        s.sendall(b"".join(frames))
        s.shutdown(socket.SHUT_WR)
        got = bytearray()
        s.settimeout(10.0)
        while chunk := s.recv(65536):
            got += chunk
    replies = FrameDecoder(replies=True).feed(bytes(got))
    assert [(r.tid, r.register, r.params) for r in replies] == [(t, 13, b"\x04") for t in range(3000)]


def test_unknown_register_sets_warning_13(srv: ServerThread) -> None:
    assert 200 not in REGISTERS
    with connect(srv.ports["command"]) as s:
        s.sendall(encode_request(5, 200, b"\x01\x02"))
        r = reply(s)
        assert (r.tid, r.register) == (5, 200)
        assert r.state & 0x20
        s.sendall(encode_request(6, 15))  # GET_ERROR: error byte, warning byte
        r = reply(s)
        assert r.state & 0x20 and not r.state & 0x40
        assert r.params[:2] == bytes((0, 13))


@pytest.mark.parametrize("register,params", [(12, b""), (12, b"\x00\x00"), (19, b""), (41, b"\x00")])
def test_wrong_parameter_length_sets_warning_12(srv: ServerThread, register: int, params: bytes) -> None:
    assert not REGISTERS[register].request.accepts(len(params))
    with connect(srv.ports["command"]) as s:
        s.sendall(encode_request(5, register, params))
        r = reply(s)
        assert r.register == register
        assert r.state & 0x20
        s.sendall(encode_request(6, 15))
        assert reply(s).params[:2] == bytes((0, 12))
        s.sendall(encode_request(7, 17))  # CLEAN_WAR
        reply(s)
        s.sendall(encode_request(8, 15))
        r = reply(s)
        assert r.params[:2] == bytes((0, 0)) and not r.state & 0x20


@pytest.mark.parametrize("garbage", [
    struct.pack(">HHH", 1, 2, 0xFFFF) + b"\x0d",  # absurd length
    struct.pack(">HHH", 1, 2, 0),  # length 0
    struct.pack(">HHH", 1, 9, 2) + b"\x0d\x00",  # unknown protocol id
])
def test_bad_frame_closes_only_that_connection(srv: ServerThread, garbage: bytes) -> None:
    with connect(srv.ports["command"]) as good, connect(srv.ports["command"]) as bad:
        assert get_state(good, 1).params == b"\x04"
        bad.sendall(garbage)
        assert_closed(bad)
        assert get_state(good, 2).params == b"\x04"
    with connect(srv.ports["command"]) as again:
        assert get_state(again, 3).params == b"\x04"


def test_truncated_frame_then_disconnect_leaves_server_up(srv: ServerThread) -> None:
    with connect(srv.ports["command"]) as good:
        for cut in range(1, 8):
            with connect(srv.ports["command"]) as bad:
                bad.sendall(encode_request(1, 41)[:cut])
            assert get_state(good, cut).params == b"\x04"
        # a truncated frame is completed by the next bytes on the same connection
        with connect(srv.ports["command"]) as slow:
            frame = encode_request(11, 13)
            for b in frame:
                slow.sendall(bytes((b,)))
                time.sleep(0.002)
            assert reply(slow).tid == 11


def test_random_bytes_while_a_second_client_keeps_working(srv: ServerThread) -> None:
    rng = os.urandom
    with connect(srv.ports["command"]) as good:
        for i in range(20):
            with connect(srv.ports["command"]) as bad:
                bad.sendall(rng(64 + 16 * i))
                bad.settimeout(0.2)
                try:
                    bad.recv(65536)
                except (TimeoutError, ConnectionResetError):
                    pass
            r = get_state(good, 100 + i)
            # random bytes may carry a valid frame that sets a warning; never an error
            assert not r.state & 0x40
        srv.call(lambda: srv.emulator.controller.state)  # the loop thread answers


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(chunks=st.lists(st.binary(min_size=0, max_size=80), min_size=1, max_size=6),
       register=st.integers(0, 255), params=st.binary(max_size=40))
def test_fuzz_server_stays_up(srv: ServerThread, chunks: list[bytes], register: int, params: bytes) -> None:
    """Arbitrary bytes and arbitrary well-framed requests: replies stay well-formed, the server up."""
    port = srv.ports["command"]
    with connect(port) as s:
        s.sendall(encode_request(0x4242, register, params))
        r = reply(s)
        assert (r.tid, r.protocol, r.register) == (0x4242, 2, register)
        for c in chunks:
            try:
                s.sendall(c)
            except (BrokenPipeError, ConnectionResetError):
                break  # the server closed this connection on an unframeable stream
    with connect(port) as probe:
        r = get_state(probe, 0x77)
        assert r.params and r.params[0] in range(0, 10)
    srv.call(lambda: srv.emulator.clear_faults())
