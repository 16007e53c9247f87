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

import functools
import math
import operator
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar

from ...protocol import regmap
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
    REGISTER_MAP: ClassVar[regmap.RegisterMap]  # below the class
    object_places: tuple[int, ...] = ()  # the emulated hand takes no object

    def __init__(self, baud_index: int = HAND_BAUD_INDEX) -> None:
        self.baud_index = baud_index
        self.data = HandState()

    # --- ToolDevice -------------------------------------------------------------------------------
    @property
    def error(self) -> int:
        return max(self.data.errors)

    @property
    def reported_error(self) -> int:
        """The SDK reads the error bytes over register 124 only: the box reports none (register 106)."""
        return 0

    def status_fields(self) -> dict[str, Any]:
        return {"angles": [int(round(a)) for a in self.data.angle]}

    def inject_error(self, code: int) -> None:
        """Every finger reports error byte ``code`` and stops."""
        if not 1 <= code <= 0xFF:
            raise ValueError("an RH56 error byte is 1..255")
        self.data.errors = [code] * DOF

    def clear_error(self) -> None:
        self.data.errors = [0] * DOF

    def check_object(self, width_mm: float, inner: bool = False) -> None:
        raise ValueError("the emulated RH56 hand takes no object")

    def driven_fingers(self, force: float) -> None:
        """None: the hand is no body of the physics twin."""
        return None

    def twin_fingers(self) -> None:
        """None: the hand is no body of the physics twin."""
        return None

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

    def read_registers(self, address: int, count: int) -> list[int]:
        return regmap.read_registers(REGISTER_MAP, self, address, count, stride=2)

    def write_registers(self, address: int, values: Sequence[int]) -> None:
        regmap.write_registers(REGISTER_MAP, self, address, values, stride=2, atomic=True)

    # --- motion -----------------------------------------------------------------------------------
    def idle_until(self, ctl: ControllerView) -> float:
        st = self.data
        moving = any(not st.errors[i] and st.angle[i] != st.angle_set[i] for i in range(DOF))
        return NOT_IDLE if moving else math.inf

    def step(self, dt: float, ctl: ControllerView) -> None:
        st = self.data
        for i in range(DOF):
            if st.errors[i]:
                continue
            delta = st.angle_set[i] - st.angle[i]
            max_step = st.speed_set[i] * SPEED_TO_UNITS * dt
            st.angle[i] = float(st.angle_set[i]) if abs(delta) <= max_step else \
                st.angle[i] + math.copysign(max_step, delta)


# --- the hand's registers ----------------------------------------------------------------------------


def _clear_on_one(hand: InspireHand, value: int) -> None:
    if value == 1:
        hand.clear_error()


def _angle(hand: InspireHand, *, index: int) -> int:
    return int(round(hand.data.angle[index]))


def _no_force(hand: InspireHand, *, index: int) -> int:
    return 0  # no object: no grip force


def _error_pair(hand: InspireHand, *, index: int) -> int:
    errors = hand.data.errors
    return errors[index] | errors[index + 1] << 8


def _status_pair(hand: InspireHand, *, index: int) -> int:
    return hand._status(index) | hand._status(index + 1) << 8


def _fingers(address: int, field: str, get: Callable[..., int], count: int = DOF,
             step: int = 1) -> dict[int, regmap.Reg]:
    """Read-only registers, one per finger (or per pair of fingers, ``step`` 2), two addresses apart."""
    return {address + 2 * k: regmap.Reg(f"{field}[{k * step}]", get=functools.partial(get, index=k * step))
            for k in range(count)}


#: Every register the hand answers (the table of the module docstring); the map numbers bytes, so
#: registers are two addresses apart. Targets, force limits and speeds take 0..1000, or 0xFFFF to
#: keep the value.
REGISTER_MAP: dict[int, regmap.Reg] = {
    REG_ID: regmap.Reg("hand_id", get=operator.attrgetter("slave_id")),
    REG_CLEAR: regmap.Reg("clear_error", "w", put=_clear_on_one),
    **regmap.items(ANGLE_SET, "data.angle_set", DOF, access="rw", stride=2, range=(0, FULL), keep=KEEP),
    **regmap.items(FORCE_SET, "data.force_set", DOF, access="rw", stride=2, range=(0, FULL), keep=KEEP),
    **regmap.items(SPEED_SET, "data.speed_set", DOF, access="rw", stride=2, range=(0, FULL), keep=KEEP),
    **_fingers(ANGLE_ACT, "angle_act", _angle),
    **_fingers(FORCE_ACT, "force_act", _no_force),
    **_fingers(ERROR, "error", _error_pair, DOF // 2, 2),
    **_fingers(STATUS, "status", _status_pair, DOF // 2, 2),
}
InspireHand.REGISTER_MAP = REGISTER_MAP
