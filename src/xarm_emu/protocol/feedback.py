"""Feedback frames (registers 253/254, ``FirmwareProfile.feedback``), sans-IO.

A feedback frame is pushed unsolicited on the command connection, 21 bytes:
``tid u16 | protocol u16 | length u16 = 15 | 0xFF | state u8 | type u8 | register u8 |
task id u16 | code u8 | time u64 (microseconds)``, all big-endian. ``tid`` is the transaction
id of the command being reported; the SDK routes every frame whose byte 6 is 0xFF to its
feedback queue and reads the tid, the type and the code. The manual V1.6.0 is silent on it.
"""

from __future__ import annotations

import enum
import struct
from dataclasses import dataclass

from .frame import HEADER_SIZE, PROTOCOL_PRIVATE_V3, FrameError

#: Byte 6 of a feedback frame (where a reply has its register).
FEEDBACK_MARK = 0xFF
FEEDBACK_SIZE = 21
FEEDBACK_LENGTH = FEEDBACK_SIZE - HEADER_SIZE  # the length field: 15

_FRAME = struct.Struct(">HHHBBBBHBQ")
assert _FRAME.size == FEEDBACK_SIZE


class FeedbackType(enum.IntFlag):
    """Register 254's mask bits and a frame's type byte."""

    NONE = 0
    MOTION_START = 1  # a motion task starts executing
    MOTION_FINISH = 2  # a motion task ends, or is discarded
    TRIGGER = 4  # a non-motion task is triggered
    OTHER_START = 32
    OTHER_FINISH = 64


#: Every bit register 254 may carry (bit 8 appears in the SDK's example mask without a name).
FEEDBACK_MASK_ALL = 0xFF


class FeedbackCode(enum.IntEnum):
    """Byte 12: the outcome the SDK returns from its wait."""

    SUCCESS = 0
    FAILURE = 1  # OTHER_* types (trajectory load/save/playback failed)
    DISCARDED = 2  # the move was dropped, usually too short to be planned


@dataclass(frozen=True, slots=True)
class FeedbackMask:
    """Register 254's request byte as a typed value."""

    bits: int = 0

    @classmethod
    def decode(cls, params: bytes) -> FeedbackMask:
        """Register 254's one parameter byte; other lengths raise :class:`ValueError`."""
        if len(params) != 1:
            raise ValueError(f"register 254 takes 1 byte, got {len(params)}")
        return cls(params[0])

    def encode(self) -> bytes:
        return bytes((self.bits & 0xFF,))

    def wants(self, kind: FeedbackType) -> bool:
        return bool(self.bits & kind)

    @property
    def types(self) -> FeedbackType:
        """The named types in the mask (unnamed bits dropped)."""
        return FeedbackType(self.bits & sum(FeedbackType))


@dataclass(frozen=True, slots=True)
class Feedback:
    """One feedback frame."""

    tid: int  # transaction id of the reported command
    kind: FeedbackType
    register: int
    task_id: int = 0
    code: FeedbackCode = FeedbackCode.SUCCESS
    time_us: int = 0  # controller time, microseconds
    protocol: int = PROTOCOL_PRIVATE_V3  # echo the command's protocol id
    state: int = 0  # byte 7, like a reply's state byte

    def encode(self) -> bytes:
        return _FRAME.pack(self.tid & 0xFFFF, self.protocol & 0xFFFF, FEEDBACK_LENGTH, FEEDBACK_MARK,
                           self.state & 0xFF, int(self.kind) & 0xFF, self.register & 0xFF,
                           self.task_id & 0xFFFF, int(self.code) & 0xFF,
                           self.time_us & 0xFFFFFFFFFFFFFFFF)


def encode_feedback(tid: int, kind: FeedbackType, register: int, task_id: int = 0,
                    code: FeedbackCode = FeedbackCode.SUCCESS, time_us: int = 0,
                    protocol: int = PROTOCOL_PRIVATE_V3) -> bytes:
    return Feedback(tid, kind, register, task_id, code, time_us, protocol).encode()


def motion_start(tid: int, register: int, task_id: int, time_us: int,
                 protocol: int = PROTOCOL_PRIVATE_V3) -> Feedback:
    return Feedback(tid, FeedbackType.MOTION_START, register, task_id, FeedbackCode.SUCCESS, time_us,
                    protocol)


def motion_finish(tid: int, register: int, task_id: int, time_us: int, *, discarded: bool = False,
                  protocol: int = PROTOCOL_PRIVATE_V3) -> Feedback:
    """MOTION_FINISH; ``discarded`` gives code 2 (a move too short to plan)."""
    code = FeedbackCode.DISCARDED if discarded else FeedbackCode.SUCCESS
    return Feedback(tid, FeedbackType.MOTION_FINISH, register, task_id, code, time_us, protocol)


def trigger(tid: int, register: int, task_id: int, time_us: int, protocol: int = PROTOCOL_PRIVATE_V3
            ) -> Feedback:
    return Feedback(tid, FeedbackType.TRIGGER, register, task_id, FeedbackCode.SUCCESS, time_us, protocol)


def other_finish(tid: int, register: int, task_id: int, time_us: int, *, ok: bool = True,
                 protocol: int = PROTOCOL_PRIVATE_V3) -> Feedback:
    """OTHER_FINISH for registers 62/63/64; code 1 when the trajectory task failed."""
    code = FeedbackCode.SUCCESS if ok else FeedbackCode.FAILURE
    return Feedback(tid, FeedbackType.OTHER_FINISH, register, task_id, code, time_us, protocol)


def is_feedback(frame: bytes) -> bool:
    """True for a buffer holding a feedback frame (byte 6 is 0xFF)."""
    return len(frame) > HEADER_SIZE and frame[HEADER_SIZE] == FEEDBACK_MARK


def decode_feedback(frame: bytes) -> Feedback:
    """Decode one 21-byte frame; anything else raises :class:`~.frame.FrameError`."""
    if len(frame) != FEEDBACK_SIZE:
        raise FrameError(f"feedback frame is {FEEDBACK_SIZE} bytes, got {len(frame)}")
    tid, prot, length, mark, state, kind, reg, task, code, t = _FRAME.unpack(frame)
    if length != FEEDBACK_LENGTH or mark != FEEDBACK_MARK:
        raise FrameError(f"not a feedback frame (length {length}, byte 6 = {mark:#04x})")
    try:
        code_v = FeedbackCode(code)
    except ValueError as exc:
        raise FrameError(f"unknown feedback code {code}") from exc
    return Feedback(tid, FeedbackType(kind), reg, task, code_v, t, prot, state)
