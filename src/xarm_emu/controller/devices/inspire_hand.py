"""The Inspire RH56 dexterous hand on the tool RS-485 (register 124, host 9; ``--gripper inspire-rh56``).

The SDK drives it with raw Modbus-RTU (``getset_tgpio_modbus_data``, its third-party example
programs) as slave 1 at 115200 bps. Its register map, as the hand's vendor publishes it, numbers
bytes: each value is a 16-bit register at an even address, one per degree of freedom (little finger,
ring, middle, index, thumb bend, thumb rotation), so finger ``n`` of a block is at ``block + 2 n``;
a read of ``count`` registers from a block's finger returns that many consecutive fingers. Status
and error bytes come two to a register (the lower-numbered finger in the low byte).
:data:`REGISTER_MAP` is the same table for code:

=======================  ======  ==========================================================
address                  access  meaning
=======================  ======  ==========================================================
1000 (0x03E8)            r       hand id (1)
1004 (0x03EC)            w       clear errors (write 1)
1486-1496 (0x05CE-)      rw      ANGLE_SET: target angle 0 (bent) .. 1000 (open); 0xFFFF keeps
1498-1508 (0x05DA-)      rw      FORCE_SET: force limit 0..1000; 0xFFFF keeps
1522-1532 (0x05F2-)      rw      SPEED_SET: speed 0..1000; 0xFFFF keeps
1546-1556 (0x060A-)      r       ANGLE_ACT: the present angle
1582-1592 (0x062E-)      r       FORCE_ACT: the present grip force (0 without an object)
1606-1610 (0x0646-)      r       ERROR bytes (0: none)
1612-1616 (0x064C-)      r       STATUS bytes: 0 opening, 1 closing, 2 at the target, 7 fault
=======================  ======  ==========================================================

Anything else is an illegal data address (exception 2); a value beyond 0..1000 other than
0xFFFF is an illegal data value (exception 3) and changes nothing. The fingers move towards their
targets at ``speed * SPEED_TO_UNITS`` units/s (speed 1000 crosses the range in 0.8 s, the
emulator's choice). The mutable values are one :class:`HandState`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

from ...protocol import rtu
from ..core.interface import NOT_IDLE, ControllerView

HAND_SLAVE = 1
HAND_BAUD_INDEX = 5  # 115200 bps in the register 127 baud table
DOF = 6
KEEP = 0xFFFF
FULL = 1000

REG_ID = 1000
REG_CLEAR = 1004
ANGLE_SET = 1486
FORCE_SET = 1498
SPEED_SET = 1522
ANGLE_ACT = 1546
FORCE_ACT = 1582
ERROR = 1606
STATUS = 1612
SPEED_TO_UNITS = 1.25  # units/s per unit of speed

STATUS_OPENING, STATUS_CLOSING, STATUS_REACHED, STATUS_FAULT = 0, 1, 2, 7

#: address -> (field, access) of every register the hand answers.
REGISTER_MAP: dict[int, tuple[str, str]] = {
    REG_ID: ("hand_id", "r"), REG_CLEAR: ("clear_error", "w"),
    **{ANGLE_SET + 2 * i: (f"angle_set[{i}]", "rw") for i in range(DOF)},
    **{FORCE_SET + 2 * i: (f"force_set[{i}]", "rw") for i in range(DOF)},
    **{SPEED_SET + 2 * i: (f"speed_set[{i}]", "rw") for i in range(DOF)},
    **{ANGLE_ACT + 2 * i: (f"angle_act[{i}]", "r") for i in range(DOF)},
    **{FORCE_ACT + 2 * i: (f"force_act[{i}]", "r") for i in range(DOF)},
    **{ERROR + 2 * i: (f"error[{2 * i}:{2 * i + 2}]", "r") for i in range(DOF // 2)},
    **{STATUS + 2 * i: (f"status[{2 * i}:{2 * i + 2}]", "r") for i in range(DOF // 2)},
}
_BLOCKS = {ANGLE_SET: "angle_set", FORCE_SET: "force_set", SPEED_SET: "speed_set"}


@dataclass
class HandState:
    """Everything of the hand that changes: targets, limits, speeds, angles and fault bytes."""

    angle_set: list[int] = field(default_factory=lambda: [FULL] * DOF)
    force_set: list[int] = field(default_factory=lambda: [FULL] * DOF)
    speed_set: list[int] = field(default_factory=lambda: [FULL] * DOF)
    angle: list[float] = field(default_factory=lambda: [float(FULL)] * DOF)
    errors: list[int] = field(default_factory=lambda: [0] * DOF)


class InspireHand:
    """The RH56 hand as a tool-bus Modbus slave (:class:`~.gripper.ToolDevice`)."""

    slave_id = HAND_SLAVE

    def __init__(self, baud_index: int = HAND_BAUD_INDEX) -> None:
        self.baud_index = baud_index
        self.data = HandState()

    # --- ToolDevice -------------------------------------------------------------------------------
    @property
    def error(self) -> int:
        return max(self.data.errors)

    def inject_error(self, code: int) -> None:
        """Every finger reports error byte ``code`` and stops."""
        if not 1 <= code <= 0xFF:
            raise ValueError("an RH56 error byte is 1..255")
        self.data.errors = [code] * DOF

    def clear_error(self) -> None:
        self.data.errors = [0] * DOF

    def check_object(self, width_mm: float, inner: bool = False) -> None:
        raise ValueError("the emulated RH56 hand takes no object")

    def set_object(self, width_mm: float | None, inner: bool = False) -> None:
        if width_mm is not None:
            self.check_object(width_mm, inner)

    # --- registers --------------------------------------------------------------------------------
    def _status(self, i: int) -> int:
        st = self.data
        if st.errors[i]:
            return STATUS_FAULT
        if abs(st.angle[i] - st.angle_set[i]) < 1e-9:
            return STATUS_REACHED
        return STATUS_CLOSING if st.angle_set[i] < st.angle[i] else STATUS_OPENING

    def _value(self, addr: int) -> int:
        st = self.data
        if addr == REG_ID:
            return self.slave_id
        for base, name in _BLOCKS.items():
            if base <= addr < base + 2 * DOF and (addr - base) % 2 == 0:
                return int(getattr(st, name)[(addr - base) // 2])
        if ANGLE_ACT <= addr < ANGLE_ACT + 2 * DOF and (addr - ANGLE_ACT) % 2 == 0:
            return int(round(st.angle[(addr - ANGLE_ACT) // 2]))
        if FORCE_ACT <= addr < FORCE_ACT + 2 * DOF and (addr - FORCE_ACT) % 2 == 0:
            return 0
        if ERROR <= addr < ERROR + DOF and (addr - ERROR) % 2 == 0:
            i = addr - ERROR
            return st.errors[i] | st.errors[i + 1] << 8
        if STATUS <= addr < STATUS + DOF and (addr - STATUS) % 2 == 0:
            i = addr - STATUS
            return self._status(i) | self._status(i + 1) << 8
        raise rtu.RtuError(rtu.ILLEGAL_ADDRESS)

    def read_registers(self, address: int, count: int) -> list[int]:
        return [self._value(address + 2 * k) & 0xFFFF for k in range(count)]

    def write_registers(self, address: int, values: Sequence[int]) -> None:
        addrs = [address + 2 * k for k in range(len(values))]
        for a, v in zip(addrs, values, strict=True):  # check everything before changing anything
            access = REGISTER_MAP.get(a, ("", ""))[1]
            if "w" not in access:
                raise rtu.RtuError(rtu.ILLEGAL_ADDRESS)
            if a != REG_CLEAR and v != KEEP and not 0 <= v <= FULL:
                raise rtu.RtuError(rtu.ILLEGAL_VALUE)
        for a, v in zip(addrs, values, strict=True):
            if a == REG_CLEAR:
                if v == 1:
                    self.clear_error()
                continue
            for base, name in _BLOCKS.items():
                if base <= a < base + 2 * DOF and v != KEEP:
                    getattr(self.data, name)[(a - base) // 2] = v

    # --- motion -----------------------------------------------------------------------------------
    def idle_until(self, ctl: ControllerView) -> float:
        st = self.data
        moving = any(not st.errors[i] and st.angle[i] != st.angle_set[i] for i in range(DOF))
        return NOT_IDLE if moving else math.inf

    def step(self, dt: float) -> None:
        st = self.data
        for i in range(DOF):
            if st.errors[i]:
                continue
            delta = st.angle_set[i] - st.angle[i]
            max_step = st.speed_set[i] * SPEED_TO_UNITS * dt
            st.angle[i] = float(st.angle_set[i]) if abs(delta) <= max_step else \
                st.angle[i] + math.copysign(max_step, delta)
