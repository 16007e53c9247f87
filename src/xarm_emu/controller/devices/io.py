"""Tool IO, control box GPIO and the special IO commands (manual section 2.1.4, registers 127-147).

Tool IO (registers 127 write, 128 read; ``[host][address][value]``, host 9):

- 0x0A14 digital inputs: bit 0 TI0, bit 1 TI1, bit 2 TI3, bit 3 TI4 (the bits the SDK's
  ``get_tgpio_digital`` reads); 0x0A12 bit 0 is TI2, on the arms that have one (Lite 6, 850);
  0x0A16 / 0x0A17 analog inputs, 0-4095 for 0-3.3 V;
- 0x0A15 digital outputs: a mask word sent as fp32, high byte = outputs to change,
  low byte = their values (256.0 "close 0", 257.0 "open 0", 512.0 "close 1", 514.0 "open 1");
  bit 0 TO0, bit 1 TO1, bit 2 TO3, bit 3 TO4, bit 4 TO2, as the SDK's ``tgpio_set_digital`` masks;
  0x0A18 reads the output word back in the same bits;
- 0x0A0B reads the RS-485 baud-rate index, 0x1A0B writes it (index 11 = 2,000,000 bps, the
  gripper's); 0x0607 soft-reboots the tool board (outputs drop to 0); 0x0801-0x0803 board version.

Control box GPIO (registers 131-139): ``n_digital`` (16 for a control box SN >= 1300, as the SDK
expects; else 8) digital inputs and outputs, two analog inputs and outputs (0-4095 for 0-10 V).
Inputs idle high (the manual's 0xFFFD example is "GPIO1 low"). Function numbers of register 138
are the manual's: 0 "system in STOP state" (state 4), 1 "system error" (error code != 0), 2 "xArm
is operating" (arm moving); the SDK's 11 (has error) and 12 (has warning) are also driven. 255 is a
general-purpose IO (the power-on default); any other number holds the output off. In register 139
the "configuration IO status" words are the IO levels and the "function IO status" words the
levels of IOs that have a function.

Special IO (registers 142-147): delayed outputs fire in the first control period at or after
their time; position-triggered outputs fire once, in the control period in which the TCP path
(the segment between two consecutive samples) enters the tolerance sphere. A zero radius only
fires when a sample lies on the point (within :data:`ZERO_RADIUS_EPS`): as the manual warns,
passing the point at speed misses it. At most 36 commands may be pending (C36 beyond). On
entering STOP (state 4) pending commands are dropped and, when register 146 says so, the
general digital outputs of the control box / tool are cleared.
"""

from __future__ import annotations

import copy
import functools
import math
import weakref
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar

from ...protocol import regmap, rtu
from ...protocol.reports import ANALOG_COUNTS, ANALOG_FULL_SCALE, counts_to_volts
from ...protocol.rtu import CONTROL_BOX_HOST, TOOL_HOST
from ..core.controller_protocol import Controller, queue_behind_moves
from ..core.controller_state import holds
from ..core.interface import (
    C_DELAYED_IO,
    NOT_IDLE,
    Binding,
    CommandError,
    ControllerView,
    Handler,
    ParameterError,
    Values,
    bind_component,
)
from ..core.state_machine import STATE_STOP

# Tool board addresses (registers 127/128).
ADDR_TOOL_DI = 0x0A14
ADDR_TOOL_DO = 0x0A15
ADDR_TOOL_AI = (0x0A16, 0x0A17)
ADDR_TOOL_DO_READ = 0x0A18
ADDR_TOOL_TI2 = 0x0A12  # TI2 in bit 0 (Lite 6, 850)
ADDR_BAUD_READ = 0x0A0B
ADDR_BAUD_WRITE = 0x1A0B
ADDR_SOFT_REBOOT = 0x0607
ADDR_VERSION = 0x0801

BAUD_RATES = (4800, 9600, 19200, 38400, 57600, 115200, 230400, 460800, 921600,
              1_000_000, 1_500_000, 2_000_000, 2_500_000)
DEFAULT_BAUD_INDEX = 11  # 2,000,000 bps, what the SDK checks before gripper commands

