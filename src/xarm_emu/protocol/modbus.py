"""The standard Modbus-TCP map of the control box (protocol id 0 on the command port), sans-IO.

The control box answers standard Modbus-TCP frames on the same port and connection as the
private protocol (manual section 2.1.2 names protocol id 0 "standard Modbus TCP"); the SDK's
``read_coil_bits`` ... ``write_and_read_holding_registers`` send them on its command socket. The
published map (UFACTORY's "Modbus TCP" manual for the control box) has four tables: coils and
discrete inputs for the GPIO and status bits, holding and input registers for the analog IO, mode
and state, joints, pose, speeds, temperatures, the counter and the Blockly / G-code triggers.

:data:`MODBUS_MAP` is that map as one table; :func:`handle_pdu` answers one request PDU against a
:class:`Datastore` (the binding to a live emulator is :mod:`xarm_emu.controller.modbus_map`).
Standard encoding and decoding of the PDUs is pymodbus's PDU layer; the address checks and
the datastore calls are here, synchronous.

Function codes 01, 02, 03, 04, 05, 06, 0F, 10, 16 and 17. Exceptions: 1 illegal function (an
unsupported code, or a code an address does not take, e.g. FC 06 on the Blockly trigger), 2
illegal data address (an address outside the published ranges, or a write to a read-only one), 3
illegal data value (a bad quantity, byte count, coil value or register value), 4 device failure
(a fault of the emulator itself; never expected).

Decisions on what the published map leaves open:

- Unit id: the box is one device; every unit id is served by the same map and echoed, since an
  unanswered frame would hold the SDK's Modbus call in its 10 000 s wait. Unit 1 is the published one.
- Bit order: coil / discrete input n and bit n of holding / input register 0 are IO n, with IO 0-7 the
  CO/CI 0-7 and IO 8-15 the DO/DI 0-7 (as the SDK's ``set_cgpio_digital`` numbers them); register 1
  holds IO 16-31 (none present, reads 0). Holding / input register 2 bit n is TO/TI n.
- Reserved addresses (coils 40-127 and 160-255, registers 11-31, 34-47 and so on) are not in the map:
  any access that touches one gets exception 2, as the published notice says ("access the pre-defined
  register address ... or there will be exception in response").
- Published but absent IO (coils 16-31 and 34-39, controller AO/AI 3-4, the tool analog outputs)
  reads 0; writes to it are accepted and change nothing.
- Read-only points in a writable table (coils 128-159) refuse writes with exception 2.
- Holding 32 (mode) writes act as register 19 and take the modes the emulator has (0, 1, 2); holding
  33 (state) writes act as register 12 and take 0 (motion), 3 (pause) and 4 (stop). Other values: 3.
- Scaled values round half away from zero and saturate at the int16 (signed) or uint16 (unsigned)
  limits instead of wrapping.
- Blockly (holding 48-63) and G-code (holding 64) triggers take FC 10 only, starting at their first
  address (others: exception 1 for the function, 2 for the start). The emulator runs no projects: the
  values are kept (reads return the last trigger) and the binding records the project numbers.
- User storage (coils and holding registers 256-511) holds what is written. It lives in the binding
  only and does not survive a restart or ``save_conf`` (register 40): the published material says the
  registers are user defined but not that they are saved, and register 40 saves settings, not data.
- Connections: as many PLC connections as the command port takes; each frame is answered alone.
"""

from __future__ import annotations

import enum
import logging
import math
import struct
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

from pymodbus.pdu import DecodePDU, ExceptionResponse, ModbusPDU
from pymodbus.pdu.bit_message import (
    ReadCoilsResponse,
    ReadDiscreteInputsResponse,
    WriteMultipleCoilsResponse,
    WriteSingleCoilResponse,
)
from pymodbus.pdu.register_message import (
    MaskWriteRegisterResponse,
    ReadHoldingRegistersResponse,
    ReadInputRegistersResponse,
    ReadWriteMultipleRegistersResponse,
    WriteMultipleRegistersResponse,
    WriteSingleRegisterResponse,
)

log = logging.getLogger(__name__)

#: The unit id the published map names ("ID, fixed"); every unit id is answered (module docstring).
UNIT_ID = 1

