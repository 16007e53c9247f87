"""UFACTORY's first-generation BIO gripper ("G1") on the tool RS-485 (register 124, host 9).

The SDK's ``*_bio_gripper*`` functions drive both generations as Modbus slave 8 at 2,000,000 bps
and tell them apart by the serial number: a G1 has none, so its read of 0x0B10 fails (the SDK's
reply-length error, code 23) and the SDK then takes the box for a G1. A G1 has no control modes,
no force setting, no separate present-position register and no one-shot move block; its open and
close are the targets 130 and 50 (the SDK's ``open_bio_gripper`` / ``close_bio_gripper`` and the C++
SDK send them), in the gripper's own position units, and 0x0700 reads back where the fingers are
(the SDK reads it there and takes more than 100 as open).

Registers (u16, big-endian); :data:`REGISTER_MAP` is the same table for code:

=========  ======  ==============================================================================
address    access  meaning
=========  ======  ==============================================================================
0x0000     r       status: bits 0-1 motion (0 stopped, 1 moving, 2 stopped on an object, 3 fault),
                   bits 2-3 enable (0 disabled, 1 enabling, 2 enabled)
0x000F     rw      error code (as the G2's); writing 0 clears it
0x0100     rw      enable (0/1)
0x0303     rw      speed, 1..4500
0x0700     rw      target (write) / present position (read), s32 in two registers, 50..130
=========  ======  ==============================================================================

Any other address is an illegal data address (exception 2). A target beyond 50..130 or a speed
beyond its range is an illegal data value (exception 3) and changes nothing. Motion, objects,
errors and enabling behave as the G2's (:mod:`.bio_gripper`); at the SDK's default speed (2000)
the fingers cross the stroke in about a second (:data:`SPEED_TO_UNITS`, the emulator's choice).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from ...protocol import rtu
from .bio_gripper import (
    ENABLE_OFF,
    REG_ENABLE,
    REG_ERROR,
    REG_SPEED,
    REG_STATUS,
    REG_TARGET,
    BioGripper,
)

OPEN = 130
CLOSED = 50
#: Position units per second per unit of speed: speed 2000 crosses the 80-unit stroke in 1 s.
SPEED_TO_UNITS = 0.04

#: address -> (field, access): the G1's registers as a plain table.
REGISTER_MAP: dict[int, tuple[str, str]] = {
    REG_STATUS: ("status", "r"),
    REG_ERROR: ("error", "rw"),
    REG_ENABLE: ("enable", "rw"),
    REG_SPEED: ("speed", "rw"),
    REG_TARGET: ("position_hi", "rw"),
    REG_TARGET + 1: ("position_lo", "rw"),
}


class BioGripperG1(BioGripper):
    """The first-generation BIO gripper: the G2's motion with the G1's register map and range."""

    object_range = (float(CLOSED), float(OPEN), "(position units)")

    def __init__(self) -> None:
        super().__init__()
        self.position = float(OPEN)
        self.goal = float(OPEN)
        self.target_raw = OPEN

    @property
    def opening_mm(self) -> float:
        """The position in the G1's own units (the public material gives no millimetre scale)."""
        return self.position

    def _goal_pulses(self, raw: int) -> float:
        if not CLOSED <= raw <= OPEN:
            raise rtu.RtuError(rtu.ILLEGAL_VALUE)
        return float(raw)

    def _getter(self, addr: int) -> Callable[[], int] | None:
        pos = rtu.s32_words(int(round(self.position)))
        table: dict[int, Callable[[], int]] = {
            REG_STATUS: lambda: self.status, REG_ERROR: lambda: self.code,
            REG_ENABLE: lambda: int(self.enable != ENABLE_OFF), REG_SPEED: lambda: self.speed,
            REG_TARGET: lambda: pos[0], REG_TARGET + 1: lambda: pos[1],
        }
        return table.get(addr)

    def write_registers(self, address: int, values: Sequence[int]) -> None:
        if address not in REGISTER_MAP or REGISTER_MAP[address][1] != "rw" or address == REG_TARGET + 1:
            raise rtu.RtuError(rtu.ILLEGAL_ADDRESS)
        if address == REG_TARGET and len(values) != 2:
            raise rtu.RtuError(rtu.ILLEGAL_ADDRESS)
        super().write_registers(address, values)

    def _object_position(self, width_mm: float) -> float:
        return float(width_mm)  # objects are given in the G1's own units

    def _rate(self) -> float:
        return self.speed * SPEED_TO_UNITS