TOOL_DIGITAL = 2  # TO0/TO1, TI0/TI1 of the xArm 5/6/7 tool connector
#: Tool input number (TI n, the SDK's ``ionum``) -> bit of 0x0A14; TI2 lives at 0x0A12 instead.
TOOL_INPUT_BITS = {0: 0, 1: 1, 3: 2, 4: 3}
TI2 = 2
TOOL_AI_FULL_SCALE = 3.3  # V at 4095
# Control box analog IO: 12-bit counts for 0-10 V, the scale the rich report also uses (one home:
# protocol/reports.py).
CGPIO_AI_FULL_SCALE = ANALOG_FULL_SCALE
ANALOG_MAX = ANALOG_COUNTS

FUN_GENERAL = 255
GENERAL_INPUT = frozenset({0, FUN_GENERAL})  # SDK: input function 0 is "general input"
FUN_STOP = 0
FUN_ERROR = 1
FUN_MOVING = 2
FUN_HAS_ERROR = 11  # SDK documentation
FUN_HAS_WARNING = 12  # SDK documentation

MAX_PENDING = 36
ERR_TOO_MANY_PENDING = C_DELAYED_IO  # C36, manual section 3.2.1
ZERO_RADIUS_EPS = 1e-3  # mm: a zero radius means "the TCP sample is on the point"


def _volts_to_raw(volts: float, full_scale: float) -> int:
    if not math.isfinite(volts):
        raise ValueError("analog value must be finite")
    return max(0, min(ANALOG_MAX, int(round(volts / full_scale * ANALOG_MAX))))


@dataclass(slots=True)
class PendingIO:
    """A delayed (``due`` set) or position-triggered (``center`` set) output command."""

    target: str  # "cgpio", "tgpio" or "analog"
    index: int
    value: int
    due: float | None = None
    center: tuple[float, float, float] | None = None
    radius: float = 0.0


class ToolIO:
    """The tool (end-effector) IO board on host 9, and the control box RS-485 baud on host 11."""

    def __init__(self, version: tuple[int, int, int] = (1, 0, 0), has_ti2: bool = False) -> None:
        self.version = version
        self.digital_inputs = 0  # 0x0A14: TI0, TI1, TI3, TI4 in bits 0-3 (TOOL_INPUT_BITS)
        #: The arm has the third tool input TI2 at 0x0A12 (Lite 6, 850).
        self.has_ti2 = has_ti2
        self.ti2 = 0
        self.digital_outputs = 0  # bit n = TO n
        self.analog_inputs = [0, 0]  # raw 0..4095
        self.baud_index = {TOOL_HOST: DEFAULT_BAUD_INDEX, CONTROL_BOX_HOST: DEFAULT_BAUD_INDEX}

    def output(self, index: int) -> int:
        return (self.digital_outputs >> index) & 1

    def set_output(self, index: int, on: int) -> None:
        self.apply_mask(((1 << index) << 8) | ((1 if on else 0) << index))

    def check_input(self, number: int) -> None:
        """Raise ParameterError unless TI ``number`` exists on this tool board."""
        if number == TI2:
            if not self.has_ti2:
                raise ParameterError("this arm has no tool input TI2 (Lite 6 and 850 have one)")
        elif number not in TOOL_INPUT_BITS:
            raise ParameterError(f"tool input {number} (0-4)")

    def input(self, number: int) -> int:
        """The level of tool input TI ``number``."""
        self.check_input(number)
        if number == TI2:
            return self.ti2
        return (self.digital_inputs >> TOOL_INPUT_BITS[number]) & 1

    def set_input(self, number: int, on: int) -> None:
        """Set tool input TI ``number`` (0x0A14 bit, or 0x0A12 for TI2)."""
        self.check_input(number)
        if number == TI2:
            self.ti2 = 1 if on else 0
            return
        bit = 1 << TOOL_INPUT_BITS[number]
        self.digital_inputs = (self.digital_inputs | bit) if on else (self.digital_inputs & ~bit)

    def apply_mask(self, word: int) -> None:
        """Apply a 0x0A15 word: high byte selects outputs, low byte gives their values."""
        mask = (word >> 8) & 0xFF
        self.digital_outputs = (self.digital_outputs & ~mask) | (word & mask)

    def write(self, host: int, addr: int, value: float) -> None:
        """Register 127."""
        if host not in self.baud_index:
            raise ParameterError(f"host id {host}")
        if not math.isfinite(value) or value != int(value) or not 0 <= value <= 0xFFFF:
            raise ParameterError(f"value {value} is not a 16-bit integer")
        v = int(value)
        if addr == ADDR_BAUD_WRITE:
            if v >= len(BAUD_RATES):
                raise ParameterError(f"baud index {v}")
            self.baud_index[host] = v
        elif host != TOOL_HOST:
            raise ParameterError(f"address {addr:#06x} on host {host}")
        else:
            try:
                regmap.write_registers(TOOL_REGISTERS, self, addr, [v])
            except rtu.RtuError:
                raise ParameterError(f"tool address {addr:#06x} is not writable") from None

    def read(self, host: int, addr: int) -> int:
        """Register 128."""
        if host not in self.baud_index:
            raise ParameterError(f"host id {host}")
        if addr == ADDR_BAUD_READ:
            return self.baud_index[host]
        if host != TOOL_HOST:
            raise ParameterError(f"address {addr:#06x} on host {host}")
        try:
            return regmap.read_registers(TOOL_REGISTERS, self, addr, 1)[0]
        except rtu.RtuError:
            raise ParameterError(f"tool address {addr:#06x} is not readable") from None

    def _ti2_value(self) -> int:
        if not self.has_ti2:
            raise rtu.RtuError(rtu.ILLEGAL_ADDRESS)
        return self.ti2

    def _soft_reboot(self, value: int) -> None:
        if value == 1:
            self.digital_outputs = 0


