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

import math
from collections.abc import Sequence
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
        self._snap: tuple[int, ReportSnapshot] | None = None

    @property
    def triggered(self) -> list[tuple[str, str]]:
        """Every trigger written, in order: ("blockly" | "gcode", "%05d" name)."""
        return self.emu.modbus.triggered

    # -- the emulator's public surface ------------------------------------------------------------
    def snapshot(self) -> ReportSnapshot:
        gen = self.emu.generation
        if self._snap is None or self._snap[0] != gen:
            self._snap = (gen, self.emu.snapshot())
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
        name = point.name
        if name.endswith("_absent") or name in ("tool_analog_outputs",
                                                "cgpio_output_word_hi", "cgpio_input_word_hi"):
            return [0.0] * point.count
        if name == "user_coils":
            return [float(v) for v in self.emu.modbus.user_coils]
        if name == "user_registers":
            return [float(v) for v in self.emu.modbus.user_registers]
        if name == "blockly_trigger":
            return [float(v) for v in self.emu.modbus.blockly_trigger]
        if name == "gcode_trigger":
            return [float(v) for v in self.emu.modbus.gcode_trigger]
        if name in ("tgpio_outputs", "tgpio_output_word"):
            word = self._tool_read(ADDR_TOOL_DO_READ)
            return _bits(word, 2) if point.kind.bits else [float(word & 0xFF)]
        if name in ("tgpio_inputs", "tgpio_input_word"):
            word = self._tool_read(ADDR_TOOL_DI)
            return _bits(word, 2) if point.kind.bits else [float(word & 0xFF)]
        if name == "tool_analog_inputs":
            return [self._tool_read(a) * (TOOL_AI_FULL_SCALE / 4095) for a in ADDR_TOOL_AI]
        s = self.snapshot()
        if name == "cgpio_outputs":
            return _bits(s.cgpio_output_config, 16)
        if name == "cgpio_output_word":
            return [float(s.cgpio_output_config & 0xFFFF)]
        if name == "cgpio_inputs":
            return _bits(s.cgpio_input_config, 16)
        if name == "cgpio_input_word":
            return [float(s.cgpio_input_config & 0xFFFF)]
        if name == "brakes":
            return _bits(s.brake_bits, 7)
        if name == "enabled":
            return _bits(s.enable_bits, 7)
        if name == "reduced_mode":
            return [float(reduced_of(self.emu.controller).on)]
        if name == "fence":
            return [float(self.emu.controller.settings.boundary_on)]
        if name == "paused":
            return [float(s.state == STATE_SUSPEND)]
        if name == "stopped":
            return [float(s.state == STATE_STOP)]
        if name == "mode_bits":
            return [float(s.mode == n) for n in range(point.count)]
        if name == "analog_outputs":
            return [float(v) for v in s.analog_outputs]
        if name == "analog_inputs":
            return [float(v) for v in s.analog_inputs]
        if name == "mode":
            return [float(s.mode)]
        if name == "state":
            return [float(s.state)]
        if name == "error":
            return [float(s.error)]
        if name == "warning":
            return [float(s.warning)]
        if name == "counter":
            return [float((s.counter >> 16) & 0xFFFF), float(s.counter & 0xFFFF)]
        if name == "pose":
            p = list(s.pose)
            aa = rpy_to_axis_angle(p[3], p[4], p[5])
            return p[:3] + _deg(p[3:6]) + _deg([float(a) for a in aa])
        if name == "payload_mass":
            return [float(s.tcp_load[0])]
        if name == "payload_center":
            return [float(v) for v in s.tcp_load[1:4]]
        if name == "tcp_offset":
            return list(s.tcp_offset[:3]) + _deg(s.tcp_offset[3:6])
        if name == "world_offset":
            return list(s.world_offset[:3]) + _deg(s.world_offset[3:6])
        if name == "joints":
            return _deg(list(s.joints)[:7])
        if name == "temperatures":
            return [float(t) for t in list(s.temperatures)[:7]]
        if name == "joint_speeds":
            return _deg(list(s.joint_speeds)[:7])
        if name == "tcp_speed":
            m = self.emu.model
            return [kinematics.tcp_speed(m, s.joints[:m.dof], s.joint_speeds[:m.dof], s.tcp_offset)]
        raise ModbusError(modbus.DEVICE_FAILURE, f"no binding for {name}")

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


def answer(emu: Emulator, tid: int, unit: int, pdu: bytes) -> bytes:
    """The reply frame to one protocol-0 request on the command port (MBAP header + PDU); the user
    storage it reads and writes is the emulator's own (per box, as on the box)."""
    return modbus.encode_adu(tid, unit, modbus.handle_pdu(pdu, EmulatorDatastore(emu)))
