"""Modbus-RTU PDUs as register 124 tunnels them to the tool RS-485 (manual section 2.1.4).

Register 124 carries ``[host id][RTU frame without CRC]`` both ways; this module
handles the RTU part: ``[slave id][function][data]``. Supported functions are the
ones the xArm Gripper uses: read holding registers (0x03), write single register
(0x06) and write multiple registers (0x10). Register values are u16 big-endian.

Sans-IO and total: :func:`serve` turns any byte string into a reply PDU; malformed
requests get a Modbus exception reply (``function | 0x80, code``), never a Python
exception.
"""

from __future__ import annotations

import struct
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Protocol

#: RS-485 host ids of register 124 and of the tool board registers 127/128: the tool bus
#: (manual section 2.1.4 "Host ID 0x09") and the control box bus (the SDK's host id 11).
TOOL_HOST = 9
CONTROL_BOX_HOST = 11

READ_HOLDING = 0x03
WRITE_SINGLE = 0x06
WRITE_MULTIPLE = 0x10
FUNCTIONS = frozenset({READ_HOLDING, WRITE_SINGLE, WRITE_MULTIPLE})

# Modbus exception codes (Modbus application protocol, section 7).
ILLEGAL_FUNCTION = 0x01
ILLEGAL_ADDRESS = 0x02
ILLEGAL_VALUE = 0x03
DEVICE_FAILURE = 0x04
GATEWAY_NO_RESPONSE = 0x0B  # the addressed slave did not answer

MAX_READ = 125  # registers per 0x03 request
MAX_WRITE = 123  # registers per 0x10 request


class RtuError(Exception):
    """A request that must be answered with a Modbus exception."""

    def __init__(self, code: int, slave: int = 0, function: int = 0) -> None:
        super().__init__(f"modbus exception {code:#04x}")
        self.code = code
        self.slave = slave
        self.function = function


@dataclass(frozen=True, slots=True)
class RtuRequest:
    """A decoded request. For reads ``values`` is empty and ``count`` the quantity."""

    slave: int
    function: int
    address: int
    count: int
    values: tuple[int, ...] = ()


class RegisterDevice(Protocol):
    """A Modbus slave: raises :class:`RtuError` to refuse."""

    def read_registers(self, address: int, count: int) -> list[int]: ...

    def write_registers(self, address: int, values: Sequence[int]) -> None: ...


def parse_request(pdu: bytes) -> RtuRequest:
    """Decode a request PDU; raises :class:`RtuError` for anything malformed."""
    if len(pdu) < 2:
        raise RtuError(ILLEGAL_FUNCTION if len(pdu) == 1 else ILLEGAL_VALUE, pdu[0] if pdu else 0, 0)
    slave, func = pdu[0], pdu[1]
    body = pdu[2:]
    if func not in FUNCTIONS:
        raise RtuError(ILLEGAL_FUNCTION, slave, func)
    if func == READ_HOLDING:
        if len(body) != 4:
            raise RtuError(ILLEGAL_VALUE, slave, func)
        addr, count = struct.unpack(">HH", body)
        if not 1 <= count <= MAX_READ or addr + count > 0x10000:
            raise RtuError(ILLEGAL_VALUE, slave, func)
        return RtuRequest(slave, func, addr, count)
    if func == WRITE_SINGLE:
        if len(body) != 4:
            raise RtuError(ILLEGAL_VALUE, slave, func)
        addr, value = struct.unpack(">HH", body)
        return RtuRequest(slave, func, addr, 1, (value,))
    # WRITE_MULTIPLE: addr, quantity, byte count, values
    if len(body) < 5:
        raise RtuError(ILLEGAL_VALUE, slave, func)
    addr, count, nbytes = struct.unpack_from(">HHB", body)
    data = body[5:]
    if not 1 <= count <= MAX_WRITE or nbytes != 2 * count or len(data) != nbytes or addr + count > 0x10000:
        raise RtuError(ILLEGAL_VALUE, slave, func)
    return RtuRequest(slave, func, addr, count, struct.unpack(f">{count}H", data))


# --- building requests (client side, tests) ----------------------------------------------------------


