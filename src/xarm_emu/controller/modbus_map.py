"""The standard Modbus-TCP map bound to a live emulator (see :mod:`xarm_emu.protocol.modbus`).

Reads come from :meth:`Emulator.snapshot` (the values the reports carry, current each control
period) and, for the tool IO the reports lack, register 128. Writes go through
:meth:`Emulator.handle` with the private register each point names (134 for the control box digital
outputs, 127 for the tool outputs, 135/136 analog outputs, 19 mode, 12 state), so each behaviour
keeps one home; a write the register refuses with a new warning gets exception 3. User storage
and the Blockly / G-code trigger values live in the emulator's state
(:class:`~xarm_emu.controller.box_state.ModbusUserState`), so a checkpoint holds them.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

from ..model import kinematics
from ..model.rotations import rpy_to_axis_angle
from ..protocol import modbus
from ..protocol import registers as regs
from ..protocol.modbus import ILLEGAL_DATA_VALUE, ModbusError, Point
from ..protocol.reports import ReportSnapshot, volts_to_counts
from .applications.reduced import reduced_of
from .devices.io import (
    ADDR_TOOL_AI,
    ADDR_TOOL_DI,
    ADDR_TOOL_DO,
    ADDR_TOOL_DO_READ,
    TOOL_AI_FULL_SCALE,
    TOOL_HOST,
)

if TYPE_CHECKING:
    from .emulator import Emulator

STATE_SUSPEND = 3
STATE_STOP = 4


def _bits(word: int, n: int) -> list[float]:
    return [float((word >> i) & 1) for i in range(n)]


def _deg(xs: Sequence[float]) -> list[float]:
    return [math.degrees(x) for x in xs]


class EmulatorDatastore:
    """A :class:`~xarm_emu.protocol.modbus.Datastore` over one :class:`Emulator`."""

    def __init__(self, emu: Emulator) -> None:
        self.emu = emu
        self._snap: tuple[tuple[int, int], ReportSnapshot] | None = None

    @property
    def triggered(self) -> list[tuple[str, str]]:
        """Every trigger written, in order: ("blockly" | "gcode", "%05d" name)."""
        return self.emu.modbus.triggered

    # -- the emulator's public surface ------------------------------------------------------------
    def snapshot(self) -> ReportSnapshot:
        emu = self.emu
        key = (emu.generation, emu.controller.data.steps)  # the snapshot carries the clock
        if self._snap is None or self._snap[0] != key:
            self._snap = (key, emu.snapshot())
        return self._snap[1]

    def _call(self, code: int, values: dict[str, Any]) -> bytes:
        reg = regs.get(code)
        assert reg is not None
        before = self.snapshot().warning
        _, reply = self.emu.handle(code, reg.request.encode(values))
        self._snap = None
        after = self.snapshot().warning
        if after and after != before:  # the register refused the values (section 3.2.2)
            raise ModbusError(ILLEGAL_DATA_VALUE, f"register {code} refused {values} (warning {after})")
        return reply

    def _tool_read(self, addr: int) -> int:
        reg = regs.get(128)
        assert reg is not None
        _, reply = self.emu.handle(128, reg.request.encode(host=TOOL_HOST, addr=addr))
        return int(reg.reply.decode(reply)["value"]) & 0xFFFF

    # -- Datastore --------------------------------------------------------------------------------
    def read(self, point: Point) -> Sequence[float]:
        """The point's values, by its reader in :data:`READERS` (the map's table)."""
        reader = READERS.get(point.name)
        if reader is None:
            raise ModbusError(modbus.DEVICE_FAILURE, f"no binding for {point.name}")
        return reader(self, point)

    def write(self, point: Point, offset: int, values: Sequence[int]) -> None:
        name = point.name
        user = self.emu.modbus
        if name == "user_coils":
            user.user_coils[offset:offset + len(values)] = [v & 1 for v in values]
        elif name == "user_registers":
            user.user_registers[offset:offset + len(values)] = list(values)
        elif name == "blockly_trigger":
            user.blockly_trigger[offset:offset + len(values)] = list(values)
            user.triggered += [("blockly", f"{v:05d}") for v in values]
        elif name == "gcode_trigger":
            user.gcode_trigger[:] = list(values)
            user.triggered += [("gcode", f"{v:05d}") for v in values]
        elif name == "cgpio_outputs":
            mask = value = 0
            for i, v in enumerate(values):
                mask |= 1 << (offset + i)
                value |= (v & 1) << (offset + i)
            self._set_cgpio(mask, value)
        elif name == "cgpio_output_word":
            self._set_cgpio(0xFFFF, values[0])
        elif name == "tgpio_outputs":
            mask = value = 0
            for i, v in enumerate(values):
                mask |= 1 << (offset + i)
                value |= (v & 1) << (offset + i)
            self._call(127, {"host": TOOL_HOST, "addr": ADDR_TOOL_DO, "value": float(mask << 8 | value)})
        elif name == "tgpio_output_word":
            word = 0x0300 | (values[0] & 3)
            self._call(127, {"host": TOOL_HOST, "addr": ADDR_TOOL_DO, "value": float(word)})
        elif name == "analog_outputs":
            for i, v in enumerate(values):
                self._call(135 + offset + i, {"analog": volts_to_counts(point.decode(v))})
        elif name == "mode":
            self._call(19, {"mode": values[0]})
        elif name == "state":
            self._call(12, {"state": values[0]})
        # the remaining writable points are published but absent: the write changes nothing

    def _set_cgpio(self, mask: int, value: int) -> None:
        """Register 134: enable bits in each word's high byte, values in its low byte."""
        lo = ((mask & 0xFF) << 8) | (value & mask & 0xFF)
        hi = (((mask >> 8) & 0xFF) << 8) | ((value & mask) >> 8 & 0xFF)
        self._call(134, {"digital": lo, "digital_hi": hi})