#: The tool IO board's registers on host 9 (registers 127/128, the module docstring's table); the
#: RS-485 baud index (0x0A0B read, 0x1A0B write) is answered on host 11 too, by :class:`ToolIO` itself.
TOOL_REGISTERS: dict[int, regmap.Reg] = {
    ADDR_TOOL_TI2: regmap.Reg("ti2", get=ToolIO._ti2_value),
    ADDR_TOOL_DI: regmap.Reg("digital_inputs"),
    ADDR_TOOL_DO: regmap.Reg("digital_outputs", "rw", put=ToolIO.apply_mask),
    **regmap.items(ADDR_TOOL_AI[0], "analog_inputs", len(ADDR_TOOL_AI)),
    ADDR_TOOL_DO_READ: regmap.Reg("digital_outputs"),
    ADDR_SOFT_REBOOT: regmap.Reg("soft_reboot", "w", put=ToolIO._soft_reboot),
    **regmap.items(ADDR_VERSION, "version", 3),
}


class ControlBoxGpio:
    """Control box digital and analog IO with output functions (registers 131-139)."""

    def __init__(self, n_digital: int = 16) -> None:
        if n_digital not in (8, 16):
            raise ValueError("a control box has 8 or 16 digital IO")
        self.n_digital = n_digital
        self._inputs = 0xFFFF  # idle high
        self.general_outputs = 0x0000  # values set by register 134 / special IO
        self.function_outputs = 0x0000  # outputs driven on by their function
        self.analog_inputs = [0, 0]  # raw 0..4095
        self.analog_outputs = [0, 0]
        self.input_functions = [FUN_GENERAL] * 16
        self.output_functions = [FUN_GENERAL] * 16
        self.module_state = 0
        self.module_error = 0

    def _check_index(self, index: int) -> None:
        if not 0 <= index < self.n_digital:
            raise ParameterError(f"control box IO {index} (0-{self.n_digital - 1})")

    @property
    def general_mask(self) -> int:
        return sum(1 << i for i, f in enumerate(self.output_functions[: self.n_digital]) if f == FUN_GENERAL)

    @property
    def _absent(self) -> int:
        """Bits of IO 8-15 on an 8-IO box: they read high, as in the manual's 139 example."""
        return 0xFF00 if self.n_digital == 8 else 0

    @property
    def digital_inputs(self) -> int:
        return self._inputs | self._absent

    @digital_inputs.setter
    def digital_inputs(self, word: int) -> None:
        self._inputs = word & 0xFFFF

    @property
    def digital_outputs(self) -> int:
        """Output levels: general outputs as set, function outputs as driven."""
        m = self.general_mask
        return (self.general_outputs & m) | (self.function_outputs & ~m & 0xFFFF) | self._absent

    @property
    def input_function_word(self) -> int:
        """Levels of the inputs that have a function (0 and 255 are general inputs)."""
        funs = self.input_functions[: self.n_digital]
        m = sum(1 << i for i, f in enumerate(funs) if f not in GENERAL_INPUT)
        return self.digital_inputs & m

    def output(self, index: int) -> int:
        return (self.digital_outputs >> index) & 1

    def set_output(self, index: int, on: int) -> None:
        self._check_index(index)
        bit = 1 << index
        self.general_outputs = (self.general_outputs | bit) if on else (self.general_outputs & ~bit)

    def apply_word(self, word: int, high: bool) -> None:
        """A register 134 word: enable bits in the high byte, values in the low byte."""
        shift = 8 if high else 0
        mask = ((word >> 8) & 0xFF) << shift
        if mask >> self.n_digital:
            raise ParameterError(f"IO beyond {self.n_digital - 1}")
        self.general_outputs = (self.general_outputs & ~mask) | (((word & 0xFF) << shift) & mask)

    def set_analog_output(self, index: int, raw: int) -> None:
        if not 0 <= raw <= ANALOG_MAX:
            raise ParameterError(f"analog output {raw} (0-4095)")
        self.analog_outputs[index] = raw

    def set_function(self, output: bool, index: int, fun: int) -> None:
        self._check_index(index)
        (self.output_functions if output else self.input_functions)[index] = fun

    def update_functions(self, ctl: ControllerView) -> None:
        funs = self.output_functions[: self.n_digital]
        if funs.count(FUN_GENERAL) == len(funs):  # every output general-purpose (the power-on default)
            self.function_outputs = 0
            return
        active = {
            FUN_STOP: ctl.state == STATE_STOP,
            FUN_ERROR: ctl.error_code != 0,
            FUN_MOVING: bool(ctl.is_moving),
            FUN_HAS_ERROR: ctl.error_code != 0,
            FUN_HAS_WARNING: ctl.warning_code != 0,
        }
        word = 0
        for i, f in enumerate(funs):
            if f != FUN_GENERAL and active.get(f, False):
                word |= 1 << i
        self.function_outputs = word

    def state_values(self) -> dict[str, Any]:
        """Register 139 reply values (34 bytes for 8 IO, 50 for 16)."""
        m = self.general_mask
        out: dict[str, Any] = {
            "module_state": self.module_state,
            "module_error": self.module_error,
            "di_function": self.input_function_word,
            "di_config": self.digital_inputs,
            "do_function": self.function_outputs & ~m & ((1 << self.n_digital) - 1),
            "do_config": self.digital_outputs,
            "ai1": self.analog_inputs[0],
            "ai2": self.analog_inputs[1],
            "ao1": self.analog_outputs[0],
            "ao2": self.analog_outputs[1],
            "di_fun": tuple(self.input_functions[:8]),
            "do_fun": tuple(self.output_functions[:8]),
        }
        if self.n_digital == 16:
            out["fun_hi"] = tuple(self.input_functions[8:]) + tuple(self.output_functions[8:])
        return out


