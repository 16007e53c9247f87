"""UFACTORY's BIO gripper (the second generation, "G2") on the tool RS-485 (register 124, host 9;
manual section 2.1.4 for the bridge).

The SDK's ``*_bio_gripper*`` functions address it as Modbus slave 8 at 2,000,000 bps, the xArm
gripper's slave id and baud rate (so only one of the two can be on the bus). Registers (u16,
big-endian), as the SDK reads and writes them:

=========  ======  ==============================================================================
address    access  meaning
=========  ======  ==============================================================================
0x0000     r       status: bits 0-1 motion (0 stopped, 1 moving, 2 stopped on an object, 3 fault),
                   bits 2-3 enable (0 disabled, 1 enabling, 2 enabled)
0x000F     rw      error code (11 current beyond limit, 12 object slipped); writing 0 clears it
0x0100     rw      enable (0/1)
0x010A     r       control mode (0 open/close mode, 1 position loop)
0x110A     w       control mode to use after the next reboot
0x0303     rw      speed, 1..4500
0x0506     rw      force, 1..100 (%)
0x0607     w       reboot (write 1): the written control mode takes effect, the motor disabled
0x0700     rw      target position, s32 in two registers, high word first
0x0702     r       current position, s32 in two registers (always pulses)
0x0801-3   r       firmware version major, minor, revision
0x0B10-1F  r       serial number, one ASCII character per register (the SDK decodes 14)
0x0C00-04  w       one move: [1, speed, force, position s32]
=========  ======  ==============================================================================

Units. The finger opening runs 71..150 mm; in pulses (what 0x0702 reports, and what the targets
mean in position-loop mode) that is ``mm * 3.7342 - 265.13``, 0..295, the SDK's own conversion. In
open/close mode (0) a target is the opening in mm, clamped to 71..150 by the SDK's callers (which
is how the SDK's open and close functions send 150 and 71 unconverted).

Refusals: a speed or force outside its range is answered with Modbus exception 3 (illegal data
value) and changes nothing; the SDK then reports a reply-length error (its code 23). A target
beyond the stroke (in either mode) is taken and clamped to the stroke's end, as a position drive
saturates at its soft limits: a program written for the first generation, whose close is 50 and
open 130 (:mod:`.bio_gripper_g1`), closes and opens a G2 fully instead of failing. A target that
is not a number the register can hold is still refused.
A target while the motor is disabled is accepted but does not move the fingers, so the SDK's wait
ends with "end effector not enabled" (its code 103), as a disabled gripper would.

Motion: the fingers move at ``speed * SPEED_TO_PULSES`` pulse/s (speed 2000, the SDK's default,
crosses the stroke in about a second), stop on an object placed between them (``set_object``,
played with ``set-input gripper-object``) with status 2, and an object that goes away while
gripped raises error 12 ("the object slipped"). Enabling takes :data:`ENABLE_TIME`. Durations,
version and serial number are the emulator's choices where the public material gives none.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

from ...protocol import codes, regmap, rtu
from ..core.controller_state import holds
from ..core.interface import NOT_IDLE, ControllerView

BIO_ID = 8
BIO_BAUD_INDEX = 11  # 2,000,000 bps, the SDK's default for the BIO gripper

REG_STATUS = 0x0000
REG_ERROR = 0x000F
REG_ENABLE = 0x0100
REG_MODE = 0x010A
REG_MODE_SET = 0x110A
REG_SPEED = 0x0303
REG_FORCE = 0x0506
REG_REBOOT = 0x0607
REG_TARGET = 0x0700
REG_POSITION = 0x0702
REG_VERSION = 0x0801
REG_SN = 0x0B10
SN_REGS = 16
REG_MOVE = 0x0C00
MOVE_REGS = 5

#: The SDK's conversion between the opening (mm) and position pulses: pulses = mm * A - B.
MM_TO_PULSE = 3.7342
PULSE_OFFSET = 265.13
OPEN_MM = 150.0
CLOSED_MM = 71.0
PULSE_MIN = 0
PULSE_MAX = int(round(OPEN_MM * MM_TO_PULSE - PULSE_OFFSET))  # 295

SPEED_MIN, SPEED_MAX = 1, 4500
FORCE_MIN, FORCE_MAX = 1, 100
DEFAULT_SPEED = 2000
DEFAULT_FORCE = 100
SPEED_TO_PULSES = 0.15  # pulse/s per unit of speed (emulator's choice)
ENABLE_TIME = 0.3  # s from the enable write to "enabled" (emulator's choice)

MOTION_STOPPED, MOTION_MOVING, MOTION_DETECTED, MOTION_FAULT = 0, 1, 2, 3
ENABLE_OFF, ENABLE_ENABLING, ENABLE_ON = 0, 1, 2
E_CURRENT = 11
E_SLIPPED = 12
ERRORS = frozenset(codes.BIO_GRIPPER_ERRORS)

VERSION = (2, 1, 3)
SERIAL = "BG2E0000000001"


def mm_to_pulses(mm: float) -> float:
    return mm * MM_TO_PULSE - PULSE_OFFSET


def pulses_to_mm(pulses: float) -> float:
    return (pulses + PULSE_OFFSET) / MM_TO_PULSE


def _refuse() -> rtu.RtuError:
    return rtu.RtuError(rtu.ILLEGAL_VALUE)


@dataclass(slots=True)
class BioGripperState:
    """Every mutable value of a BIO gripper (power-on values: :class:`BioGripper`)."""

    baud_index: int = 0
    mode: int = 0
    next_mode: int = 0
    enable: int = 0
    enable_left: float = 0.0
    speed: int = 0
    force: int = 0
    position: float = 0.0  # pulses
    goal: float = 0.0
    target_raw: int = 0
    moving: bool = False
    detected: bool = False
    code: int = 0
    object_mm: float | None = None


@holds(BioGripperState)
class BioGripper:
    """The simulated BIO gripper: a Modbus slave (:class:`rtu.RegisterDevice`) that moves in
    :meth:`step` (a :class:`~xarm_emu.controller.devices.gripper.ToolDevice`)."""

    slave_id = BIO_ID
    object_places: tuple[int, ...] = (0,)  # between the fingers only
    #: The registers this gripper answers (below the class; the G1 has its own).
    REGISTER_MAP: ClassVar[regmap.RegisterMap]

    def __init__(self, baud_index: int = BIO_BAUD_INDEX) -> None:
        self.data = BioGripperState()
        self.baud_index = baud_index
        self.mode = 0
        self.next_mode = 0
        self.enable = ENABLE_OFF
        self.enable_left = 0.0
        self.speed = DEFAULT_SPEED
        self.force = DEFAULT_FORCE
        self.position = float(PULSE_MAX)  # open
        self.goal = float(PULSE_MAX)
        self.target_raw = int(OPEN_MM)  # the target register as last written
        self.moving = False
        self.detected = False
        self.code = 0
        self.object_mm: float | None = None

    # --- derived values ----------------------------------------------------------------------------

    @property
    def error(self) -> int:
        return self.code

    @property
    def reported_error(self) -> int:
        """The SDK reads the errors over register 124 only: the box reports none (register 106)."""
        return 0

    def status_fields(self) -> dict[str, Any]:
        return {"enabled": self.enabled, "mode": self.mode, "opening_mm": round(self.opening_mm, 1),
                "object": self.detected}

    @property
    def enabled(self) -> bool:
        return self.enable == ENABLE_ON

    @property
    def opening_mm(self) -> float:
        return pulses_to_mm(self.position)

    @property
    def status(self) -> int:
        motion = (MOTION_FAULT if self.code else MOTION_MOVING if self.moving
                  else MOTION_DETECTED if self.detected else MOTION_STOPPED)
        return motion | (self.enable << 2)

    # --- faults and objects ------------------------------------------------------------------------

    def inject_error(self, code: int) -> None:
        """Error ``code`` (codes.BIO_GRIPPER_ERRORS): the fingers stop."""
        if code not in ERRORS:
            raise ValueError(f"BIO gripper error {code} is not one of {sorted(ERRORS)}")
        self.code = code
        self.moving = False

    def clear_error(self) -> None:
        self.code = 0

    #: The widths an object between the fingers can have, and their unit.
    object_range: tuple[float, float, str] = (CLOSED_MM, OPEN_MM, "mm")

    def check_object(self, width_mm: float, inner: bool = False) -> None:
        """Raise ValueError unless an object of ``width_mm`` fits between the fingers."""
        if inner:
            raise ValueError("the BIO gripper grips between its fingers only (index 0)")
        lo, hi, unit = self.object_range
        if not lo <= width_mm <= hi:
            raise ValueError(f"object width {width_mm:g} {unit}: the BIO gripper opens {lo:g}..{hi:g} {unit}")

    def set_object(self, width_mm: float | None, inner: bool = False) -> None:
        """Put an object of ``width_mm`` between the fingers; ``None`` takes it away (a gripped one
        slips out: error 12)."""
        if width_mm is not None:
            self.check_object(width_mm, inner)
        self.object_mm = width_mm
        if self.detected and width_mm is None:
            self.detected = False
            self.inject_error(E_SLIPPED)

    def driven_fingers(self, force: float) -> BioFingers | None:
        """Its fingers as the physics twin drives them, ``force`` the most each pad presses with (N)."""
        return BioFingers(self, force)

    def twin_fingers(self) -> None:
        """None: its own model moves its fingers (:meth:`driven_fingers`)."""
        return None

    # --- commands ----------------------------------------------------------------------------------

    def _set_enable(self, on: int) -> None:
        """Register 0x0100 (0 or 1, the map checks): enabling takes :data:`ENABLE_TIME`."""
        if on and self.enable == ENABLE_OFF:
            self.enable, self.enable_left = ENABLE_ENABLING, ENABLE_TIME
        elif not on:
            self.enable = ENABLE_OFF
            self.moving = False

    def _goal_pulses(self, raw: int) -> float:
        """The goal (pulses) of target ``raw``, clamped to the stroke (module docstring)."""
        if self.mode == 1:
            return float(min(max(raw, PULSE_MIN), PULSE_MAX))
        return min(max(mm_to_pulses(min(max(raw, CLOSED_MM), OPEN_MM)), PULSE_MIN), PULSE_MAX)

    def _move(self, raw: int) -> None:
        goal = self._goal_pulses(raw)
        self.target_raw = raw
        if not self.enabled or self.code:
            return  # accepted; an unpowered or faulted motor does not follow
        self.goal = goal
        self.detected = False
        self.moving = True

    def _reboot(self) -> None:
        self.mode = self.next_mode
        self.enable = ENABLE_OFF
        self.moving = self.detected = False

    # --- Modbus slave ------------------------------------------------------------------------------

    def read_registers(self, address: int, count: int) -> list[int]:
        return regmap.read_registers(self.REGISTER_MAP, self, address, count)

    def write_registers(self, address: int, values: Sequence[int]) -> None:
        regmap.write_registers(self.REGISTER_MAP, self, address, values)

    # --- motion ------------------------------------------------------------------------------------

    def _object_position(self, width_mm: float) -> float:
        """Where the fingers touch an object of ``width_mm``, in position units (pulses)."""
        return mm_to_pulses(width_mm)

    def _rate(self) -> float:
        """Finger speed in position units per second."""
        return self.speed * SPEED_TO_PULSES

    def idle_until(self, ctl: ControllerView) -> float:
        """Idle (:func:`~..core.interface.idle_until`) while the motor is not being enabled and the fingers do
        not move: then :meth:`step` changes nothing until a command, an object or an error comes."""
        return NOT_IDLE if self.enable == ENABLE_ENABLING or self.moving else math.inf

    def step(self, dt: float, ctl: ControllerView) -> None:
        if self.enable == ENABLE_ENABLING:
            self.enable_left -= dt
            if self.enable_left <= 1e-9:
                self.enable = ENABLE_ON
            return
        if not self.moving:
            return
        stop, contact = self.goal, False
        if self.object_mm is not None and self.goal < self.position:  # closing onto the object
            at = self._object_position(self.object_mm)
            if self.position >= at - 1e-9 and self.goal <= at:
                stop, contact = at, True
        delta = stop - self.position
        max_step = self._rate() * dt
        if abs(delta) > max_step:
            self.position += max_step if delta > 0 else -max_step
            return
        self.position = stop
        self.moving = False
        self.detected = contact

    def _write_move(self, values: tuple[int, ...]) -> None:
        """The one-shot move block (0x0C00, five registers): op 1, speed, force, target (s32); every
        value is checked before anything changes."""
        op, speed, force, hi, lo = values
        if op != 1:
            raise _refuse()
        self._goal_pulses(rtu.words_s32(hi, lo))  # check everything before changing anything
        if not (SPEED_MIN <= speed <= SPEED_MAX and FORCE_MIN <= force <= FORCE_MAX):
            raise _refuse()
        self.speed, self.force = speed, force
        self._move(rtu.words_s32(hi, lo))

    def _write_target(self, words: tuple[int, ...]) -> None:
        """The target (0x0700, both registers at once)."""
        self._move(rtu.words_s32(*words))

    def _reboot_on_one(self, value: int) -> None:
        if value == 1:
            self._reboot()

    def _clear_on_zero(self, value: int) -> None:
        self.clear_error()  # the map accepts 0 only

    def _enable_read(self) -> int:
        return int(self.enable != ENABLE_OFF)


#: The BIO gripper's registers (module docstring): a write that covers any other address, or only part
#: of the target or the move block, is exception 2; a value outside a range is exception 3.
REGISTER_MAP: dict[int, regmap.Reg] = {
    REG_STATUS: regmap.Reg("status"),
    REG_ERROR: regmap.Reg("code", "rw", put=BioGripper._clear_on_zero, range=(0, 0)),
    REG_ENABLE: regmap.Reg("enable", "rw", get=BioGripper._enable_read, put=BioGripper._set_enable,
                           range=(0, 1)),
    REG_MODE: regmap.Reg("mode"),
    REG_MODE_SET: regmap.Reg("next_mode", "w", range=(0, 1)),
    REG_SPEED: regmap.Reg("speed", "rw", range=(SPEED_MIN, SPEED_MAX)),
    REG_FORCE: regmap.Reg("force", "rw", range=(FORCE_MIN, FORCE_MAX)),
    REG_REBOOT: regmap.Reg("reboot", "w", put=BioGripper._reboot_on_one),
    **regmap.s32(REG_TARGET, "target_raw", access="rw", put=BioGripper._write_target, whole=True),
    **regmap.s32(REG_POSITION, "position", unit="pulse"),
    **regmap.constants(REG_VERSION, "version", VERSION),
    **regmap.constants(REG_SN, "serial", [ord(c) for c in SERIAL] + [0] * (SN_REGS - len(SERIAL))),
    REG_MOVE: regmap.Reg("move", "w", put=BioGripper._write_move, block=MOVE_REGS),
}
BioGripper.REGISTER_MAP = REGISTER_MAP


class BioFingers:
    """The BIO gripper's fingers as the physics twin drives them (``DrivenFingers`` of
    controller/devices/gripper.py): they open over the gripper's :attr:`~BioGripper.object_range`
    (71..150 mm; the G1's 50..130 positions, one a millimetre), positions count up as they open; the
    force register (1..100) scales the most the twin's pads press with, where the gripper has one
    (``scaled``; the G1 has no force setting and presses with the most)."""

    def __init__(self, b: BioGripper, most: float, scaled: bool = True) -> None:
        self.b = b
        self.most = most
        self.scaled = scaled

    @property
    def opening(self) -> float:
        return self.b.opening_mm

    @property
    def closing(self) -> bool:
        return self.b.moving and self.b.goal < self.b.position

    @property
    def gripping(self) -> bool:
        return self.b.detected and not self.b.code

    @property
    def force(self) -> float:
        return self.most * self.b.force / FORCE_MAX if self.scaled else self.most

    @property
    def met(self) -> bool:
        return self.b.object_mm is not None

    def meet(self, width: float) -> None:
        b = self.b
        lo, hi, _ = b.object_range
        width = min(max(width, lo), hi)
        b.set_object(width)
        b.position = max(b.position, b._object_position(width))  # the fingers stopped where they met it

    def part(self, touching: bool) -> None:
        b = self.b
        if b.object_mm is not None and not touching and not b.detected and not self.closing:
            b.object_mm = None  # opening away from it: nothing between the fingers any more
