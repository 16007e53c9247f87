"""The Robotiq 2F-85 and 2F-140 adaptive grippers on the tool RS-485 (register 124, host 9; manual
section 2.1.4 for the bridge).

The SDK's ``robotiq_*`` functions talk to the gripper as Modbus slave 9 at 115200 bps (the SDK
switches the tool bus to that baud rate first), with Robotiq's register map:

=========  ==========================================================================================
address    meaning (each register holds two bytes, high byte first)
=========  ==========================================================================================
0x03E8-EA  robot output, written with 0x10: byte 0 ACTION REQUEST (rACT bit 0 activates, rGTO bit 3
           goes to the requested position, rATR bit 4 automatic release), bytes 1-2 reserved,
           byte 3 rPR position request (0 open .. 255 closed), byte 4 rSP speed, byte 5 rFR force
0x07D0-D2  robot input, read with 0x03: byte 0 GRIPPER STATUS (gACT bit 0, gGTO bit 3, gSTA bits
           4-5: 0 reset, 1 activating, 3 activated; gOBJ bits 6-7: 0 moving, 1 stopped by a contact
           while opening, 2 stopped by a contact while closing, 3 at the requested position),
           byte 1 reserved, byte 2 FAULT STATUS (gFLT low nibble, kFLT high nibble), byte 3 gPR
           echo, byte 4 gPO position, byte 5 gCU current (about 10 mA per count)
=========  ==========================================================================================

The SDK's ``robotiq_reset`` writes all zeros (rACT cleared: reset, faults cleared),
``robotiq_set_activate`` writes rACT and polls gSTA until 3, ``robotiq_set_position`` writes
rACT | rGTO with position, speed and force and polls until gOBJ is 1, 2 or 3 (any gFLT except 5 during
an activation ends the wait with "end effector has fault").

Behaviour, from Robotiq's instruction manual and its public notes:

- activation (rACT rising) calibrates the stroke: gSTA 1 for :attr:`RobotiqModel.activation_s`,
  then 3, the fingers ending open; after it the encoder reads about 3 open and 230 closed
  (:data:`PO_OPEN`, :data:`PO_CLOSED`), not 0 and 255;
- a motion request before the activation completes raises minor fault 5 and runs once it does;
  one with rACT cleared raises fault 7;
- the fingers move at the speed rSP maps linearly onto the model's closing speed range, and stop on
  an object (``set_object``, played with ``set-input gripper-object``): gOBJ 2 while closing, 1 while
  opening onto an inner object, gPO the position where they stopped; the grip force is rFR mapped
  onto the model's force range;
- an object that goes away while gripped lets the fingers carry on to the request (gOBJ 3: "object
  lost or dropped").

Durations, currents and the calibration's end position are the emulator's choices where the public
material gives none.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar

from ...protocol import codes, regmap
from ..core.controller_state import holds
from ..core.interface import NOT_IDLE, ControllerView

ROBOTIQ_ID = 9
ROBOTIQ_BAUD_INDEX = 5  # 115200 bps in the register 127 baud table, the SDK's default for Robotiq

REG_OUTPUT = 0x03E8
REG_INPUT = 0x07D0
N_REGS = 8  # 16 bytes each side; bytes 6-15 are reserved

#: Encoder counts after the activation's calibration: fully open and fully closed (fingers touching).
PO_OPEN = 3
PO_CLOSED = 230

#: gCU counts (about 10 mA each) while moving, and per unit of rFR while gripping (emulator's choice).
CURRENT_MOVING = 10
CURRENT_PER_FORCE = 0.6

OBJ_MOVING, OBJ_OPENING_CONTACT, OBJ_CLOSING_CONTACT, OBJ_AT_POSITION = 0, 1, 2, 3
STA_RESET, STA_ACTIVATING, STA_ACTIVATED = 0, 1, 3
FLT_ACTION_DELAYED = 0x05
FLT_NOT_ACTIVATED = 0x07
#: Every fault code the gripper reports (protocol/codes.py).
FAULTS = frozenset(codes.ROBOTIQ_FAULTS)


@dataclass(frozen=True)
class RobotiqModel:
    """One Robotiq 2-finger model: its stroke, its speed and force ranges (Robotiq's specifications)
    and how long its activation takes (the emulator's choice)."""

    name: str
    stroke_mm: float
    speed_min: float  # mm/s at rSP 0
    speed_max: float  # mm/s at rSP 255
    force_min: float  # N at rFR 0
    force_max: float  # N at rFR 255
    activation_s: float


ROBOTIQ_2F85 = RobotiqModel("2F-85", 85.0, 20.0, 150.0, 20.0, 235.0, 1.5)
ROBOTIQ_2F140 = RobotiqModel("2F-140", 140.0, 30.0, 250.0, 10.0, 125.0, 2.0)
MODELS = {"robotiq-2f85": ROBOTIQ_2F85, "robotiq-2f140": ROBOTIQ_2F140}


@dataclass(slots=True)
class RobotiqState:
    """Every mutable value of a Robotiq 2F gripper (power-on values: :class:`RobotiqGripper`)."""

    baud_index: int = 0
    output: list[int] = field(default_factory=list)
    gACT: int = 0
    gSTA: int = 0
    gGTO: int = 0
    gOBJ: int = 0
    fault: int = 0
    position: float = 0.0  # encoder counts
    goal: float = 0.0
    moving: bool = False
    activation_left: float = 0.0
    pending_goto: bool = False
    object_mm: float | None = None
    inner_object_mm: float | None = None
    gripping: bool = False


@holds(RobotiqState)
class RobotiqGripper:
    """The simulated Robotiq 2F gripper: a Modbus slave (:class:`rtu.RegisterDevice`) that moves in
    :meth:`step` (a :class:`~xarm_emu.controller.devices.gripper.ToolDevice`)."""

    slave_id = ROBOTIQ_ID
    REGISTER_MAP: ClassVar[regmap.RegisterMap]  # below the class
    object_places: tuple[int, ...] = (0, 1)  # between the fingers, or around them (internal grip)

    def __init__(self, model: RobotiqModel = ROBOTIQ_2F85, baud_index: int = ROBOTIQ_BAUD_INDEX) -> None:
        self.data = RobotiqState()
        self.model = model
        self.baud_index = baud_index
        self.output = [0] * (2 * N_REGS)  # robot output bytes as last written
        self.gACT = 0
        self.gSTA = STA_RESET
        self.gGTO = 0
        self.gOBJ = OBJ_MOVING
        self.fault = 0
        self.position = float(PO_OPEN)  # encoder counts
        self.goal = float(PO_OPEN)  # where the fingers are heading (the request, clamped)
        self.moving = False
        self.activation_left = 0.0
        self.pending_goto = False  # a request that waits for the activation to complete
        self.object_mm: float | None = None  # an object between the fingers (its width)
        self.inner_object_mm: float | None = None  # an object around the fingers (internal grip)
        self.gripping = False

    # --- derived values ----------------------------------------------------------------------------

    @property
    def mm_per_count(self) -> float:
        return self.model.stroke_mm / (PO_CLOSED - PO_OPEN)

    @property
    def opening_mm(self) -> float:
        """The distance between the fingers, mm."""
        return max(0.0, self.model.stroke_mm - (self.position - PO_OPEN) * self.mm_per_count)

    def _counts_at(self, opening_mm: float) -> float:
        return PO_OPEN + (self.model.stroke_mm - opening_mm) / self.mm_per_count

    @property
    def rPR(self) -> int:
        return self.output[3]

    @property
    def rSP(self) -> int:
        return self.output[4]

    @property
    def rFR(self) -> int:
        return self.output[5]

    @property
    def speed_mm_s(self) -> float:
        m = self.model
        return m.speed_min + (m.speed_max - m.speed_min) * self.rSP / 255.0

    @property
    def grip_force(self) -> float:
        """The force (N) on a gripped object, 0 when nothing is gripped."""
        m = self.model
        return m.force_min + (m.force_max - m.force_min) * self.rFR / 255.0 if self.gripping else 0.0

    @property
    def current(self) -> int:
        if self.gripping:
            return min(255, round(CURRENT_MOVING + CURRENT_PER_FORCE * self.rFR))
        return CURRENT_MOVING if self.moving else 0

    @property
    def error(self) -> int:
        return self.fault

    @property
    def reported_error(self) -> int:
        """The SDK reads the faults over register 124 only: the box reports none (register 106)."""
        return 0

    def status_fields(self) -> dict[str, Any]:
        return {"activated": self.gSTA == STA_ACTIVATED, "position": int(round(self.position)),
                "opening_mm": round(self.opening_mm, 1), "object": self.gOBJ in (1, 2),
                "force_n": round(self.grip_force, 1)}

    @property
    def status_bytes(self) -> list[int]:
        """The 16 robot input bytes (registers 0x07D0-0x07D7)."""
        status = self.gACT | (self.gGTO << 3) | (self.gSTA << 4) | (self.gOBJ << 6)
        out = [status, 0, self.fault & 0x0F, self.rPR, int(round(self.position)) & 0xFF, self.current]
        return out + [0] * (2 * N_REGS - len(out))

    # --- faults and objects ------------------------------------------------------------------------

    def inject_error(self, code: int) -> None:
        """A fault gFLT ``code`` (codes.ROBOTIQ_FAULTS): the fingers stop."""
        if code not in FAULTS:
            raise ValueError(f"Robotiq fault {code} is not one of {sorted(FAULTS)}")
        self.fault = code
        self.moving = False
        self.pending_goto = False

    def clear_error(self) -> None:
        self.fault = 0

    def check_object(self, width_mm: float, inner: bool = False) -> None:
        """Raise ValueError unless an object of ``width_mm`` fits between the fingers."""
        if not 0.0 < width_mm <= self.model.stroke_mm:
            raise ValueError(f"object width {width_mm:g} mm: the {self.model.name} opens "
                             f"0..{self.model.stroke_mm:g} mm")

    def set_object(self, width_mm: float | None, inner: bool = False) -> None:
        """Put an object of ``width_mm`` between the fingers (``inner``: around them, gripped by
        opening); ``None`` takes it away."""
        if width_mm is not None:
            self.check_object(width_mm, inner)
        if inner:
            self.inner_object_mm = width_mm
        else:
            self.object_mm = width_mm
        if self.gripping:  # the gripped object changed or went away: carry on toward the request
            self.gripping = False
            self.moving = True
            self.gOBJ = OBJ_MOVING

    def driven_fingers(self, force: float) -> RobotiqFingers:
        """Its fingers as the physics twin drives them (their force is its own rFR's)."""
        return RobotiqFingers(self)

    def twin_fingers(self) -> None:
        """None: its own model moves its fingers (:meth:`driven_fingers`)."""
        return None

    # --- commands ----------------------------------------------------------------------------------

    def _apply_action(self) -> None:
        action = self.output[0]
        rACT, rGTO = action & 0x01, (action >> 3) & 0x01
        if not rACT:
            self.gACT, self.gSTA, self.gGTO, self.gOBJ = 0, STA_RESET, 0, OBJ_MOVING
            self.fault = 0
            self.moving = self.gripping = self.pending_goto = False
            self.activation_left = 0.0
            if rGTO:
                self.fault = FLT_NOT_ACTIVATED
            return
        if not self.gACT:
            self.gACT, self.gSTA = 1, STA_ACTIVATING
            self.activation_left = self.model.activation_s
            self.moving = self.gripping = False
        self.gGTO = rGTO
        if not rGTO:
            self.moving = self.pending_goto = False
            return
        if self.gSTA != STA_ACTIVATED:
            self.pending_goto = True
            self.fault = FLT_ACTION_DELAYED
            return
        self._go()

    def _go(self) -> None:
        """Start a motion to the position request."""
        if self.fault and self.fault != FLT_ACTION_DELAYED:
            return  # a fault holds the fingers until a reset
        self.fault = 0
        self.goal = float(min(max(self.rPR, PO_OPEN), PO_CLOSED))
        self.gripping = False
        self.gOBJ = OBJ_MOVING
        self.moving = True

    # --- Modbus slave ------------------------------------------------------------------------------

    def read_registers(self, address: int, count: int) -> list[int]:
        return regmap.read_registers(REGISTER_MAP, self, address, count)

    def write_registers(self, address: int, values: Sequence[int]) -> None:
        regmap.write_registers(REGISTER_MAP, self, address, values)

    # --- motion ------------------------------------------------------------------------------------

    def _contact(self, closing: bool) -> float | None:
        """Where (counts) the fingers meet the object on their way, or None."""
        if closing and self.object_mm is not None and self.opening_mm >= self.object_mm - 1e-9:
            return self._counts_at(self.object_mm)
        inner = self.inner_object_mm
        if not closing and inner is not None and self.opening_mm <= inner + 1e-9:
            return self._counts_at(inner)
        return None

    def idle_until(self, ctl: ControllerView) -> float:
        """Idle (:func:`~..core.interface.idle_until`) while neither the activation runs nor the fingers move:
        then :meth:`step` changes nothing until a request, an object or a fault comes from outside."""
        return NOT_IDLE if self.gSTA == STA_ACTIVATING or self.moving else math.inf

    def step(self, dt: float, ctl: ControllerView) -> None:
        if self.gSTA == STA_ACTIVATING:
            self.activation_left -= dt
            if self.activation_left <= 1e-9:
                self.gSTA = STA_ACTIVATED
                self.position = self.goal = float(PO_OPEN)
                if self.pending_goto:
                    self.pending_goto = False
                    self._go()
                elif self.fault == FLT_ACTION_DELAYED:
                    self.fault = 0
            return
        if not self.moving:
            return
        closing = self.goal > self.position
        stop = self.goal
        contact = self._contact(closing)
        if contact is not None and (contact <= self.goal if closing else contact >= self.goal):
            stop = contact
        else:
            contact = None
        max_step = self.speed_mm_s / self.mm_per_count * dt
        delta = stop - self.position
        if abs(delta) > max_step:
            self.position += max_step if delta > 0 else -max_step
            return
        self.position = stop
        self.moving = False
        if contact is None:
            self.gOBJ = OBJ_AT_POSITION
        else:
            self.gripping = True
            self.gOBJ = OBJ_CLOSING_CONTACT if closing else OBJ_OPENING_CONTACT


# --- the gripper's registers -------------------------------------------------------------------------


def _bytes(r: RobotiqGripper, *, block: str, index: int) -> int:
    """Register ``index`` of the output or input block: two bytes, high byte first."""
    data = r.output if block == "output" else r.status_bytes
    return (data[2 * index] << 8) | data[2 * index + 1]


def _put_bytes(r: RobotiqGripper, value: int, *, index: int) -> None:
    r.output[2 * index], r.output[2 * index + 1] = (value >> 8) & 0xFF, value & 0xFF


#: Robot output (0x03E8-, written and read back) and robot input (0x07D0-, read), two bytes a register
#: (module docstring). A write that starts at the ACTION REQUEST register applies it afterwards.
REGISTER_MAP: dict[int, regmap.Reg] = {
    **{REG_OUTPUT + i: regmap.Reg(f"output[{2 * i}:{2 * i + 2}]", "rw",
                                  get=functools.partial(_bytes, block="output", index=i),
                                  put=functools.partial(_put_bytes, index=i),
                                  commit=RobotiqGripper._apply_action if i == 0 else None)
       for i in range(N_REGS)},
    **{REG_INPUT + i: regmap.Reg(f"input[{2 * i}:{2 * i + 2}]",
                                 get=functools.partial(_bytes, block="input", index=i))
       for i in range(N_REGS)},
}
RobotiqGripper.REGISTER_MAP = REGISTER_MAP


class RobotiqFingers:
    """The 2F-85's or 2F-140's fingers as the physics twin drives them (``DrivenFingers`` of
    controller/devices/gripper.py): force from rFR over the model's range; positions count up as the
    fingers close."""

    def __init__(self, r: RobotiqGripper) -> None:
        self.r = r

    @property
    def opening(self) -> float:
        return self.r.opening_mm

    @property
    def closing(self) -> bool:
        return self.r.moving and self.r.goal > self.r.position

    @property
    def gripping(self) -> bool:
        return self.r.gripping

    @property
    def force(self) -> float:
        m = self.r.model
        return m.force_min + (m.force_max - m.force_min) * self.r.rFR / 255.0

    @property
    def met(self) -> bool:
        return self.r.object_mm is not None

    def meet(self, width: float) -> None:
        r = self.r
        width = min(width, r.model.stroke_mm)
        r.set_object(width)
        r.position = min(r.position, r._counts_at(width))  # the fingers stopped where they met it

    def part(self, touching: bool) -> None:
        r = self.r
        if r.object_mm is not None and not touching and not r.gripping and r.gOBJ == OBJ_MOVING:
            r.object_mm = None  # opening away from it: nothing between the fingers any more