@dataclass(slots=True)
class IOState:
    """Every mutable value of the IO component: the tool IO board, the control box GPIO, the
    delayed and position-triggered outputs (registers 142-147) and the stop-clearing switches."""

    tool: ToolIO = field(default_factory=ToolIO)
    cgpio: ControlBoxGpio = field(default_factory=ControlBoxGpio)
    pending: list[PendingIO] = field(default_factory=list)
    cgpio_reset_on_stop: bool = False
    tgpio_reset_on_stop: bool = False
    #: Time of the last step, s, kept only while the module is not attached to a controller (an
    #: attached module reads the controller's clock, :meth:`IOModule.time`, so a period jumped
    #: over at rest leaves nothing of it behind).
    now: float = 0.0
    _last_tcp: tuple[float, float, float] | None = None
    _last_state: int | None = None


@holds(IOState)
class IOModule:
    """Controller component: tool IO, control box GPIO and special IO (registers 127-147); a device
    (:class:`~..core.device.Device`) whose registers are the tool IO board's, without an error code."""

    REGISTER_MAP: ClassVar[regmap.RegisterMap] = TOOL_REGISTERS

    def __init__(self, n_digital: int = 16, tool_version: tuple[int, int, int] = (1, 0, 0),
                 tool_ti2: bool = False) -> None:
        self.data = IOState()
        self.tool = ToolIO(tool_version, has_ti2=tool_ti2)
        self.cgpio = ControlBoxGpio(n_digital)
        self.pending: list[PendingIO] = []
        self.cgpio_reset_on_stop = False
        self.tgpio_reset_on_stop = False
        self.now = 0.0
        self._last_tcp: tuple[float, float, float] | None = None
        self._last_state: int | None = None

        #: The controller whose command buffer queues IO in its turn (:meth:`attach`); a weak
        #: reference, so checkpoints copy the IO state without the controller.
        self._ctl: weakref.ref[Any] | None = None
        #: The firmware reads the sync byte of registers 127/134/135/136 (``FirmwareProfile.io_sync_byte``).
        self.sync_io = False

    def attach(self, ctl: Controller) -> None:
        """Queue through ``ctl``'s command buffer: IO sent with sync byte 1 (profiles that read it)
        and position triggers (144, 145, 147) sent while moves are queued wait their turn there."""
        self._ctl = weakref.ref(ctl)
        self.sync_io = bool(ctl.firmware.io_sync_byte)

    @property
    def defer(self) -> Callable[[int, Callable[[], None]], None] | None:
        """Runs a task in its turn in the controller's command buffer; ``None`` when unattached."""
        ctl = self._ctl() if self._ctl is not None else None
        if ctl is None:
            return None
        return functools.partial(queue_behind_moves, ctl)

    def _in_turn(self, register: int, run: Callable[[], None], queued: bool = True) -> None:
        defer = self.defer
        if queued and defer is not None:
            defer(register, run)
        else:
            run()

    def _synced(self, v: Any) -> bool:
        """Sync byte 1 (the SDK's default): the IO change waits in the motion queue; 0: at once."""
        return self.sync_io and int(v.get("sync", 0)) == 1

    # --- inputs from outside (tests, admin channel) ------------------------------------------------

    def check_input(self, kind: str, index: int) -> None:
        """Raise (ParameterError, ValueError) unless ``kind`` ``index`` is an input this box has."""
        if kind == "cgpio":
            self.cgpio._check_index(index)
        elif kind == "tgpio":
            self.tool.check_input(index)
        elif kind in ("analog", "tool-analog", "tool_analog", "tanalog"):
            self._analog_index(index)
        else:
            raise ValueError(f"unknown input kind {kind!r} (cgpio, tgpio, analog, tool-analog)")

    def set_input(self, kind: str, index: int, value: float) -> None:
        """Play a sensor: ``cgpio`` / ``tgpio`` digital (0/1), ``analog`` (control box, V) or
        ``tool-analog`` (V). ``tgpio`` numbers are the SDK's: TI0-TI4, TI2 only on Lite 6 and 850."""
        self.check_input(kind, index)
        if kind == "cgpio":
            bit = 1 << index
            self.cgpio.digital_inputs = (self.cgpio.digital_inputs | bit) if value else (
                self.cgpio.digital_inputs & ~bit)
        elif kind == "tgpio":
            self.tool.set_input(index, 1 if value else 0)
        elif kind == "analog":
            self.cgpio.analog_inputs[index] = _volts_to_raw(value, CGPIO_AI_FULL_SCALE)
        else:
            self.tool.analog_inputs[index] = _volts_to_raw(value, TOOL_AI_FULL_SCALE)

    @staticmethod
    def _analog_index(index: int) -> None:
        if index not in (0, 1):
            raise ParameterError(f"analog IO {index} (0/1)")

    # --- report -----------------------------------------------------------------------------------

    @property
    def analog_input_volts(self) -> tuple[float, float]:
        return tuple(counts_to_volts(r) for r in self.cgpio.analog_inputs)  # type: ignore

    @property
    def analog_output_volts(self) -> tuple[float, float]:
        return tuple(counts_to_volts(r) for r in self.cgpio.analog_outputs)  # type: ignore

    def snapshot_fields(self) -> dict[str, Any]:
        """The :class:`~xarm_emu.protocol.reports.ReportSnapshot` fields this component owns."""
        st = self.cgpio.state_values()
        return {
            "cgpio_reset_on_stop": self.cgpio_reset_on_stop,
            "tgpio_reset_on_stop": self.tgpio_reset_on_stop,
            "cgpio_state": st["module_state"],
            "cgpio_error": st["module_error"],
            "cgpio_input_function": st["di_function"],
            "cgpio_input_config": st["di_config"],
            "cgpio_output_function": st["do_function"],
            "cgpio_output_config": st["do_config"],
            "analog_inputs": self.analog_input_volts,
            "analog_outputs": self.analog_output_volts,
            "input_functions": tuple(self.cgpio.input_functions),
            "output_functions": tuple(self.cgpio.output_functions),
        }

    # --- saved configuration (register 40) ---------------------------------------------------------

    def config(self) -> dict[str, Any]:
        """The IO settings register 40 saves: function configuration and stop-clearing switches."""
        return {
            "input_functions": list(self.cgpio.input_functions),
            "output_functions": list(self.cgpio.output_functions),
            "cgpio_reset_on_stop": self.cgpio_reset_on_stop,
            "tgpio_reset_on_stop": self.tgpio_reset_on_stop,
        }

    def load_config(self, data: dict[str, Any]) -> None:
        """Apply saved IO settings; malformed entries are ignored (defaults stay)."""
        for key in ("input_functions", "output_functions"):
            funs = data.get(key)
            if isinstance(funs, list) and len(funs) == 16 and all(isinstance(f, int) and 0 <= f <= 255
                                                                   for f in funs):
                setattr(self.cgpio, key, list(funs))
        for key in ("cgpio_reset_on_stop", "tgpio_reset_on_stop"):
            if isinstance(data.get(key), bool):
                setattr(self, key, data[key])

    # --- special IO (142-147) ---------------------------------------------------------------------

    def _add_pending(self, p: PendingIO) -> None:
        if len(self.pending) >= MAX_PENDING:
            raise CommandError(ERR_TOO_MANY_PENDING, "more than 36 delayed / position IO commands")
        self.pending.append(p)

    def _check_target(self, target: str, index: int, value: int) -> None:
        if target == "cgpio":
            self.cgpio._check_index(index)
        elif target == "tgpio":
            if not 0 <= index < TOOL_DIGITAL:
                raise ParameterError(f"tool output {index} (0/1)")
        else:
            self._analog_index(index)
            if not 0 <= value <= ANALOG_MAX:
                raise ParameterError(f"analog value {value}")
            return
        if value not in (0, 1):
            raise ParameterError(f"switch value {value}")

    def delayed_digital(self, target: str, index: int, on: int, delay: float) -> None:
        """Registers 142 (``cgpio``) and 143 (``tgpio``)."""
        self._check_target(target, index, on)
        if not math.isfinite(delay) or delay < 0:
            raise ParameterError(f"delay {delay}")
        self._add_pending(PendingIO(target, index, on, due=self.time() + delay))

    def time(self) -> float:
        """Controller time now, s (the end of the period that ran last); unattached, the time of
        this module's last step."""
        ctl = self._ctl() if self._ctl is not None else None
        return self.now if ctl is None else float(ctl.time)

    def position_output(self, target: str, index: int, value: int,
                        xyz: Sequence[float], radius: float) -> None:
        """Registers 144 (``cgpio``), 145 (``tgpio``) and 147 (``analog``, raw 0-4095)."""
        self._check_target(target, index, value)
        if len(xyz) != 3 or not all(math.isfinite(c) for c in xyz) or not math.isfinite(radius) or radius < 0:
            raise ParameterError("trigger point or tolerance radius")
        self._add_pending(PendingIO(target, index, value, center=(xyz[0], xyz[1], xyz[2]), radius=radius))

    def _position_in_turn(self, register: int, target: str, index: int, value: int,
                          xyz: Sequence[float], radius: float) -> None:
        """Registers 144/145/147 through the controller: a trigger sent behind queued moves is armed
        when the queue reaches it, so only armed triggers count toward the limit of 36 (C36)."""
        defer = self.defer
        if defer is None:
            self.position_output(target, index, value, xyz, radius)
            return
        self._check_target(target, index, value)
        if len(xyz) != 3 or not all(math.isfinite(c) for c in xyz) or not math.isfinite(radius) or radius < 0:
            raise ParameterError("trigger point or tolerance radius")
        point = tuple(float(c) for c in xyz)
        defer(register, functools.partial(self.position_output, target, index, value, point, radius))

    def set_reset_on_stop(self, io_type: int, on: int) -> None:
        """Register 146: io_type 0 control box, 1 tool."""
        if io_type not in (0, 1) or on not in (0, 1):
            raise ParameterError("io_type 0/1, on 0/1")
        if io_type == 0:
            self.cgpio_reset_on_stop = bool(on)
        else:
            self.tgpio_reset_on_stop = bool(on)

    def _fire(self, p: PendingIO) -> None:
        if p.target == "cgpio":
            self.cgpio.set_output(p.index, p.value)
        elif p.target == "tgpio":
            self.tool.set_output(p.index, p.value)
        else:
            self.cgpio.set_analog_output(p.index, p.value)

    @staticmethod
    def _reached(p: PendingIO, a: tuple[float, float, float] | None, b: tuple[float, float, float]) -> bool:
        c = p.center
        assert c is not None
        if p.radius <= 0:
            return math.dist(b, c) <= ZERO_RADIUS_EPS
        if a is None or a == b:
            return math.dist(b, c) <= p.radius
        # Closest point of segment a-b to the centre.
        ab = [b[i] - a[i] for i in range(3)]
        ac = [c[i] - a[i] for i in range(3)]
        t = max(0.0, min(1.0, sum(x * y for x, y in zip(ab, ac, strict=True)) / sum(x * x for x in ab)))
        closest = [a[i] + t * ab[i] for i in range(3)]
        return math.dist(closest, c) <= p.radius

    def step(self, dt: float, ctl: ControllerView) -> None:
        d = self.data  # written through directly: this runs every period
        if self._ctl is None:
            d.now = ctl.time
        now = ctl.time
        state = ctl.state
        if state == STATE_STOP and d._last_state not in (None, STATE_STOP):
            d.pending.clear()
            if d.cgpio_reset_on_stop:
                d.cgpio.general_outputs = 0
            if d.tgpio_reset_on_stop:
                d.tool.digital_outputs = 0
        d._last_state = state
        if not d.pending:  # nothing delayed (the usual period)
            d._last_tcp = None
            self.cgpio.update_functions(ctl)
            return
        if not any(p.due is None for p in self.pending):
            # No position trigger pending: skip the TCP read (it costs forward kinematics).
            self._last_tcp = None
            tcp3 = None
        else:
            tcp = tuple(float(v) for v in ctl.tcp_position)
            tcp3 = (tcp[0], tcp[1], tcp[2])
        if self.pending:
            keep: list[PendingIO] = []
            for p in self.pending:
                if p.due is not None:
                    hit = now >= p.due - 1e-9
                else:
                    assert tcp3 is not None
                    hit = self._reached(p, self._last_tcp, tcp3)
                if hit:
                    self._fire(p)
                else:
                    keep.append(p)
            self.pending = keep
        if tcp3 is not None:
            self._last_tcp = tcp3
        self.cgpio.update_functions(ctl)

    def idle_until(self, ctl: ControllerView) -> float:
        """Idle (:func:`~..core.interface.idle_until`) until the first delayed output is due, once a step has
        seen the present motion state; a position trigger the last step did not fire cannot fire
        while the TCP rests where that step saw it."""
        if self._last_state != ctl.state:
            return NOT_IDLE
        due = math.inf
        for p in self.pending:
            if p.due is not None:
                due = min(due, p.due - 1e-9)
            elif self._last_tcp != tuple(float(v) for v in ctl.tcp_position):
                return NOT_IDLE
        return due

    # --- the device interface (core/device.py): the IO has no error code of its own ----------------

    @property
    def error(self) -> int:
        return 0

    def inject_error(self, code: int) -> None:
        raise ValueError("the IO has no error code of its own")

    def clear_error(self) -> None:
        pass

    def status_fields(self) -> dict[str, Any]:
        return {"tool_outputs": self.tool.digital_outputs, "tool_inputs": self.tool.digital_inputs,
                "cgpio_outputs": self.cgpio.digital_outputs, "cgpio_inputs": self.cgpio.digital_inputs}

    # --- register table adapter -------------------------------------------------------------------

    def handlers(self) -> dict[int, Handler]:
        """This component's registers (:data:`BINDINGS`), bound to it."""
        return bind_component(self, BINDINGS)

    def cgpio_set_digital(self, words: Sequence[int]) -> None:
        """Register 134: one word for IO 0-7, or ``[word 0-7, word 8-15]``."""
        for i, w in enumerate(words[:2]):
            self.cgpio.apply_word(w, high=bool(i))


