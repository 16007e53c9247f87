"""The xArm Gripper on the tool RS-485 (manual section 2.1.4, register 124; gripper codes 3.3).

Register 124 tunnels ``[host id][Modbus-RTU PDU]``; host 9 is the tool RS-485,
where the gripper answers as slave 8. Gripper registers (u16, big-endian):

=========  ======  ====================================================
address    access  meaning
=========  ======  ====================================================
0x0000     r       status: bits 0-1 motion (0 stopped, 1 moving, 2 stopped on an object,
                   3 fault),
                   bits 2-3 enable (0 disabled, 2 enabled)
0x000F     r       error code (section 3.3, 0 = none)
0x0100     rw      enable (0/1)
0x0101     rw      mode (0 position, 1 speed; only position mode moves)
0x0109     w       error clear (write 1)
0x0303     rw      speed, r/min, 1..10000 (the fingers top out at 5000)
0x0700     rw      target position, s32 in two registers, high word first
0x0702     r       current position, s32 in two registers
0x0801-3   r       firmware version major, minor, revision
0x0817     w       set the current position as zero (write 1)
=========  ======  ====================================================

Speed mapping: the SDK's speed is in r/min; the emulated fingers move at
``SPEED_TO_PULSES = 0.17`` pulse/s per r/min, so speed 5000 crosses the full
0..850 range in 1.0 s (and the manual's example speed 1500 in 3.33 s).

Speed range, as the real gripper behaves: the speed register accepts 1..10000
without an error, and the fingers move no faster than at 5000 (:data:`SPEED_TOP`).
Sources, in words: users driving real grippers report setting 10000 (one robot
learning project did so for hours) with no error and no warning, only more
noise from the gripper; UFACTORY's answer on the SDK's tracker gives 0-5000 as
the useful range, and their ROS driver clamps the speed to 5000 before sending
it. So the SDK's example 5004, which asks for 8000, succeeds and moves at the
top speed; G12 remains for 0 and anything above 10000.

Refusals (section 3.3 codes; any gripper error stops and disables the motor, as
"re-enable the Gripper" in the manual's handling column implies):

- target position outside 0..850: G25 "Command Over Software Limit";
- speed outside 1..10000: G12 "Speed Overlimit";
- target position while disabled: G23 "Large Motor Position Deviation" (the
  unpowered motor cannot follow the command).

Erratum: the manual's "Set the gripper position" example carries 400 as the fp32
``00 00 C8 43``; the SDK, which drives real grippers, sends an s32 big-endian
(``00 00 01 90``). The emulator follows the SDK, so the manual's bytes read as
51267 and give G25. The manual's "Get the gripper position" example shows
function code 0x10 without data, a malformed write; the SDK reads with 0x03.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar, Protocol

from ...protocol import codes, regmap, rtu
from ...protocol.rtu import CONTROL_BOX_HOST, TOOL_HOST
from ..core.controller_state import holds
from ..core.device import NO_REGISTERS, Device
from ..core.interface import (
    NOT_IDLE,
    Binding,
    ControllerView,
    Handler,
    ParameterError,
    bind_component,
)
from .io import BAUD_RATES

GRIPPER_ID = 8  # section 2.1.4 "Gripper ID 0x08"
GRIPPER_BAUD_INDEX = 11  # 2,000,000 bps (register 127 baud table)

POS_MIN = 0
POS_MAX = 850
SPEED_MIN = 1
#: The speed register accepts up to this (r/min) without an error.
SPEED_MAX = 10000
#: The fingers move no faster than at this speed (r/min); above it they top out.
SPEED_TOP = 5000
SPEED_TO_PULSES = POS_MAX / SPEED_TOP  # pulse/s per r/min: 0.17
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

#: Motion bits of the status: 2 is fingers stopped on an object short of the target, which the SDK's
#: wait for a grip takes as done (only a physics scene, controller/physics/, stops them so).
MOTION_STOPPED, MOTION_MOVING, MOTION_GRIPPED, MOTION_FAULT = 0, 1, 2, 3


class DrivenFingers(Protocol):
    """A gripper's own model of its fingers, as the physics twin (controller/physics/) drives it, in
    the model's own units: the opening (mm), whether the fingers are closing, whether the model grips
    (stopped on an object), the force each pad presses with (N), whether the fingers met an object;
    ``meet(width)`` tells it the fingers met one that wide (its status then says so), ``part`` that
    it is gone when the fingers no longer touch it."""

    @property
    def opening(self) -> float: ...
    @property
    def closing(self) -> bool: ...
    @property
    def gripping(self) -> bool: ...
    @property
    def force(self) -> float: ...
    @property
    def met(self) -> bool: ...
    def meet(self, width: float) -> None: ...
    def part(self, touching: bool) -> None: ...


class TwinFingers(Protocol):
    """A gripper whose fingers the physics twin (controller/physics/) moves itself, in pulses: the
    twin reads the finger command (``enabled``, ``mode``, ``error``, ``target``, ``speed``,
    ``moving``) and writes back where the fingers are (``position``) and whether they press on an
    object short of the target (``gripped``)."""

    enabled: bool
    mode: int
    speed: int
    target: int
    position: float
    gripped: bool

    @property
    def error(self) -> int: ...
    @property
    def moving(self) -> bool: ...


class ToolDevice(Device, rtu.RegisterDevice, Protocol):
    """A device (:class:`~..core.device.Device`) on the tool RS-485 (register 124, host 9): a Modbus
    slave with its own slave id and baud rate (register 127 baud table index) whose ``REGISTER_MAP``
    register 124 reaches; the xArm gripper, the Robotiq 2F-85/2F-140 (controller/devices/robotiq.py),
    the BIO gripper G2 and G1 (controller/devices/bio_gripper.py, bio_gripper_g1.py) or the Inspire
    RH56 hand (controller/devices/inspire_hand.py). Beyond the device interface it says what the box
    reports of it and takes the objects a test plays between its fingers."""

    slave_id: int
    baud_index: int
    #: Its state, handed back whole by a restore (``Emulator._adopt``).
    data: Any
    #: Where ``set-input gripper-object`` may put an object: 0 between the fingers, 1 around them
    #: (gripped by opening); empty for a device that detects none.
    object_places: tuple[int, ...]

    #: Register 106 and the reports' end-tool code: the device's error where the box knows it, else 0.
    @property
    def reported_error(self) -> int: ...

    def check_object(self, width_mm: float, inner: bool = False) -> None: ...

    def set_object(self, width_mm: float | None, inner: bool = False) -> None: ...

    def driven_fingers(self, force: float) -> DrivenFingers | None:
        """Its fingers as the physics twin drives them when its own model moves them (``force``: the
        most each pad of the twin's hand presses with, N); None where the twin moves them itself
        (the xArm gripper) or has no body for them."""
        ...

    def twin_fingers(self) -> TwinFingers | None:
        """Its fingers when the physics twin moves them itself (the xArm gripper); None where its own
        model moves them (:meth:`driven_fingers`) or the twin has no body for them."""
        ...


@dataclass(slots=True)
class XArmGripperState:
    """Every mutable value of the xArm gripper (registers 124/125; section 3.3 for the error)."""

    baud_index: int = 0
    enabled: bool = False
    mode: int = 0
    speed: int = 0
    position: float = 0.0  # pulses
    target: int = 0
    error: int = 0
    _target_words: list[int] = field(default_factory=lambda: [0, 0])
    #: The fingers press on an object short of the target (set by the physics world).
    gripped: bool = False


@holds(XArmGripperState)
class XArmGripper:
    """The simulated gripper: a Modbus slave (:class:`rtu.RegisterDevice`) that moves in :meth:`step`."""

    slave_id = GRIPPER_ID
    REGISTER_MAP: ClassVar[regmap.RegisterMap]  # below the class
    object_places: tuple[int, ...] = ()  # no object detection the SDK reads

    def __init__(self, version: tuple[int, int, int] = (3, 4, 3),
                 baud_index: int = GRIPPER_BAUD_INDEX) -> None:
        self.data = XArmGripperState()
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
        self.gripped = False
        self._target_words = [0, 0]

    # --- state -------------------------------------------------------------------------------------

    @property
    def moving(self) -> bool:
        return self.enabled and not self.error and self.mode == 0 and self.position != self.target

    @property
    def status(self) -> int:
        motion = (MOTION_FAULT if self.error else MOTION_GRIPPED if self.gripped
                  else MOTION_MOVING if self.moving else MOTION_STOPPED)
        return motion | ((2 if self.enabled else 0) << 2)

    @property
    def position_pulses(self) -> int:
        return int(round(self.position))

    @property
    def reported_error(self) -> int:
        """The box knows the xArm gripper's error: register 106 and the reports carry it."""
        return self.error

    def status_fields(self) -> dict[str, Any]:
        return {"enabled": self.enabled, "position": self.position_pulses}

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

    def check_object(self, width_mm: float, inner: bool = False) -> None:
        """The xArm gripper has no object detection the SDK reads: refused."""
        self.set_object(width_mm, inner)

    def set_object(self, width_mm: float | None, inner: bool = False) -> None:
        """The xArm gripper has no object detection the SDK reads: refused."""
        raise ValueError("the xArm gripper reports no object detection; gripper-object needs "
                         "--gripper robotiq-2f85, robotiq-2f140, bio or bio-g1")

    def driven_fingers(self, force: float) -> None:
        """None: the physics twin moves the xArm gripper's fingers itself (:meth:`twin_fingers`)."""
        return None

    def twin_fingers(self) -> TwinFingers:
        """Itself: the physics twin runs its finger command and writes back its position and grip
        (physics/component.py)."""
        return self

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

    def read_registers(self, address: int, count: int) -> list[int]:
        return regmap.read_registers(REGISTER_MAP, self, address, count)

    def write_registers(self, address: int, values: Sequence[int]) -> None:
        regmap.write_registers(REGISTER_MAP, self, address, values)

    # --- motion ------------------------------------------------------------------------------------

    def idle_until(self, ctl: ControllerView) -> float:
        """Idle (:func:`~..core.interface.idle_until`) while the fingers do not move."""
        return NOT_IDLE if self.moving else math.inf

    def step(self, dt: float, ctl: ControllerView) -> None:
        """Move toward the target at ``min(speed, SPEED_TOP) * SPEED_TO_PULSES`` pulse/s."""
        if not self.moving:
            return
        delta = self.target - self.position
        max_step = min(self.speed, SPEED_TOP) * SPEED_TO_PULSES * dt
        if abs(delta) <= max_step:
            self.position = float(self.target)
        else:
            self.position += max_step if delta > 0 else -max_step


def _put_target_word(g: XArmGripper, value: int, *, word: int) -> None:
    g._target_words[word] = value


def _commit_target(g: XArmGripper) -> None:
    """Both target registers written by one request (or one of them with the other's last value)."""
    g.set_target(rtu.words_s32(*g._target_words))


def _clear_error(g: XArmGripper, value: int) -> None:
    if value == 1:
        g.clear_error()


def _set_zero(g: XArmGripper, value: int) -> None:
    if value == 1:
        g.set_zero()


#: The xArm gripper's registers (the table of the module docstring); :func:`~xarm_emu.protocol.regmap.
#: write_registers` refuses a request that reaches any other address before it changes anything.
REGISTER_MAP: dict[int, regmap.Reg] = {
    REG_STATUS: regmap.Reg("status"),
    REG_ERROR: regmap.Reg("error"),
    REG_ENABLE: regmap.Reg("enabled", "rw", put=XArmGripper.set_enable, range=(0, 1)),
    REG_MODE: regmap.Reg("mode", "rw", put=XArmGripper.set_mode, range=(0, 1)),
    REG_CLEAR: regmap.Reg("clear_error", "w", put=_clear_error),
    # 1..10000 accepted; outside it the gripper raises G12 itself (set_speed), no exception.
    REG_SPEED: regmap.Reg("speed", "rw", put=XArmGripper.set_speed, unit="r/min"),
    **regmap.s32(REG_TARGET, "target", access="rw", put=_put_target_word, commit=_commit_target,
                 unit="pulse"),
    **regmap.s32(REG_POSITION, "position", unit="pulse"),
    **regmap.items(REG_VERSION, "version", 3),
    REG_ZERO: regmap.Reg("set_zero", "w", put=_set_zero),
}
XArmGripper.REGISTER_MAP = REGISTER_MAP


#: The gripper's turnaround, ms: from the end of a request to the start of its reply. The public
#: material gives none; 1 ms is the emulator's choice (a Modbus-RTU slave at these rates answers
#: within a few bit times plus its processing).
DEVICE_TURNAROUND_MS = 1.0

#: Default timeouts (ms) of the tool RS-485 Modbus bridge (register 123) and of its transparent
#: transfer (register 240); the emulator's choice, longer than any reply the gripper takes.
DEFAULT_MODBUS_TIMEOUT_MS = 20
DEFAULT_TRANSPARENT_TIMEOUT_MS = 20

BITS_PER_BYTE = 11  # Modbus-RTU: start, 8 data, parity or second stop, stop

#: Old (non-Modbus) gripper path, registers 129/130: 32-bit gripper registers by address.
REG32_TARGET = REG_TARGET
REG32_POSITION = REG_POSITION
REG32_SPEED = REG_SPEED
REG32_ENABLE = REG_ENABLE


def crc16_modbus(data: bytes) -> bytes:
    """The Modbus-RTU CRC of ``data``, low byte first (as it goes on the wire)."""
    crc = 0xFFFF
    for b in data:
        crc ^= b
        for _ in range(8):
            crc = (crc >> 1) ^ 0xA001 if crc & 1 else crc >> 1
    return bytes((crc & 0xFF, crc >> 8))


def _baud(index: int) -> int:
    return BAUD_RATES[index] if 0 <= index < len(BAUD_RATES) else BAUD_RATES[-1]


@dataclass(slots=True)
class ToolBusState:
    """The tool RS-485 bridge's timeouts: register 123 (Modbus-RTU) and 241 (transparent transfer)."""

    modbus_timeout_ms: int = DEFAULT_MODBUS_TIMEOUT_MS
    transparent_timeout_ms: int = DEFAULT_TRANSPARENT_TIMEOUT_MS


@holds(ToolBusState)
class GripperModule:
    """Controller component for the tool RS-485 bus with the gripper on it: register 124 (Modbus-RTU
    through the bridge), 123 (the bridge's timeout), 240/241 (transparent transfer and its timeout)
    and the old non-Modbus gripper path, 125/129/130. As a device (:class:`~..core.device.Device`)
    it is the bridge with the device on the bus: no registers of its own, the device's error and
    status; clearing clears the xArm gripper's too (the old path's).

    ``tool_baud`` returns the tool bus baud index (the IO component's, register 127
    address 0x0A0B); when it differs from the gripper's the gripper does not
    answer (exception 0x0B), as on a real bus. Neither does it when the reply takes longer than the
    bridge's timeout (register 123): the request and reply bytes at the bus baud rate, plus
    :data:`DEVICE_TURNAROUND_MS`.
    """

    def __init__(self, gripper: XArmGripper | None = None,
                 tool_baud: Callable[[], int] | None = None, device: ToolDevice | None = None) -> None:
        self.data = ToolBusState()
        #: The xArm gripper (kept for the old non-Modbus path and the view even when another device
        #: is attached; then it is not on the bus).
        self.gripper = gripper or XArmGripper()
        #: The device on the tool bus: the xArm gripper unless another one is attached.
        self.device: ToolDevice = device if device is not None else self.gripper
        self.tool_baud = tool_baud
        self.modbus_timeout_ms = DEFAULT_MODBUS_TIMEOUT_MS
        self.transparent_timeout_ms = DEFAULT_TRANSPARENT_TIMEOUT_MS
        #: The slaves answering on the control box RS-485 (host 11) now, by slave id (the linear
        #: track, controller/devices/linear_track.py, when attached and the bus baud matches its own).
        self.box_devices: Callable[[], dict[int, rtu.RegisterDevice]] = dict

    def _bus_baud_index(self) -> int:
        return self.tool_baud() if self.tool_baud else self.device.baud_index

    def response_ms(self, request_len: int, reply_len: int) -> float:
        """How long a request of ``request_len`` bytes and its reply take on the tool bus (ms, CRC
        included)."""
        n = request_len + reply_len + 4
        return n * BITS_PER_BYTE * 1000.0 / _baud(self._bus_baud_index()) + DEVICE_TURNAROUND_MS

    def rtu(self, host: int, pdu: bytes) -> bytes:
        """Answer one register-124 request: RTU reply PDU (without the host byte)."""
        devices: dict[int, rtu.RegisterDevice] = {}
        if host == TOOL_HOST:
            if self._bus_baud_index() == self.device.baud_index:
                devices[self.device.slave_id] = self.device
        elif host == CONTROL_BOX_HOST:
            devices.update(self.box_devices())
        else:
            raise ParameterError(f"RS-485 host id {host}")
        reply = rtu.serve(pdu, devices)
        if host == TOOL_HOST and devices and self.response_ms(len(pdu), len(reply)) > self.modbus_timeout_ms:
            slave = pdu[0] if pdu else 0
            func = pdu[1] if len(pdu) > 1 else 0
            return rtu.exception_reply(slave, func, rtu.GATEWAY_NO_RESPONSE)
        return reply

    def transparent(self, host: int, data: bytes) -> bytes:
        """Register 241: raw bytes on the bus. A Modbus-RTU frame with a valid CRC for the gripper
        gets the gripper's reply frame (CRC appended) within the transparent timeout; anything else
        gets no reply bytes. The gripper is whichever device is on the tool bus."""
        if host not in (TOOL_HOST, CONTROL_BOX_HOST):
            raise ParameterError(f"RS-485 host id {host}")
        if host != TOOL_HOST or len(data) < 4 or crc16_modbus(data[:-2]) != data[-2:]:
            return b""
        dev = self.device
        if self._bus_baud_index() != dev.baud_index or data[0] != dev.slave_id:
            return b""
        reply = rtu.serve(data[:-2], {dev.slave_id: dev})
        if self.response_ms(len(data) - 2, len(reply)) > self.transparent_timeout_ms:
            return b""
        return reply + crc16_modbus(reply)

    REGISTER_MAP: ClassVar[regmap.RegisterMap] = NO_REGISTERS

    def step(self, dt: float, ctl: ControllerView) -> None:
        self.device.step(dt, ctl)

    def idle_until(self, ctl: ControllerView) -> float:
        """Idle (:func:`~..core.interface.idle_until`) as far as the device on the bus says."""
        return self.device.idle_until(ctl)

    @property
    def error(self) -> int:
        return self.device.error

    def inject_error(self, code: int) -> None:
        self.device.inject_error(code)

    def clear_error(self) -> None:
        self.gripper.clear_error()
        self.device.clear_error()

    def status_fields(self) -> dict[str, Any]:
        return self.device.status_fields()

    # --- register table adapter --------------------------------------------------------------------

    def rs485_rtu(self, values: Any) -> dict[str, Any]:
        """Register 124: one Modbus-RTU request to the RS-485 of host 9 (tool) or 11 (control box)."""
        host = int(values["host"])
        return {"host": host, "rtu": self.rtu(host, bytes(values["rtu"]))}

    @staticmethod
    def _timeout(values: Any) -> int:
        ms = int(values["timeout"])
        if ms <= 0:
            raise ParameterError(f"timeout {ms} ms")
        return ms

    def set_modbus_timeout(self, values: Any) -> None:
        """Register 123: the tool RS-485 Modbus bridge's timeout (ms)."""
        self.modbus_timeout_ms = self._timeout(values)

    def set_transparent_timeout(self, values: Any) -> None:
        """Register 240: the transparent transfer's timeout (ms)."""
        self.transparent_timeout_ms = self._timeout(values)

    def transparent_transfer(self, values: Any) -> dict[str, Any]:
        host = int(values["host"])
        return {"host": host, "data": self.transparent(host, bytes(values["data"]))}

    def _old_path(self, values: Any) -> XArmGripper:
        if int(values["host"]) != GRIPPER_ID:
            raise ParameterError(f"gripper id {values['host']} (8)")
        if self.device is not self.gripper:
            raise ParameterError("the old gripper path drives the xArm gripper, which is not attached")
        return self.gripper

    def old_gripper_error(self, values: Any) -> dict[str, Any]:
        """Register 125: the gripper error code (old path): the second byte carries it."""
        return {"error": 0, "code": self.gripper.error & 0xFF}

    def old_gripper_write(self, values: Any) -> None:
        """Register 129 (old path): write a 32-bit gripper register (enable, speed, target)."""
        g = self._old_path(values)
        raw = float(values["value"])
        if raw != int(raw):
            raise ParameterError(f"value {raw} is not an integer")
        addr, value = int(values["addr"]), int(raw)
        if addr == REG32_TARGET:
            g.set_target(value)
        elif addr == REG32_SPEED:
            g.set_speed(value)
        elif addr == REG32_ENABLE:
            try:
                g.set_enable(value)
            except rtu.RtuError as exc:
                raise ParameterError(f"enable {value}") from exc
        else:
            raise ParameterError(f"gripper address {addr:#06x} is not writable on the old path")

    def old_gripper_read(self, values: Any) -> dict[str, Any]:
        """Register 130 (old path): read a 32-bit gripper register (position, target, speed)."""
        g = self._old_path(values)
        addr = int(values["addr"])
        table = {REG32_POSITION: g.position_pulses, REG32_TARGET: g.target, REG32_SPEED: g.speed,
                 REG32_ENABLE: int(g.enabled), REG_ERROR: g.error, REG_STATUS: g.status}
        if addr not in table:
            raise ParameterError(f"gripper address {addr:#06x} is not readable on the old path")
        return {"value": int(table[addr])}

    def handlers(self) -> dict[int, Handler]:
        """This component's registers (:data:`BINDINGS`), bound to it."""
        return bind_component(self, BINDINGS)


#: The registers of the tool RS-485 bus component (:class:`~xarm_emu.controller.core.interface.Binding`).
BINDINGS: tuple[Binding, ...] = (
    Binding(123, GripperModule.set_modbus_timeout, GripperModule),
    Binding(124, GripperModule.rs485_rtu, GripperModule),
    Binding(125, GripperModule.old_gripper_error, GripperModule),
    Binding(129, GripperModule.old_gripper_write, GripperModule),
    Binding(130, GripperModule.old_gripper_read, GripperModule),
    Binding(240, GripperModule.set_transparent_timeout, GripperModule),
    Binding(241, GripperModule.transparent_transfer, GripperModule),
)