# Function codes (Modbus application protocol).
READ_COILS = 0x01
READ_DISCRETE_INPUTS = 0x02
READ_HOLDING_REGISTERS = 0x03
READ_INPUT_REGISTERS = 0x04
WRITE_SINGLE_COIL = 0x05
WRITE_SINGLE_REGISTER = 0x06
WRITE_MULTIPLE_COILS = 0x0F
WRITE_MULTIPLE_REGISTERS = 0x10
MASK_WRITE_REGISTER = 0x16
READ_WRITE_MULTIPLE_REGISTERS = 0x17
FUNCTION_CODES = frozenset({0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x0F, 0x10, 0x16, 0x17})

# Exception codes.
ILLEGAL_FUNCTION = 1
ILLEGAL_DATA_ADDRESS = 2
ILLEGAL_DATA_VALUE = 3
DEVICE_FAILURE = 4

# Quantity limits of the standard.
MAX_READ_BITS = 2000
MAX_READ_REGISTERS = 125
MAX_WRITE_BITS = 1968
MAX_WRITE_REGISTERS = 123
MAX_RW_WRITE_REGISTERS = 121

COIL_ON = 0xFF00
COIL_OFF = 0x0000


class Kind(enum.Enum):
    """The four tables of the map."""

    COIL = "coil"
    DISCRETE_INPUT = "discrete input"
    HOLDING = "holding register"
    INPUT = "input register"

    @property
    def bits(self) -> bool:
        return self in (Kind.COIL, Kind.DISCRETE_INPUT)


class ModbusError(Exception):
    """A request the map refuses; ``code`` is the Modbus exception code."""

    def __init__(self, code: int, message: str = "") -> None:
        super().__init__(message or f"Modbus exception {code}")
        self.code = code


@dataclass(frozen=True)
class Point:
    """``count`` consecutive addresses of one table with one meaning.

    ``scale``: wire value = engineering value x scale (rounded half away from zero, saturated);
    ``signed``: int16 on the wire, else uint16; ``writable``: writes accepted; ``accepts``: the raw
    values a write may carry (None: any); ``functions``: the write function codes it takes (None:
    any); ``start_only``: writes must start at ``address``; ``writes``: the private register a
    write is equivalent to; ``doc``: the decision taken where the published map is silent.
    """

    kind: Kind
    address: int
    count: int
    name: str
    unit: str = ""
    scale: float = 1.0
    signed: bool = False
    writable: bool = False
    accepts: frozenset[int] | range | None = None
    functions: frozenset[int] | None = None
    start_only: bool = False
    writes: str = ""
    doc: str = ""

    @property
    def end(self) -> int:
        return self.address + self.count

    def encode(self, value: float) -> int:
        """Engineering value -> uint16 wire word (two's complement when signed)."""
        if self.kind.bits:
            return 1 if value else 0
        x = float(value) * self.scale
        if not math.isfinite(x):
            x = 0.0
        r = math.floor(abs(x) + 0.5)
        n = int(-r if x < 0 else r)
        lo, hi = (-0x8000, 0x7FFF) if self.signed else (0, 0xFFFF)
        return min(max(n, lo), hi) & 0xFFFF

    def decode(self, word: int) -> float:
        """uint16 wire word -> engineering value."""
        if self.kind.bits:
            return float(word & 1)
        n = word - 0x10000 if self.signed and word & 0x8000 else word
        return n / self.scale


_C, _D, _H, _I = Kind.COIL, Kind.DISCRETE_INPUT, Kind.HOLDING, Kind.INPUT
_ABSENT = "published but not present on this box: reads 0, writes change nothing"
_FC10 = frozenset({WRITE_MULTIPLE_REGISTERS})