# --- the registers of the IO component (manual section 2.1.3, registers 127-147) -----------------
# Each handler reads ``io.cgpio`` / ``io.tool`` at call time: a restored checkpoint replaces them.


def tool_write(io: IOModule, v: Values) -> None:
    """Register 127: write a tool board register (tool IO, baud rate, ...)."""
    args = (int(v["host"]), int(v["addr"]), float(v["value"]))
    if not io._synced(v):
        io.tool.write(*args)
        return
    copy.deepcopy(io.tool).write(*args)  # refuse bad values now, apply in turn
    io._in_turn(127, functools.partial(io.tool.write, *args))


def tool_read(io: IOModule, v: Values) -> dict[str, Any]:
    """Register 128: read a tool board register."""
    return {"value": io.tool.read(int(v["host"]), int(v["addr"]))}


def cgpio_digital_inputs(io: IOModule, v: Values) -> dict[str, Any]:
    """Register 131: the control box digital inputs."""
    return {"digital": io.cgpio.digital_inputs}


def cgpio_analog_input(io: IOModule, v: Values, *, index: int) -> dict[str, Any]:
    """Registers 132/133: control box analog input 0/1."""
    return {"analog": io.cgpio.analog_inputs[index]}


def cgpio_digital_outputs(io: IOModule, v: Values) -> None:
    """Register 134: the control box digital outputs, one word or two (IO 8-15)."""
    words = [int(v["digital"])]
    if "digital_hi" in v:
        words.append(int(v["digital_hi"]))
    if not io._synced(v):
        io.cgpio_set_digital(words)
        return
    copy.deepcopy(io.cgpio).apply_word(words[0], high=False)
    io._in_turn(134, functools.partial(io.cgpio_set_digital, words))


