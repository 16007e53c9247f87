"""Modbus-TCP style frames of the xArm command port (manual section 2.1.2).

Request:  ``tid u16 BE | protocol u16 BE | length u16 BE | register u8 | params``
Reply:    ``tid u16 BE | protocol u16 BE | length u16 BE | register u8 | state u8 | params``

``length`` counts the bytes after itself. Sans-IO: :class:`FrameDecoder` takes
bytes as they arrive and yields complete frames; nothing here touches a socket.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

HEADER = struct.Struct(">HHH")
HEADER_SIZE = HEADER.size  # 6

PROTOCOL_STANDARD = 0  # standard Modbus TCP (SDK section 3.9)
PROTOCOL_HEARTBEAT = 1  # SDK heartbeat, never answered
#: The control box command port (manual section 2.1.1).
COMMAND_PORT = 502
PROTOCOL_PRIVATE = 2  # manual section 2.1.2: "0x00 0x02 Control"
PROTOCOL_PRIVATE_V3 = 3  # SDK after its report thread starts, on firmware past the manual's
PRIVATE_PROTOCOLS = frozenset({PROTOCOL_PRIVATE, PROTOCOL_PRIVATE_V3})

# Reply state bits (section 2.1.2, "Status Bit of the Response Format").
STATE_ERROR = 0x40
STATE_WARNING = 0x20
STATE_NOT_READY = 0x10
#: The command was understood but could not be carried out (the SDK's code 10, "invalid").
STATE_FAILED = 0x08

#: Largest length field accepted. The biggest real request (register 124 with
#: a Modbus-RTU write) is far below this; anything larger is a broken stream.
MAX_LENGTH = 1024


class FrameError(ValueError):
    """The byte stream cannot be framed; the connection should be closed."""


@dataclass(frozen=True, slots=True)
class Request:
    """One decoded request frame. For protocol 0 (standard Modbus) ``register``
    is the unit id and ``params`` the PDU."""

    tid: int
    protocol: int
    register: int
    params: bytes

    def encode(self) -> bytes:
        return encode_request(self.tid, self.register, self.params, self.protocol)


class StateBits:
    """The reply state byte's bits (section 2.1.2) for anything with a ``state`` attribute."""

    __slots__ = ()
    state: int

    @property
    def has_error(self) -> bool:
        return bool(self.state & STATE_ERROR)

    @property
    def has_warning(self) -> bool:
        return bool(self.state & STATE_WARNING)

    @property
    def not_ready(self) -> bool:
        return bool(self.state & STATE_NOT_READY)


@dataclass(frozen=True, slots=True)
class Reply(StateBits):
    """One decoded reply frame."""

    tid: int
    protocol: int
    register: int
    state: int
    params: bytes

    def encode(self) -> bytes:
        return encode_reply(self.tid, self.protocol, self.register, self.state, self.params)


def answers(protocol: int) -> bool:
    """Whether a request frame of ``protocol`` gets a reply: ids 2 and 3 (private, echoed in the
    reply; the SDK switches between them on one connection), 0 (standard Modbus); never id 1, the
    SDK's heartbeat."""
    return protocol in PRIVATE_PROTOCOLS or protocol == PROTOCOL_STANDARD


def reply_for(request: Request, state: int, params: bytes = b"") -> bytes | None:
    """The reply frame to a private-protocol request, echoing its tid and protocol id (2 or 3);
    ``None`` for the heartbeat (id 1), which is never answered."""
    if request.protocol == PROTOCOL_HEARTBEAT:
        return None
    if request.protocol not in PRIVATE_PROTOCOLS:
        raise FrameError(f"protocol {request.protocol} is not the private protocol")
    return encode_reply(request.tid, request.protocol, request.register, state, params)


def encode_request(tid: int, register: int, params: bytes = b"", protocol: int = PROTOCOL_PRIVATE) -> bytes:
    return HEADER.pack(tid & 0xFFFF, protocol, 1 + len(params)) + bytes((register,)) + params


def encode_reply(tid: int, protocol: int, register: int, state: int, params: bytes = b"") -> bytes:
    head = HEADER.pack(tid & 0xFFFF, protocol, 2 + len(params))
    return head + bytes((register & 0xFF, state & 0xFF)) + params


def encode_modbus_exception(tid: int, unit: int, function: int, code: int = 1) -> bytes:
    """Standard Modbus TCP exception reply (function | 0x80, code; 1 = illegal function)."""
    pdu = bytes(((function | 0x80) & 0xFF, code & 0xFF))
    return HEADER.pack(tid & 0xFFFF, PROTOCOL_STANDARD, 1 + len(pdu)) + bytes((unit & 0xFF,)) + pdu


class FrameDecoder:
    """Stream reassembly: feed bytes, get whole frames.

    Handles frames split across reads and several frames in one read. A length
    field of 0 or above :data:`MAX_LENGTH` raises :class:`FrameError`; the
    caller closes that connection (other clients are unaffected).
    """

    __slots__ = ("_buf", "_reply")

    def __init__(self, replies: bool = False) -> None:
        self._buf = bytearray()
        self._reply = replies

    @property
    def pending(self) -> int:
        return len(self._buf)

    def feed(self, data: bytes) -> list[Request] | list[Reply]:
        self._buf += data
        out: list = []
        buf = self._buf
        while len(buf) >= HEADER_SIZE:
            tid, prot, length = HEADER.unpack_from(buf, 0)
            minimum = 2 if self._reply else 1
            if length < minimum or length > MAX_LENGTH:
                raise FrameError(f"frame length {length} out of range")
            end = HEADER_SIZE + length
            if len(buf) < end:
                break
            reg = buf[HEADER_SIZE]
            if self._reply:
                out.append(Reply(tid, prot, reg, buf[HEADER_SIZE + 1], bytes(buf[HEADER_SIZE + 2 : end])))
            else:
                out.append(Request(tid, prot, reg, bytes(buf[HEADER_SIZE + 1 : end])))
            del buf[:end]
        return out


def decode_request(data: bytes) -> Request:
    """Decode exactly one request frame (tests and tools)."""
    frames = FrameDecoder().feed(data)
    if len(frames) != 1:
        raise FrameError(f"expected one frame, got {len(frames)}")
    return frames[0]  # type: ignore[return-value]


def decode_reply(data: bytes) -> Reply:
    frames = FrameDecoder(replies=True).feed(data)
    if len(frames) != 1:
        raise FrameError(f"expected one frame, got {len(frames)}")
    return frames[0]  # type: ignore[return-value]