def s32_words(value: int) -> tuple[int, int]:
    """A signed 32-bit value as two holding registers, high word first (as the grippers and the
    linear track hold positions)."""
    v = value & 0xFFFFFFFF
    return v >> 16, v & 0xFFFF


def words_s32(hi: int, lo: int) -> int:
    """Two holding registers, high word first, as a signed 32-bit value (:func:`s32_words`)."""
    v = (hi << 16) | lo
    return v - (1 << 32) if v & 0x80000000 else v


def read_request(slave: int, address: int, count: int) -> bytes:
    return struct.pack(">BBHH", slave, READ_HOLDING, address, count)


def write_single_request(slave: int, address: int, value: int) -> bytes:
    return struct.pack(">BBHH", slave, WRITE_SINGLE, address, value & 0xFFFF)


def write_multiple_request(slave: int, address: int, values: Sequence[int]) -> bytes:
    n = len(values)
    return struct.pack(f">BBHHB{n}H", slave, WRITE_MULTIPLE, address, n, 2 * n, *(v & 0xFFFF for v in values))


# --- building replies --------------------------------------------------------------------------------


def read_reply(slave: int, values: Sequence[int]) -> bytes:
    n = len(values)
    return struct.pack(f">BBB{n}H", slave, READ_HOLDING, 2 * n, *(v & 0xFFFF for v in values))


def write_single_reply(slave: int, address: int, value: int) -> bytes:
    return struct.pack(">BBHH", slave, WRITE_SINGLE, address, value & 0xFFFF)


def write_multiple_reply(slave: int, address: int, count: int) -> bytes:
    return struct.pack(">BBHH", slave, WRITE_MULTIPLE, address, count)


def exception_reply(slave: int, function: int, code: int) -> bytes:
    return bytes((slave & 0xFF, (function | 0x80) & 0xFF, code & 0xFF))


def parse_reply(pdu: bytes) -> tuple[int, int, tuple[int, ...]]:
    """Decode a reply into ``(slave, function, values)`` (client side and tests).

    Reads give the register values, writes ``(address, count or value)``,
    exceptions ``(code,)`` with ``function`` keeping its 0x80 bit.
    """
    if len(pdu) < 3:
        raise ValueError("RTU reply too short")
    slave, func = pdu[0], pdu[1]
    if func & 0x80:
        return slave, func, (pdu[2],)
    if func == READ_HOLDING:
        n = pdu[2]
        if n % 2 or len(pdu) != 3 + n:
            raise ValueError("RTU read reply length mismatch")
        return slave, func, struct.unpack(f">{n // 2}H", pdu[3:])
    if len(pdu) != 6:
        raise ValueError("RTU write reply length mismatch")
    return slave, func, struct.unpack(">HH", pdu[2:])


# --- serving -----------------------------------------------------------------------------------------


def serve(pdu: bytes, devices: Mapping[int, RegisterDevice]) -> bytes:
    """Answer one request PDU from the devices on the bus (keyed by slave id).

    A slave id with no device gets exception 0x0B (gateway: target did not
    respond); the controller relays that instead of timing out.
    """
    try:
        req = parse_request(bytes(pdu))
        dev = devices.get(req.slave)
        if dev is None:
            raise RtuError(GATEWAY_NO_RESPONSE, req.slave, req.function)
        try:
            if req.function == READ_HOLDING:
                vals = dev.read_registers(req.address, req.count)
                return read_reply(req.slave, vals)
            dev.write_registers(req.address, req.values)
        except RtuError as exc:
            raise RtuError(exc.code, req.slave, req.function) from exc
        if req.function == WRITE_SINGLE:
            return write_single_reply(req.slave, req.address, req.values[0])
        return write_multiple_reply(req.slave, req.address, req.count)
    except RtuError as exc:
        return exception_reply(exc.slave, exc.function, exc.code)
    except Exception:  # a device bug must not escape to the command port
        slave = pdu[0] if len(pdu) > 0 else 0
        func = pdu[1] if len(pdu) > 1 else 0
        return exception_reply(slave, func, DEVICE_FAILURE)