def cgpio_analog_output(io: IOModule, v: Values, *, index: int) -> None:
    """Registers 135/136: control box analog output 0/1."""
    raw = int(v["analog"])
    if not io._synced(v):
        io.cgpio.set_analog_output(index, raw)
        return
    copy.deepcopy(io.cgpio).set_analog_output(index, raw)
    io._in_turn(135 + index, functools.partial(io.cgpio.set_analog_output, index, raw))


def cgpio_function(io: IOModule, v: Values, *, output: bool) -> None:
    """Registers 137/138: the function of a control box digital input / output."""
    io.cgpio.set_function(output, int(v["ionum"]), int(v["fun"]))


def cgpio_states(io: IOModule, v: Values) -> dict[str, Any]:
    """Register 139: every control box IO value and function."""
    return io.cgpio.state_values()


def delayed_digital(io: IOModule, v: Values, *, target: str) -> None:
    """Registers 142/143: a control box / tool digital output set after a delay."""
    io.delayed_digital(target, int(v["ionum"]), int(v["on"]), float(v["delay"]))


def position_output(io: IOModule, v: Values, *, register: int, target: str) -> None:
    """Registers 144/145/147: a control box digital, tool digital or analog output set when the TCP
    reaches a position."""
    value = int(v["value"] if target == "analog" else v["on"])
    io._position_in_turn(register, target, int(v["ionum"]), value, v["xyz"], float(v["tol_r"]))