# -- readers: one per point of the map, each reading the emulator's public surface ----------------------

Reader = Callable[[EmulatorDatastore, Point], Sequence[float]]


def _absent(ds: EmulatorDatastore, point: Point) -> list[float]:
    """Published but absent on this box: reads as zeros."""
    return [0.0] * point.count


def _user(ds: EmulatorDatastore, point: Point) -> list[float]:
    """User storage and the trigger values, the emulator's own (a checkpoint holds them)."""
    return [float(v) for v in getattr(ds.emu.modbus, point.name)]


def _tool_word(ds: EmulatorDatastore, point: Point, *, addr: int) -> list[float]:
    """Tool digital IO through register 128: two bits, or the low byte as a word."""
    word = ds._tool_read(addr)
    return _bits(word, 2) if point.kind.bits else [float(word & 0xFF)]


def _tool_analog_inputs(ds: EmulatorDatastore, point: Point) -> list[float]:
    return [ds._tool_read(a) * (TOOL_AI_FULL_SCALE / 4095) for a in ADDR_TOOL_AI]


def _snap_bits(ds: EmulatorDatastore, point: Point, *, field: str, n: int) -> list[float]:
    return _bits(getattr(ds.snapshot(), field), n)


def _snap_word(ds: EmulatorDatastore, point: Point, *, field: str) -> list[float]:
    return [float(getattr(ds.snapshot(), field) & 0xFFFF)]


def _snap_value(ds: EmulatorDatastore, point: Point, *, field: str) -> list[float]:
    return [float(getattr(ds.snapshot(), field))]


def _snap_values(ds: EmulatorDatastore, point: Point, *, field: str) -> list[float]:
    return [float(v) for v in list(getattr(ds.snapshot(), field))[:7]]


def _snap_degrees(ds: EmulatorDatastore, point: Point, *, field: str) -> list[float]:
    return _deg(list(getattr(ds.snapshot(), field))[:7])


def _snap_offset(ds: EmulatorDatastore, point: Point, *, field: str) -> list[float]:
    """A TCP or user offset: mm, then degrees."""
    offset = getattr(ds.snapshot(), field)
    return list(offset[:3]) + _deg(offset[3:6])


def _reduced_mode(ds: EmulatorDatastore, point: Point) -> list[float]:
    return [float(reduced_of(ds.emu.controller).on)]


def _fence(ds: EmulatorDatastore, point: Point) -> list[float]:
    return [float(ds.emu.controller.settings.boundary_on)]


def _state_is(ds: EmulatorDatastore, point: Point, *, state: int) -> list[float]:
    return [float(ds.snapshot().state == state)]


def _mode_bits(ds: EmulatorDatastore, point: Point) -> list[float]:
    mode = ds.snapshot().mode
    return [float(mode == n) for n in range(point.count)]


def _counter(ds: EmulatorDatastore, point: Point) -> list[float]:
    counter = ds.snapshot().counter
    return [float((counter >> 16) & 0xFFFF), float(counter & 0xFFFF)]


