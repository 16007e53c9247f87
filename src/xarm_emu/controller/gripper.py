"""The xArm Gripper on the tool RS-485 (manual section 2.1.4, register 124; gripper codes 3.3).

Register 124 tunnels ``[host id][Modbus-RTU PDU]``; host 9 is the tool RS-485,
where the gripper answers as slave 8. Gripper registers (u16, big-endian):

=========  ======  ====================================================
address    access  meaning
=========  ======  ====================================================
0x0000     r       status: bits 0-1 motion (0 stopped, 1 moving, 3 fault),
                   bits 2-3 enable (0 disabled, 2 enabled)
0x000F     r       error code (section 3.3, 0 = none)
0x0100     rw      enable (0/1)
0x0101     rw      mode (0 position, 1 speed; only position mode moves)
0x0109     w       error clear (write 1)
0x0303     rw      speed, r/min, 1..5000
0x0700     rw      target position, s32 in two registers, high word first
0x0702     r       current position, s32 in two registers
0x0801-3   r       firmware version major, minor, revision
0x0817     w       set the current position as zero (write 1)
=========  ======  ====================================================

Speed mapping: the SDK's speed is in r/min (1..5000); the emulated fingers move
at ``SPEED_TO_PULSES = 0.17`` pulse/s per r/min, so speed 5000 crosses the full
0..850 range in 1.0 s (and the manual's example speed 1500 in 3.33 s).

Refusals (section 3.3 codes; any gripper error stops and disables the motor, as
"re-enable the Gripper" in the manual's handling column implies):

- target position outside 0..850: G25 "Command Over Software Limit";
- speed outside 1..5000: G12 "Speed Overlimit";
- target position while disabled: G23 "Large Motor Position Deviation" (the
  unpowered motor cannot follow the command).

Erratum: the manual's "Set the gripper position" example carries 400 as the fp32
``00 00 C8 43``; the SDK, which drives real grippers, sends an s32 big-endian
(``00 00 01 90``). The emulator follows the SDK, so the manual's bytes read as
51267 and give G25. The manual's "Get the gripper position" example shows
function code 0x10 without data, a malformed write; the SDK reads with 0x03.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from ..protocol import codes, rtu
from ..protocol.rtu import CONTROL_BOX_HOST, TOOL_HOST
from .base import ControllerView, Handler, ParameterError

GRIPPER_ID = 8  # section 2.1.4 "Gripper ID 0x08"
GRIPPER_BAUD_INDEX = 11  # 2,000,000 bps (register 127 baud table)

POS_MIN = 0
POS_MAX = 850
SPEED_MIN = 1
SPEED_MAX = 5000
SPEED_TO_PULSES = POS_MAX / SPEED_MAX  # pulse/s per r/min: 0.17
#: Speed after power-on (r/min), the manual's example speed: a position command sent without a
#: speed first (the SDK's ``set_gripper_position(pos)``) moves the fingers instead of doing nothing.
DEFAULT_SPEED = 1500

# Register addresses.
REG_STATUS = 0x0000
REG_ERROR = 0x000F
REG_ENABLE = 0x0100
REG_MODE = 0x0101
REG_CLEAR = 0x0109
REG_SPEED = 0x0303
REG_TARGET = 0x0700
REG_POSITION = 0x0702
REG_VERSION = 0x0801
REG_ZERO = 0x0817

# Gripper error codes, manual section 3.3.
G_CURRENT_DETECTION = 0x09
G_CURRENT_OVERLIMIT = 0x0B
G_SPEED_OVERLIMIT = 0x0C
G_POSITION_COMMAND_OVERLIMIT = 0x0E
G_EEPROM = 0x0F
G_DRIVER_IC_HARDWARE = 0x14
G_DRIVER_IC_INIT = 0x15
G_POSITION_DEVIATION = 0x17
G_SOFT_LIMIT = 0x19
G_FEEDBACK_SOFT_LIMIT = 0x1A
G_DRIVE_OVERLOADED = 0x21
G_MOTOR_OVERLOAD = 0x22
G_DRIVER_TYPE = 0x24
#: Every gripper error code of section 3.3 (one home: protocol/codes.py).
GRIPPER_ERRORS = frozenset(codes.GRIPPER_ERRORS)
#: Codes whose handling is "restart the xArm": error clear does not remove them.
NEEDS_RESTART = frozenset({G_CURRENT_DETECTION})

MOTION_STOPPED, MOTION_MOVING, MOTION_FAULT = 0, 1, 3


def _s32_words(value: int) -> tuple[int, int]:
    v = value & 0xFFFFFFFF
    return v >> 16, v & 0xFFFF


def _words_s32(hi: int, lo: int) -> int:
    v = (hi << 16) | lo
    return v - (1 << 32) if v & 0x80000000 else v


class XArmGripper:
    """The simulated gripper: a Modbus slave (:class:`rtu.RegisterDevice`) that moves in :meth:`step`."""

    def __init__(self, version: tuple[int, int, int] = (3, 4, 3),
                 baud_index: int = GRIPPER_BAUD_INDEX) -> None:
        self.version = version
        self.baud_index = baud_index
        self.reset()

    def reset(self) -> None:
        """Power-on state: disabled, at 0, speed :data:`DEFAULT_SPEED`, no error."""
        self.enabled = False
        self.mode = 0
        self.speed = DEFAULT_SPEED
        self.position = 0.0
        self.target = 0
        self.error = 0
        self._target_words = [0, 0]

    # --- state -------------------------------------------------------------------------------------

    @property
    def moving(self) -> bool:
        return self.enabled and not self.error and self.mode == 0 and self.position != self.target

    @property
    def status(self) -> int:
        motion = MOTION_FAULT if self.error else (MOTION_MOVING if self.moving else MOTION_STOPPED)
        return motion | ((2 if self.enabled else 0) << 2)

    @property
    def position_pulses(self) -> int:
        return int(round(self.position))

    def inject_error(self, code: int) -> None:
        """Raise a gripper error (section 3.3): the motor stops and is disabled."""
        if not 0 < code <= 0xFFFF:
            raise ValueError(f"gripper error code {code} out of range")
        self.error = code
        self.enabled = False
        self.target = self.position_pulses

    def clear_error(self) -> None:
        if self.error not in NEEDS_RESTART:
            self.error = 0

    # --- commands ----------------------------------------------------------------------------------

    def set_enable(self, on: int) -> None:
        if on not in (0, 1):
            raise rtu.RtuError(rtu.ILLEGAL_VALUE)
        if on and self.error:
            return  # an error keeps the motor off until cleared
        self.enabled = bool(on)
        if not on:
            self.target = self.position_pulses

    def set_mode(self, mode: int) -> None:
        if mode not in (0, 1):
            raise rtu.RtuError(rtu.ILLEGAL_VALUE)
        self.mode = mode

    def set_speed(self, speed: int) -> None:
        if not SPEED_MIN <= speed <= SPEED_MAX:
            self.inject_error(G_SPEED_OVERLIMIT)
            return
        self.speed = speed

    def set_target(self, pos: int) -> None:
        if not POS_MIN <= pos <= POS_MAX:
            self.inject_error(G_SOFT_LIMIT)
        elif not self.enabled:
            if not self.error:
                self.inject_error(G_POSITION_DEVIATION)
        else:
            self.target = pos

    def set_zero(self) -> None:
        self.position = 0.0
        self.target = 0

    # --- Modbus slave ------------------------------------------------------------------------------

    def _read(self, addr: int) -> int:
        pos_words = _s32_words(self.position_pulses)
        tgt_words = _s32_words(self.target)
        table: dict[int, Callable[[], int]] = {
            REG_STATUS: lambda: self.status,
            REG_ERROR: lambda: self.error,
            REG_ENABLE: lambda: int(self.enabled),
            REG_MODE: lambda: self.mode,
            REG_SPEED: lambda: self.speed,
            REG_TARGET: lambda: tgt_words[0],
            REG_TARGET + 1: lambda: tgt_words[1],
            REG_POSITION: lambda: pos_words[0],
            REG_POSITION + 1: lambda: pos_words[1],
            REG_VERSION: lambda: self.version[0],
            REG_VERSION + 1: lambda: self.version[1],
            REG_VERSION + 2: lambda: self.version[2],
        }
        getter = table.get(addr)
        if getter is None:
            raise rtu.RtuError(rtu.ILLEGAL_ADDRESS)
        return getter() & 0xFFFF

    def read_registers(self, address: int, count: int) -> list[int]:
        return [self._read(a) for a in range(address, address + count)]

    def write_registers(self, address: int, values: Sequence[int]) -> None:
        writable = {REG_ENABLE, REG_MODE, REG_CLEAR, REG_SPEED, REG_TARGET, REG_TARGET + 1, REG_ZERO}
        addrs = range(address, address + len(values))
        if any(a not in writable for a in addrs):
            raise rtu.RtuError(rtu.ILLEGAL_ADDRESS)
        target_written = False
        for a, v in zip(addrs, values, strict=True):
            if a == REG_ENABLE:
                self.set_enable(v)
            elif a == REG_MODE:
                self.set_mode(v)
            elif a == REG_CLEAR:
                if v == 1:
                    self.clear_error()
            elif a == REG_SPEED:
                self.set_speed(v)
            elif a == REG_ZERO:
                if v == 1:
                    self.set_zero()
            else:
                self._target_words[a - REG_TARGET] = v
                target_written = True
        if target_written:
            self.set_target(_words_s32(*self._target_words))

    # --- motion ------------------------------------------------------------------------------------

    def step(self, dt: float) -> None:
        """Move toward the target at ``speed * SPEED_TO_PULSES`` pulse/s."""
        if not self.moving:
            return
        delta = self.target - self.position
        max_step = self.speed * SPEED_TO_PULSES * dt
        if abs(delta) <= max_step:
            self.position = float(self.target)
        else:
            self.position += max_step if delta > 0 else -max_step


class GripperModule:
    """Controller component for register 124: the tool RS-485 bus with the gripper on it.

    ``tool_baud`` returns the tool bus baud index (the IO component's, register 127
    address 0x0A0B); when it differs from the gripper's the gripper does not
    answer (exception 0x0B), as on a real bus.
    """

    def __init__(self, gripper: XArmGripper | None = None,
                 tool_baud: Callable[[], int] | None = None) -> None:
        self.gripper = gripper or XArmGripper()
        self.tool_baud = tool_baud

    def rtu(self, host: int, pdu: bytes) -> bytes:
        """Answer one register-124 request: RTU reply PDU (without the host byte)."""
        devices: dict[int, rtu.RegisterDevice] = {}
        if host == TOOL_HOST:
            baud = self.tool_baud() if self.tool_baud else self.gripper.baud_index
            if baud == self.gripper.baud_index:
                devices[GRIPPER_ID] = self.gripper
        elif host != CONTROL_BOX_HOST:
            raise ParameterError(f"RS-485 host id {host}")
        return rtu.serve(pdu, devices)

    def step(self, dt: float, ctl: ControllerView) -> None:
        self.gripper.step(dt)

    # --- register table adapter --------------------------------------------------------------------

    def _handle_124(self, values: Any) -> dict[str, Any]:
        host = int(values["host"])
        return {"host": host, "rtu": self.rtu(host, bytes(values["rtu"]))}

    def handlers(self) -> dict[int, Handler]:
        return {124: self._handle_124}