def reset_on_stop(io: IOModule, v: Values) -> dict[str, Any]:
    """Register 146: reset the outputs when the arm stops; the manual's reply echoes the switch."""
    io.set_reset_on_stop(int(v["io_type"]), int(v["on"]))
    return {"cmdnum": int(v["on"])}


#: The registers of the IO component (:class:`~xarm_emu.controller.core.interface.Binding`).
BINDINGS: tuple[Binding, ...] = (
    Binding(127, tool_write, IOModule),
    Binding(128, tool_read, IOModule),
    Binding(131, cgpio_digital_inputs, IOModule),
    Binding(132, functools.partial(cgpio_analog_input, index=0), IOModule),
    Binding(133, functools.partial(cgpio_analog_input, index=1), IOModule),
    Binding(134, cgpio_digital_outputs, IOModule),
    Binding(135, functools.partial(cgpio_analog_output, index=0), IOModule),
    Binding(136, functools.partial(cgpio_analog_output, index=1), IOModule),
    Binding(137, functools.partial(cgpio_function, output=False), IOModule),
    Binding(138, functools.partial(cgpio_function, output=True), IOModule),
    Binding(139, cgpio_states, IOModule),
    Binding(142, functools.partial(delayed_digital, target="cgpio"), IOModule),
    Binding(143, functools.partial(delayed_digital, target="tgpio"), IOModule),
    Binding(144, functools.partial(position_output, register=144, target="cgpio"), IOModule),
    Binding(145, functools.partial(position_output, register=145, target="tgpio"), IOModule),
    Binding(146, reset_on_stop, IOModule),
    Binding(147, functools.partial(position_output, register=147, target="analog"), IOModule),
)
