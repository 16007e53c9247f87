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

from ...protocol import regmap, rtu
from .bio_gripper import (
    REG_ENABLE,
    REG_ERROR,
    REG_SPEED,
    REG_STATUS,
    REG_TARGET,
    SPEED_MAX,
    SPEED_MIN,
    BioFingers,
    BioGripper,
)

OPEN = 130
CLOSED = 50
#: Position units per second per unit of speed: speed 2000 crosses the 80-unit stroke in 1 s.
SPEED_TO_UNITS = 0.04


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

    def _object_position(self, width_mm: float) -> float:
        return float(width_mm)  # objects are given in the G1's own units

    def _rate(self) -> float:
        return self.speed * SPEED_TO_UNITS

    def driven_fingers(self, force: float) -> BioFingers:
        """Its fingers as the physics twin drives them: one position unit taken as a millimetre (the
        opening this model reports, ``opening_mm``), always at ``force`` (no force setting)."""
        return BioFingers(self, force, scaled=False)


#: The G1's registers (the table of the module docstring): 0x0700 takes the target, both registers
#: at once, and reads back the present position.
REGISTER_MAP: dict[int, regmap.Reg] = {
    REG_STATUS: regmap.Reg("status"),
    REG_ERROR: regmap.Reg("code", "rw", put=BioGripper._clear_on_zero, range=(0, 0)),
    REG_ENABLE: regmap.Reg("enable", "rw", get=BioGripper._enable_read, put=BioGripper._set_enable,
                           range=(0, 1)),
    REG_SPEED: regmap.Reg("speed", "rw", range=(SPEED_MIN, SPEED_MAX)),
    **regmap.s32(REG_TARGET, "position", access="rw", put=BioGripper._write_target, whole=True),
}
BioGripperG1.REGISTER_MAP = REGISTER_MAP