#: The whole published map. Point names are what the binding keys on.
MODBUS_MAP: tuple[Point, ...] = (
    # ---- coils ------------------------------------------------------------------------------
    Point(_C, 0, 16, "cgpio_outputs", writable=True, writes="134 CGPIO_SET_DIGIT",
          doc="coil n = IO n: 0-7 CO0-7, 8-15 DO0-7; a write sets the outputs as register 134 does"),
    Point(_C, 16, 16, "cgpio_outputs_absent", writable=True, doc=_ABSENT),
    Point(_C, 32, 2, "tgpio_outputs", writable=True, writes="127 TGPIO_W16B 0x0A15",
          doc="32 = TO0, 33 = TO1"),
    Point(_C, 34, 6, "tgpio_outputs_absent", writable=True, doc=_ABSENT),
    Point(_C, 128, 7, "brakes", doc="J1-J7, 1 = brake released (report byte of brake states)"),
    Point(_C, 135, 7, "enabled", doc="J1-J7, 1 = enabled"),
    Point(_C, 142, 1, "reduced_mode", doc="1 while reduced mode is on (register 50)"),
    Point(_C, 143, 1, "fence", doc="safety boundary switch (register 59); not reported: reads 0"),
    Point(_C, 144, 1, "paused", doc="1 when the state is 3 (suspended)"),
    Point(_C, 145, 1, "stopped", doc="1 when the state is 4 (stopped)"),
    Point(_C, 146, 14, "mode_bits", doc="coil 146 + n is 1 in mode n (register 19 modes)"),
    Point(_C, 256, 256, "user_coils", writable=True,
          doc="general purpose; kept by the binding, not saved by register 40"),
    # ---- discrete inputs ---------------------------------------------------------------------
    Point(_D, 0, 16, "cgpio_inputs", doc="input n = IO n: 0-7 CI0-7, 8-15 DI0-7 (register 131)"),
    Point(_D, 16, 16, "cgpio_inputs_absent", doc=_ABSENT),
    Point(_D, 32, 2, "tgpio_inputs", doc="32 = TI0, 33 = TI1 (register 128, 0x0A14)"),
    Point(_D, 34, 6, "tgpio_inputs_absent", doc=_ABSENT),
    # ---- holding registers -------------------------------------------------------------------
    Point(_H, 0, 1, "cgpio_output_word", writable=True, writes="134 CGPIO_SET_DIGIT",
          doc="bit n = IO n (CO0-7, DO0-7); a write sets all 16 outputs"),
    Point(_H, 1, 1, "cgpio_output_word_hi", writable=True, doc="IO 16-31: " + _ABSENT),
    Point(_H, 2, 1, "tgpio_output_word", writable=True, writes="127 TGPIO_W16B 0x0A15",
          doc="bit n = TO n; bits 2-7 are " + _ABSENT),
    Point(_H, 3, 2, "analog_outputs", unit="V", scale=1000.0, writable=True, accepts=range(0, 10001),
          writes="135/136 CGPIO_SET_ANALOG1/2", doc="AO0, AO1, 0-10 V; values beyond 10000: exception 3"),
    Point(_H, 5, 2, "analog_outputs_absent", unit="V", scale=1000.0, writable=True, doc=_ABSENT),
    Point(_H, 7, 4, "tool_analog_outputs", unit="V", scale=1000.0, writable=True,
          doc="published as not effective: " + _ABSENT),
    Point(_H, 32, 1, "mode", writable=True, accepts=frozenset({0, 1, 2}), writes="19 SET_MODE",
          doc="a write sets the mode as register 19 does (0 position, 1 servo, 2 joint teaching)"),
    Point(_H, 33, 1, "state", writable=True, accepts=frozenset({0, 3, 4}), writes="12 SET_STATE",
          doc="reads the state (register 13); a write acts as register 12 (0 motion, 3 pause, 4 stop)"),
    Point(_H, 48, 16, "blockly_trigger", writable=True, functions=_FC10, start_only=True,
          doc="FC 10 at 48 only; value n requests Blockly project %05d, in order. The emulator runs "
              "no projects: the values are kept and recorded"),
    Point(_H, 64, 1, "gcode_trigger", writable=True, functions=_FC10, start_only=True,
          doc="FC 10 at 64 only; value n requests G-code file %05d. Kept and recorded, not run"),
    Point(_H, 256, 256, "user_registers", writable=True,
          doc="general purpose; kept by the binding, not saved by register 40"),
    # ---- input registers ---------------------------------------------------------------------
    Point(_I, 0, 1, "cgpio_input_word", doc="bit n = IO n (CI0-7, DI0-7)"),
    Point(_I, 1, 1, "cgpio_input_word_hi", doc="IO 16-31: " + _ABSENT),
    Point(_I, 2, 1, "tgpio_input_word", doc="bit n = TI n"),
    Point(_I, 3, 2, "analog_inputs", unit="V", scale=1000.0, doc="AI0, AI1 (registers 132/133)"),
    Point(_I, 5, 2, "analog_inputs_absent", unit="V", scale=1000.0, doc=_ABSENT),
    Point(_I, 7, 2, "tool_analog_inputs", unit="V", scale=1000.0, doc="tool AI0, AI1 (register 128)"),
    Point(_I, 9, 2, "tool_analog_inputs_absent", unit="V", scale=1000.0, doc=_ABSENT),
    Point(_I, 32, 1, "error", doc="control box error code (section 3.2.1)"),
    Point(_I, 33, 1, "warning", doc="warning code (section 3.2.2)"),
    Point(_I, 34, 2, "counter",
          doc="the commands counter (rich report bytes 285-288): 34 high 16 bits, 35 low 16 bits"),
    Point(_I, 64, 9, "pose", unit="mm, deg", scale=10.0, signed=True,
          doc="TCP x, y, z (mm), roll, pitch, yaw (deg), then the same orientation as an axis-angle "
              "vector rx, ry, rz (deg)"),
    Point(_I, 73, 1, "payload_mass", unit="kg", scale=1000.0, doc="TCP payload (register 25)"),
    Point(_I, 74, 3, "payload_center", unit="mm", scale=10.0, signed=True),
    Point(_I, 77, 6, "tcp_offset", unit="mm, deg", scale=10.0, signed=True, doc="TCP offset (register 22)"),
    Point(_I, 83, 6, "world_offset", unit="mm, deg", scale=10.0, signed=True,
          doc="user coordinate offset (register 73)"),
    Point(_I, 89, 7, "joints", unit="deg", scale=10.0, signed=True, doc="J1-J7; absent joints read 0"),
    Point(_I, 96, 7, "temperatures", unit="degC", signed=True, doc="J1-J7"),
    Point(_I, 103, 7, "joint_speeds", unit="deg/s", scale=10.0, signed=True, doc="J1-J7, planned"),
    Point(_I, 110, 1, "tcp_speed", unit="mm/s", scale=10.0, doc="planned TCP speed"),
)

