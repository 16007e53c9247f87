"""Frame codec of the manual's section 2.1.2: stream reassembly, bad lengths, replies, fuzz."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from xarm_emu.protocol import frame
from xarm_emu.protocol.frame import FrameDecoder, FrameError, Reply, Request

ENABLE = bytes.fromhex("0001 0002 0003 0B 08 01")  # manual 2.1.2 request example
ENABLE_REPLY = bytes.fromhex("0001 0002 0002 0B 00")  # and its reply
GET_POSE = bytes.fromhex("0007 0003 0001 29")


def test_manual_request_example() -> None:
    (req,) = FrameDecoder().feed(ENABLE)
    assert req == Request(tid=1, protocol=2, register=0x0B, params=b"\x08\x01")
    assert req.encode() == ENABLE
    assert frame.encode_request(1, 0x0B, b"\x08\x01") == ENABLE


def test_manual_reply_example() -> None:
    (rep,) = FrameDecoder(replies=True).feed(ENABLE_REPLY)
    assert rep == Reply(tid=1, protocol=2, register=0x0B, state=0, params=b"")
    assert rep.encode() == ENABLE_REPLY
    assert frame.encode_reply(1, 2, 0x0B, 0) == ENABLE_REPLY


@pytest.mark.parametrize("cut", range(1, len(ENABLE)))
def test_split_at_every_byte(cut: int) -> None:
    dec = FrameDecoder()
    assert dec.feed(ENABLE[:cut]) == []
    assert dec.pending == cut
    (req,) = dec.feed(ENABLE[cut:])
    assert req.register == 0x0B and req.params == b"\x08\x01" and dec.pending == 0


def test_byte_by_byte_stream_of_several_frames() -> None:
    stream = ENABLE + GET_POSE + ENABLE
    dec = FrameDecoder()
    got: list = []
    for i in range(len(stream)):
        got.extend(dec.feed(stream[i : i + 1]))
    assert [(r.tid, r.protocol, r.register) for r in got] == [(1, 2, 0x0B), (7, 3, 0x29), (1, 2, 0x0B)]


def test_several_frames_in_one_read_and_a_partial_tail() -> None:
    dec = FrameDecoder()
    frames = dec.feed(ENABLE + GET_POSE + ENABLE[:4])
    assert [f.register for f in frames] == [0x0B, 0x29]
    assert dec.pending == 4
    (last,) = dec.feed(ENABLE[4:])
    assert last.params == b"\x08\x01"


def test_replies_split_and_joined() -> None:
    pose = frame.encode_reply(9, 3, 0x29, 0x10, bytes(range(24)))
    dec = FrameDecoder(replies=True)
    out = dec.feed(pose[:10]) + dec.feed(pose[10:] + ENABLE_REPLY)
    got = [(r.tid, r.register, r.state, len(r.params)) for r in out]
    assert got == [(9, 0x29, 0x10, 24), (1, 0x0B, 0, 0)]
    assert out[0].not_ready and not out[0].has_error and not out[0].has_warning


@pytest.mark.parametrize("length", [0, frame.MAX_LENGTH + 1, 0xFFFF])
def test_bad_request_lengths_raise(length: int) -> None:
    with pytest.raises(FrameError):
        FrameDecoder().feed(frame.HEADER.pack(1, 2, length) + b"\x0b")


def test_reply_length_must_cover_register_and_state() -> None:
    # A reply of length 1 (register only, as printed for register 127's baud-rate example) is no reply.
    with pytest.raises(FrameError):
        FrameDecoder(replies=True).feed(bytes.fromhex("0001 0002 0001 7F"))


def test_largest_length_is_accepted() -> None:
    raw = frame.encode_request(1, 124, bytes(frame.MAX_LENGTH - 1))
    (req,) = FrameDecoder().feed(raw)
    assert len(req.params) == frame.MAX_LENGTH - 1


def test_bad_length_is_detected_from_the_header_alone() -> None:
    dec = FrameDecoder()
    assert dec.feed(b"\x00\x01\x00") == []
    with pytest.raises(FrameError):
        dec.feed(b"\x02\x00\x00")


def test_reply_encoding_and_state_bits() -> None:
    raw = frame.encode_reply(0x1234, 3, 0x0D, frame.STATE_ERROR | frame.STATE_WARNING, b"\x04")
    assert raw == bytes.fromhex("1234 0003 0003 0D 60 04")
    rep = frame.decode_reply(raw)
    assert rep.has_error and rep.has_warning and not rep.not_ready
    # tid wraps at 16 bits, register and state are single bytes
    assert frame.encode_reply(0x10001, 2, 0x10B, 0x110)[:8] == bytes.fromhex("0001 0002 0002 0B 10")


def test_modbus_exception_reply() -> None:
    raw = frame.encode_modbus_exception(5, 1, 0x03)
    assert raw == bytes.fromhex("0005 0000 0003 01 83 01")


def test_decode_one_frame_helpers_refuse_zero_or_two() -> None:
    with pytest.raises(FrameError):
        frame.decode_request(ENABLE[:-1])
    with pytest.raises(FrameError):
        frame.decode_request(ENABLE + ENABLE)
    with pytest.raises(FrameError):
        frame.decode_reply(ENABLE_REPLY + ENABLE_REPLY)


@settings(max_examples=300, deadline=None)
@given(st.lists(st.binary(max_size=64), max_size=8), st.booleans())
def test_fuzz_random_bytes_only_raise_frame_error(chunks: list[bytes], replies: bool) -> None:
    dec = FrameDecoder(replies=replies)
    try:
        for chunk in chunks:
            for f in dec.feed(chunk):
                assert isinstance(f, Reply if replies else Request)
    except FrameError:
        pass


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 0xFFFF), st.sampled_from([0, 2, 3]), st.integers(0, 255),
                          st.binary(max_size=40)), min_size=1, max_size=6),
       st.lists(st.integers(1, 20), max_size=10))
def test_fuzz_reassembly_matches_frames(frames: list[tuple[int, int, int, bytes]], cuts: list[int]) -> None:
    stream = b"".join(frame.encode_request(t, r, p, protocol=pr) for t, pr, r, p in frames)
    dec = FrameDecoder()
    got: list = []
    pos = 0
    for n in cuts:
        got.extend(dec.feed(stream[pos : pos + n]))
        pos += n
    got.extend(dec.feed(stream[pos:]))
    assert [(g.tid, g.protocol, g.register, g.params) for g in got] == frames
    assert dec.pending == 0