def _pose(ds: EmulatorDatastore, point: Point) -> list[float]:
    """The TCP pose: mm, RPY degrees, then the same orientation as an axis-angle vector in degrees."""
    p = list(ds.snapshot().pose)
    aa = rpy_to_axis_angle(p[3], p[4], p[5])
    return p[:3] + _deg(p[3:6]) + _deg([float(a) for a in aa])


def _payload_mass(ds: EmulatorDatastore, point: Point) -> list[float]:
    return [float(ds.snapshot().tcp_load[0])]


def _payload_center(ds: EmulatorDatastore, point: Point) -> list[float]:
    return [float(v) for v in ds.snapshot().tcp_load[1:4]]


def _tcp_speed(ds: EmulatorDatastore, point: Point) -> list[float]:
    s, m = ds.snapshot(), ds.emu.model
    return [kinematics.tcp_speed(m, s.joints[:m.dof], s.joint_speeds[:m.dof], s.tcp_offset)]


#: How each point of the standard map reads (:data:`~xarm_emu.protocol.modbus.MODBUS_MAP`, by name);
#: checked at import to cover every point.
READERS: dict[str, Reader] = {
    **{p.name: _absent for p in modbus.MODBUS_MAP if p.name.endswith("_absent")},
    "tool_analog_outputs": _absent,
    "cgpio_output_word_hi": _absent,
    "cgpio_input_word_hi": _absent,
    "user_coils": _user,
    "user_registers": _user,
    "blockly_trigger": _user,
    "gcode_trigger": _user,
    "tgpio_outputs": functools.partial(_tool_word, addr=ADDR_TOOL_DO_READ),
    "tgpio_output_word": functools.partial(_tool_word, addr=ADDR_TOOL_DO_READ),
    "tgpio_inputs": functools.partial(_tool_word, addr=ADDR_TOOL_DI),
    "tgpio_input_word": functools.partial(_tool_word, addr=ADDR_TOOL_DI),
    "tool_analog_inputs": _tool_analog_inputs,
    "cgpio_outputs": functools.partial(_snap_bits, field="cgpio_output_config", n=16),
    "cgpio_output_word": functools.partial(_snap_word, field="cgpio_output_config"),
    "cgpio_inputs": functools.partial(_snap_bits, field="cgpio_input_config", n=16),
    "cgpio_input_word": functools.partial(_snap_word, field="cgpio_input_config"),
    "brakes": functools.partial(_snap_bits, field="brake_bits", n=7),
    "enabled": functools.partial(_snap_bits, field="enable_bits", n=7),
    "reduced_mode": _reduced_mode,
    "fence": _fence,
    "paused": functools.partial(_state_is, state=STATE_SUSPEND),
    "stopped": functools.partial(_state_is, state=STATE_STOP),
    "mode_bits": _mode_bits,
    "analog_outputs": functools.partial(_snap_values, field="analog_outputs"),
    "analog_inputs": functools.partial(_snap_values, field="analog_inputs"),
    "mode": functools.partial(_snap_value, field="mode"),
    "state": functools.partial(_snap_value, field="state"),
    "error": functools.partial(_snap_value, field="error"),
    "warning": functools.partial(_snap_value, field="warning"),
    "counter": _counter,
    "pose": _pose,
    "payload_mass": _payload_mass,
    "payload_center": _payload_center,
    "tcp_offset": functools.partial(_snap_offset, field="tcp_offset"),
    "world_offset": functools.partial(_snap_offset, field="world_offset"),
    "joints": functools.partial(_snap_degrees, field="joints"),
    "temperatures": functools.partial(_snap_values, field="temperatures"),
    "joint_speeds": functools.partial(_snap_degrees, field="joint_speeds"),
    "tcp_speed": _tcp_speed,
}
if _unread := {p.name for p in modbus.MODBUS_MAP} - READERS.keys():
    raise ValueError(f"standard Modbus points without a reader: {sorted(_unread)}")


def answer(emu: Emulator, tid: int, unit: int, pdu: bytes) -> bytes:
    """The reply frame to one protocol-0 request on the command port (MBAP header + PDU); the user
    storage it reads and writes is the emulator's own (per box, as on the box)."""
    return modbus.encode_adu(tid, unit, modbus.handle_pdu(pdu, EmulatorDatastore(emu)))