POINTS: dict[str, Point] = {p.name: p for p in MODBUS_MAP}


def _index() -> dict[Kind, dict[int, tuple[Point, int]]]:
    idx: dict[Kind, dict[int, tuple[Point, int]]] = {k: {} for k in Kind}
    for p in MODBUS_MAP:
        for off in range(p.count):
            if p.address + off in idx[p.kind]:
                raise ValueError(f"{p.kind.value} {p.address + off} is mapped twice")
            idx[p.kind][p.address + off] = (p, off)
    return idx


#: kind -> address -> (point, offset within the point)
ADDRESSES = _index()


class Datastore(Protocol):
    """What :func:`handle_pdu` reads and writes.

    ``read`` returns the point's ``count`` engineering values (bits as 0/1); ``write`` takes raw
    wire values (bits 0/1, or uint16 words) for addresses ``point.address + offset`` onwards and may
    raise :class:`ModbusError`.
    """

    def read(self, point: Point) -> Sequence[float]: ...

    def write(self, point: Point, offset: int, values: Sequence[int]) -> None: ...


# ---- the PDU layer -------------------------------------------------------------------------------

_DECODER = DecodePDU(is_server=True)


def exception_pdu(function: int, code: int) -> bytes:
    """Exception reply PDU: ``function | 0x80``, code."""
    exc = ExceptionResponse(function & 0x7F, code)
    return bytes((exc.function_code,)) + exc.encode()


def _pdu(resp: ModbusPDU) -> bytes:
    return bytes((resp.function_code,)) + resp.encode()


def _span(kind: Kind, address: int, count: int) -> list[tuple[Point, int]]:
    table = ADDRESSES[kind]
    out = []
    for a in range(address, address + count):
        hit = table.get(a)
        if hit is None:
            raise ModbusError(ILLEGAL_DATA_ADDRESS, f"{kind.value} {a} is not in the map")
        out.append(hit)
    return out


