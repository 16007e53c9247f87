"""Feedback frames (registers 253/254, firmware >= 2.0.102): the 21-byte unsolicited 0xFF frame
as the SDK routes and reads it, and register 254's mask."""

from __future__ import annotations

import pytest

from xarm_emu.protocol import feedback as F
from xarm_emu.protocol.feedback import Feedback, FeedbackCode, FeedbackMask, FeedbackType
from xarm_emu.protocol.frame import FrameDecoder, FrameError, encode_reply


def test_frame_bytes():
    frame = F.motion_finish(0x1234, 21, task_id=7, time_us=0x0102030405060708, protocol=3).encode()
    assert frame.hex() == "1234" "0003" "000f" "ff" "00" "02" "15" "0007" "00" "0102030405060708"
    assert len(frame) == 21


@pytest.mark.parametrize("fb, kind, code", [
    (F.motion_start(1, 23, 1, 10), 1, 0),
    (F.motion_finish(1, 25, 1, 10, discarded=True), 2, 2),
    (F.trigger(1, 36, 2, 10), 4, 0),
    (F.other_finish(1, 64, 3, 10, ok=False), 64, 1),
    (F.other_finish(1, 63, 3, 10), 64, 0),
])
def test_types_and_codes(fb, kind, code):
    frame = fb.encode()
    assert (frame[8], frame[12]) == (kind, code)
    assert F.decode_feedback(frame) == fb


def test_round_trip_keeps_every_field():
    fb = Feedback(tid=65535, kind=FeedbackType.OTHER_START, register=62, task_id=513,
                  code=FeedbackCode.SUCCESS, time_us=2**64 - 1, protocol=2, state=0x20)
    assert F.decode_feedback(fb.encode()) == fb


def test_sdk_routes_and_reads_the_frame():
    """The SDK's receive loop sends a frame whose byte 6 is 0xFF to its feedback queue and takes the
    tid from bytes 0..1, the type from byte 8 and the code from byte 12."""
    from xarm.core.utils.convert import bytes_to_u16

    frame = F.motion_finish(42, 21, 9, 123, discarded=True).encode()
    assert F.is_feedback(frame) and frame[6] == 0xFF
    assert bytes_to_u16(frame[0:2]) == 42 and frame[8] & 2 and frame[12] == 2


def test_frames_split_by_length_between_replies():
    reply = encode_reply(5, 3, 21, 0, b"\x00\x01\x00")
    fb = F.motion_finish(4, 21, 1, 99).encode()
    frames = FrameDecoder(replies=True).feed(reply + fb + reply)
    assert [f.register for f in frames] == [21, 0xFF, 21]
    assert frames[1].tid == 4 and frames[1].state == 0 and len(frames[1].params) == 13


_GOOD = F.trigger(1, 36, 1, 1).encode()


@pytest.mark.parametrize("bad", [b"", b"\x00" * 20, _GOOD + b"\x00",
                                 _GOOD[:5] + b"\x10" + _GOOD[6:],  # length field 16
                                 _GOOD[:6] + b"\x15" + _GOOD[7:]])  # a reply to register 21, not 0xFF
def test_bad_frames_refused(bad):
    with pytest.raises(FrameError):
        F.decode_feedback(bad)


def test_unknown_code_refused():
    frame = bytearray(F.trigger(1, 36, 1, 1).encode())
    frame[12] = 9
    with pytest.raises(FrameError, match="code"):
        F.decode_feedback(bytes(frame))


def test_mask():
    m = FeedbackMask.decode(b"\x0e")
    assert m.wants(FeedbackType.MOTION_FINISH) and m.wants(FeedbackType.TRIGGER)
    assert not m.wants(FeedbackType.MOTION_START) and not m.wants(FeedbackType.OTHER_FINISH)
    assert m.types == FeedbackType.MOTION_FINISH | FeedbackType.TRIGGER  # bit 8 has no name
    assert m.encode() == b"\x0e" and FeedbackMask().bits == 0
    with pytest.raises(ValueError):
        FeedbackMask.decode(b"")
    with pytest.raises(ValueError):
        FeedbackMask.decode(b"\x01\x02")


def test_type_values_match_the_sdk():
    from xarm.core.config.x_config import XCONF

    sdk = XCONF.FeedbackType
    assert [int(t) for t in (FeedbackType.MOTION_START, FeedbackType.MOTION_FINISH, FeedbackType.TRIGGER,
                             FeedbackType.OTHER_START, FeedbackType.OTHER_FINISH)] == \
        [sdk.MOTION_START, sdk.MOTION_FINISH, sdk.TRIGGER, sdk.OTHER_START, sdk.OTHER_FINISH]
    codes = XCONF.FeedbackCode
    assert (FeedbackCode.SUCCESS, FeedbackCode.FAILURE, FeedbackCode.DISCARDED) == \
        (codes.SUCCESS, codes.FAILURE, codes.DISCARD)