def read_raw(kind: Kind, address: int, count: int, store: Datastore) -> list[int]:
    """Wire values of ``count`` addresses of one table (bits 0/1 or uint16 words)."""
    cache: dict[str, Sequence[float]] = {}
    out = []
    for point, off in _span(kind, address, count):
        values = cache.get(point.name)
        if values is None:
            values = cache[point.name] = store.read(point)
        out.append(point.encode(values[off]))
    return out


def write_raw(kind: Kind, address: int, values: Sequence[int], store: Datastore, function: int) -> None:
    """Check a whole write against the map, then hand it to ``store`` one point at a time."""
    span = _span(kind, address, len(values))
    for (point, off), v in zip(span, values, strict=True):
        if not point.writable:
            raise ModbusError(ILLEGAL_DATA_ADDRESS, f"{point.name} is read-only")
        if point.functions is not None and function not in point.functions:
            raise ModbusError(ILLEGAL_FUNCTION, f"{point.name} takes functions {sorted(point.functions)}")
        if point.start_only and (point, off) == span[0] and off != 0:
            raise ModbusError(ILLEGAL_DATA_ADDRESS, f"writes to {point.name} start at {point.address}")
        if point.accepts is not None and v not in point.accepts:
            raise ModbusError(ILLEGAL_DATA_VALUE, f"{v} for {point.name}")
    i = 0
    while i < len(span):
        point, off = span[i]
        j = i
        while j < len(span) and span[j][0] is point:
            j += 1
        store.write(point, off, list(values[i:j]))
        i = j


def _count_ok(count: int, limit: int) -> None:
    if not 1 <= count <= limit:
        raise ModbusError(ILLEGAL_DATA_VALUE, f"quantity {count} (1-{limit})")


#: Shortest request PDU per function code, and the quantity limit at bytes 3-4 where there is one.
_MIN_SIZE = {0x01: 5, 0x02: 5, 0x03: 5, 0x04: 5, 0x05: 5, 0x06: 5, 0x0F: 6, 0x10: 6, 0x16: 7, 0x17: 10}
_QUANTITY = {0x01: MAX_READ_BITS, 0x02: MAX_READ_BITS, 0x03: MAX_READ_REGISTERS, 0x04: MAX_READ_REGISTERS,
             0x0F: MAX_WRITE_BITS, 0x10: MAX_WRITE_REGISTERS}


def _dispatch(pdu: bytes, store: Datastore) -> bytes:
    function = pdu[0]
    # Sizes and quantities are checked before pymodbus decodes, so malformed requests get
    # exception 3 here rather than a decoder failure.
    if len(pdu) < _MIN_SIZE[function]:
        raise ModbusError(ILLEGAL_DATA_VALUE, "short request")
    if function in _QUANTITY:
        _count_ok(struct.unpack_from(">H", pdu, 3)[0], _QUANTITY[function])
    req = _DECODER.decode(pdu)
    if req is None or req.function_code != function:
        raise ModbusError(ILLEGAL_DATA_VALUE, "malformed request")
    body = pdu[1:]
    if function in (READ_COILS, READ_DISCRETE_INPUTS):
        if len(body) != 4:
            raise ModbusError(ILLEGAL_DATA_VALUE, "length")
        _count_ok(req.count, MAX_READ_BITS)
        kind = _C if function == READ_COILS else _D
        bits = [bool(b) for b in read_raw(kind, req.address, req.count, store)]
        cls = ReadCoilsResponse if function == READ_COILS else ReadDiscreteInputsResponse
        return _pdu(cls(bits=bits))
    if function in (READ_HOLDING_REGISTERS, READ_INPUT_REGISTERS):
        if len(body) != 4:
            raise ModbusError(ILLEGAL_DATA_VALUE, "length")
        _count_ok(req.count, MAX_READ_REGISTERS)
        kind = _H if function == READ_HOLDING_REGISTERS else _I
        words = read_raw(kind, req.address, req.count, store)
        holding = function == READ_HOLDING_REGISTERS
        rcls = ReadHoldingRegistersResponse if holding else ReadInputRegistersResponse
        return _pdu(rcls(registers=words))
    if function == WRITE_SINGLE_COIL:
        if len(body) != 4:
            raise ModbusError(ILLEGAL_DATA_VALUE, "length")
        value = struct.unpack_from(">H", body, 2)[0]
        if value not in (COIL_ON, COIL_OFF):
            raise ModbusError(ILLEGAL_DATA_VALUE, f"coil value {value:#06x} (FF00 or 0000)")
        write_raw(_C, req.address, [1 if value == COIL_ON else 0], store, function)
        return _pdu(WriteSingleCoilResponse(address=req.address, bits=[value == COIL_ON]))
    if function == WRITE_SINGLE_REGISTER:
        if len(body) != 4:
            raise ModbusError(ILLEGAL_DATA_VALUE, "length")
        write_raw(_H, req.address, [req.registers[0]], store, function)
        return _pdu(WriteSingleRegisterResponse(address=req.address, registers=[req.registers[0]]))
    if function == WRITE_MULTIPLE_COILS:
        _count_ok(req.count, MAX_WRITE_BITS)
        if body[4] != (req.count + 7) // 8 or len(body) != 5 + body[4]:
            raise ModbusError(ILLEGAL_DATA_VALUE, "byte count")
        write_raw(_C, req.address, [1 if b else 0 for b in req.bits[: req.count]], store, function)
        return _pdu(WriteMultipleCoilsResponse(address=req.address, count=req.count))
    if function == WRITE_MULTIPLE_REGISTERS:
        _count_ok(req.count, MAX_WRITE_REGISTERS)
        if body[4] != 2 * req.count or len(body) != 5 + body[4]:
            raise ModbusError(ILLEGAL_DATA_VALUE, "byte count")
        write_raw(_H, req.address, list(req.registers), store, function)
        return _pdu(WriteMultipleRegistersResponse(address=req.address, count=req.count))
    if function == MASK_WRITE_REGISTER:
        if len(body) != 6:
            raise ModbusError(ILLEGAL_DATA_VALUE, "length")
        and_mask, or_mask = req.and_mask, req.or_mask  # type: ignore[attr-defined]
        current = read_raw(_H, req.address, 1, store)[0]
        result = (current & and_mask) | (or_mask & ~and_mask & 0xFFFF)
        write_raw(_H, req.address, [result], store, function)
        return _pdu(MaskWriteRegisterResponse(address=req.address, and_mask=and_mask, or_mask=or_mask))
    if function == READ_WRITE_MULTIPLE_REGISTERS:
        r_addr, r_count, w_addr, w_count, w_bytes = struct.unpack_from(">HHHHB", body)
        _count_ok(r_count, MAX_READ_REGISTERS)
        _count_ok(w_count, MAX_RW_WRITE_REGISTERS)
        if w_bytes != 2 * w_count or len(body) != 9 + w_bytes:
            raise ModbusError(ILLEGAL_DATA_VALUE, "byte count")
        _span(_H, r_addr, r_count)  # both ranges are checked before the write
        write_raw(_H, w_addr, list(struct.unpack_from(f">{w_count}H", body, 9)), store, function)
        words = read_raw(_H, r_addr, r_count, store)
        return _pdu(ReadWriteMultipleRegistersResponse(registers=words))
    raise ModbusError(ILLEGAL_FUNCTION, f"function {function:#04x}")


def handle_pdu(request_pdu: bytes, datastore: Datastore) -> bytes:
    """The reply PDU to one request PDU (function code and data, no MBAP header); never raises."""
    if not request_pdu:
        return exception_pdu(0, ILLEGAL_FUNCTION)
    function = request_pdu[0]
    if function not in FUNCTION_CODES:
        return exception_pdu(function, ILLEGAL_FUNCTION)
    try:
        return _dispatch(request_pdu, datastore)
    except ModbusError as exc:
        return exception_pdu(function, exc.code)
    except (struct.error, IndexError, ValueError) as exc:
        log.debug("malformed Modbus request %s: %s", request_pdu.hex(), exc)
        return exception_pdu(function, ILLEGAL_DATA_VALUE)
    except Exception:  # a fault of the emulator must not take the connection down
        log.exception("Modbus request %s failed", request_pdu.hex())
        return exception_pdu(function, DEVICE_FAILURE)


def encode_adu(tid: int, unit: int, pdu: bytes) -> bytes:
    """MBAP header (transaction id, protocol 0, length, unit id) + PDU."""
    return struct.pack(">HHHB", tid & 0xFFFF, 0, 1 + len(pdu), unit & 0xFF) + pdu
