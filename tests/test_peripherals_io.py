"""Tool IO, control box GPIO and special IO (registers 127-147) through the register table,
stepped with a fake ControllerView."""

from __future__ import annotations

import math
import struct
from typing import Any

import pytest
from helpers import FakeView as View

from xarm_emu.controller.core.interface import PERIOD, CommandError, ParameterError
from xarm_emu.controller.devices.io import IOModule
from xarm_emu.protocol.registers import REGISTERS


def call(io: IOModule, code: int, params: bytes) -> bytes:
    reg = REGISTERS[code]
    values = io.handlers()[code](reg.request.decode(params))
    return reg.reply.encode(values or {})


def tgpio_w(io: IOModule, addr: int, value: float, sync: bool = True) -> bytes:
    return call(io, 127, struct.pack(">BH", 9, addr) + struct.pack("<f", value) + (b"\x01" if sync else b""))


def tgpio_r(io: IOModule, addr: int, host: int = 9) -> int:
    return struct.unpack(">i", call(io, 128, struct.pack(">BH", host, addr)))[0]


class Clock:
    """Steps an IOModule like the controller does, every PERIOD."""

    def __init__(self, io: IOModule, view: View | None = None) -> None:
        self.io, self.view, self.k = io, view or View(), 0

    def step(self, **changes: Any) -> None:
        self.k += 1
        self.view.time = self.k * PERIOD
        for k, v in changes.items():
            setattr(self.view, k, v)
        self.io.step(PERIOD, self.view)


# --- tool IO --------------------------------------------------------------------------------------


@pytest.mark.parametrize("io_api,value,word", [
    (0, 1, 257), (0, 0, 256), (1, 1, 514), (1, 0, 512),  # the manual's encodings
])
def test_tool_outputs_mask_encoding(io_api: int, value: int, word: int) -> None:
    io = IOModule()
    io.tool.digital_outputs = 0b10 if io_api == 0 else 0b01  # the other output stays as it is
    other = io.tool.digital_outputs
    assert tgpio_w(io, 0x0A15, float(word)) == b""
    assert io.tool.output(io_api) == value
    assert tgpio_r(io, 0x0A18) == (other | (value << io_api))


def test_tool_output_sdk_bytes() -> None:
    io = IOModule()
    # set_tgpio_digital(0, 1) sends 09 0a15 00808043 01 (as the SDK builds it).
    call(io, 127, bytes.fromhex("09 0a 15 00 80 80 43 01"))
    assert tgpio_r(io, 0x0A18) == 1


@pytest.mark.parametrize("bad", [257.5, -1.0, 70000.0, math.nan, math.inf])
def test_tool_write_rejects_bad_values(bad: float) -> None:
    with pytest.raises(ParameterError):
        tgpio_w(IOModule(), 0x0A15, bad)


def test_tool_inputs_and_analog() -> None:
    io = IOModule()
    assert tgpio_r(io, 0x0A14) == 0
    io.set_input("tgpio", 1, 1)
    assert tgpio_r(io, 0x0A14) == 0b10
    io.set_input("tool-analog", 0, 1.65)
    io.set_input("tool-analog", 1, 5.0)  # clamps at full scale
    assert tgpio_r(io, 0x0A16) == round(1.65 / 3.3 * 4095) == 2048
    assert tgpio_r(io, 0x0A17) == 4095
    assert tgpio_r(io, 0x0A16) * 3.3 / 4095 == pytest.approx(1.65, abs=3.3 / 4095)


def test_baud_index_and_soft_reboot() -> None:
    io = IOModule()
    assert tgpio_r(io, 0x0A0B) == 11  # 2,000,000 bps: what the SDK expects for the gripper
    tgpio_w(io, 0x1A0B, 5.0, sync=False)
    assert tgpio_r(io, 0x0A0B) == 5
    assert tgpio_r(io, 0x0A0B, host=11) == 11  # the control box RS-485 is separate
    with pytest.raises(ParameterError):
        tgpio_w(io, 0x1A0B, 13.0)
    tgpio_w(io, 0x0A15, 257.0)
    tgpio_w(io, 0x0607, 1.0)
    assert tgpio_r(io, 0x0A18) == 0
    with pytest.raises(ParameterError):
        tgpio_r(io, 0x0A14, host=5)


# --- control box GPIO -----------------------------------------------------------------------------


def test_cgpio_digital_words() -> None:
    io = IOModule(n_digital=16)
    assert call(io, 131, b"") == b"\xff\xff"  # inputs idle high
    io.set_input("cgpio", 3, 0)
    io.set_input("cgpio", 12, 0)
    assert call(io, 131, b"") == struct.pack(">H", 0xFFFF & ~(1 << 3) & ~(1 << 12))
    call(io, 134, bytes.fromhex("04 04 01"))  # set_cgpio_digital(2, 1), SDK bytes with sync
    call(io, 134, struct.pack(">HHB", 0, 0x0101 << 5, 1))  # set_cgpio_digital(13, 1): two words
    assert io.cgpio.digital_outputs == (1 << 2) | (1 << 13)
    call(io, 134, struct.pack(">H", 0x0400))  # CO2 off, others untouched
    assert io.cgpio.digital_outputs == 1 << 13
    st = REGISTERS[139].reply.decode(call(io, 139, b""))
    assert st["do_config"] == 1 << 13 and st["di_config"] == 0xFFFF & ~(1 << 3) & ~(1 << 12)


def test_cgpio_8_io_box_rejects_high_io() -> None:
    io = IOModule(n_digital=8)
    with pytest.raises(ParameterError):
        call(io, 134, struct.pack(">HH", 0, 0x0101))
    with pytest.raises(ParameterError):
        io.set_input("cgpio", 8, 0)
    assert len(call(io, 139, b"")) == 34


def test_cgpio_analog() -> None:
    io = IOModule()
    io.set_input("analog", 1, 5.0)
    assert call(io, 133, b"") == struct.pack(">H", round(5.0 / 10 * 4095))
    call(io, 135, struct.pack(">HB", int(2.5 / 10 * 4095), 1))
    call(io, 136, struct.pack(">H", 4095))
    assert io.analog_output_volts == pytest.approx((2.5, 10.0), abs=10 / 4095)
    with pytest.raises(ParameterError):
        call(io, 135, struct.pack(">H", 4096))
    f = io.snapshot_fields()
    assert f["analog_inputs"][1] == pytest.approx(5.0, abs=10 / 4095)
    assert f["analog_outputs"] == io.analog_output_volts


def test_output_functions_follow_controller_state() -> None:
    io = IOModule()
    clock = Clock(io)
    call(io, 138, bytes((0, 0)))  # CO0: system in STOP state
    call(io, 138, bytes((1, 1)))  # CO1: system error
    call(io, 138, bytes((2, 2)))  # CO2: xArm is operating
    call(io, 134, struct.pack(">H", 0x0707))  # general writes do not override functions
    clock.step(state=2)
    assert io.cgpio.digital_outputs & 0b111 == 0
    clock.step(state=1, is_moving=True)
    assert io.cgpio.digital_outputs & 0b111 == 0b100
    clock.step(state=4, is_moving=False, error_code=22)
    assert io.cgpio.digital_outputs & 0b111 == 0b011
    st = REGISTERS[139].reply.decode(call(io, 139, b""))
    assert st["do_function"] == 0b011 and st["do_fun"][:3] == (0, 1, 2)
    call(io, 138, bytes((2, 255)))  # back to general: its written value shows
    clock.step(state=0, error_code=0)
    assert io.cgpio.digital_outputs & 0b111 == 0b100


def test_input_functions_recorded() -> None:
    io = IOModule()
    call(io, 137, bytes((4, 12)))
    io.set_input("cgpio", 4, 1)
    st = REGISTERS[139].reply.decode(call(io, 139, b""))
    assert st["di_fun"][4] == 12 and st["di_function"] == 1 << 4
    with pytest.raises(ParameterError):
        call(io, 137, bytes((16, 1)))


# --- special IO -----------------------------------------------------------------------------------


@pytest.mark.parametrize("code,target", [(142, "cgpio"), (143, "tgpio")])
def test_delayed_output_fires_within_one_period(code: int, target: str) -> None:
    io = IOModule()
    clock = Clock(io)
    for _ in range(10):
        clock.step()
    t_cmd, delay = clock.view.time, 0.25
    call(io, code, struct.pack("<BBf", 1, 1, delay))
    out = io.cgpio if target == "cgpio" else io.tool
    fired = None
    for _ in range(200):
        clock.step()
        if out.output(1) and fired is None:
            fired = clock.view.time
    assert fired is not None
    assert t_cmd + delay - 1e-9 <= fired < t_cmd + delay + PERIOD
    assert not io.pending


def _pass_through(io: IOModule, clock: Clock, start: float, end: float, speed: float) -> list[float]:
    """Moves the TCP along x at ``speed`` mm/s; returns the times outputs changed."""
    changes, last = [], (io.cgpio.digital_outputs, io.tool.digital_outputs, tuple(io.cgpio.analog_outputs))
    x = start
    while x < end:
        x = min(end, x + speed * PERIOD)
        clock.step(tcp_position=(x, 0.0, 200.0), is_moving=True)
        now = (io.cgpio.digital_outputs, io.tool.digital_outputs, tuple(io.cgpio.analog_outputs))
        if now != last:
            changes.append(clock.view.time)
            last = now
    return changes


def test_position_trigger_fires_once_within_one_period_of_entering() -> None:
    io = IOModule()
    clock = Clock(io)
    clock.step(tcp_position=(0.0, 0.0, 200.0))
    # The manual's example: CO0 on at (400, 0, 200), 50 mm radius.
    call(io, 144, bytes.fromhex("00 01 00 00 C8 43 00 00 00 00 00 00 48 43 00 00 48 42"))
    t0, speed = clock.view.time, 300.0
    changes = _pass_through(io, clock, 0.0, 800.0, speed)
    enter = t0 + 350.0 / speed  # x = 350 is the sphere's near surface
    assert len(changes) == 1 and enter <= changes[0] < enter + PERIOD
    assert io.cgpio.output(0) == 1 and not io.pending
    io.cgpio.set_output(0, 0)  # exactly once: passing again does nothing
    clock.step(tcp_position=(0.0, 0.0, 200.0))
    assert _pass_through(io, clock, 0.0, 800.0, speed) == []


def test_position_trigger_small_sphere_fast_pass() -> None:
    io = IOModule()
    clock = Clock(io)
    clock.step(tcp_position=(0.0, 0.0, 200.0))
    # 1 mm sphere, TCP moving 4 mm per period: the path between samples crosses it.
    call(io, 145, struct.pack("<BB4f", 1, 1, 401.0, 0.5, 200.0, 1.0))
    changes = _pass_through(io, clock, 0.0, 800.0, 1000.0)
    assert len(changes) == 1 and io.tool.output(1) == 1


def test_position_trigger_analog_and_zero_radius() -> None:
    io = IOModule()
    clock = Clock(io)
    clock.step(tcp_position=(0.0, 0.0, 200.0))
    call(io, 147, struct.pack(">BH", 1, 2048) + struct.pack("<4f", 400.0, 0.0, 200.0, 10.0))
    # Zero radius at a point no sample lands on: missed, as the manual warns.
    call(io, 144, struct.pack("<BB4f", 3, 1, 401.7, 0.0, 200.0, 0.0))
    # Zero radius at the end point of the move: the arm stops there, so it fires.
    call(io, 144, struct.pack("<BB4f", 4, 1, 800.0, 0.0, 200.0, 0.0))
    _pass_through(io, clock, 0.0, 800.0, 300.0)
    assert io.cgpio.analog_outputs[1] == 2048
    assert io.cgpio.output(3) == 0 and io.cgpio.output(4) == 1
    assert len(io.pending) == 1


def test_37th_pending_command_is_c36() -> None:
    io = IOModule()
    for i in range(18):
        call(io, 142, struct.pack("<BBf", i % 16, 1, 10.0))
        call(io, 145, struct.pack("<BB4f", 0, 1, 1000.0, 0.0, 0.0, 1.0))
    assert len(io.pending) == 36
    with pytest.raises(CommandError) as exc:
        call(io, 143, struct.pack("<BBf", 0, 1, 1.0))
    assert exc.value.code == 36
    clock = Clock(io)
    for _ in range(int(10.0 / PERIOD) + 2):
        clock.step(tcp_position=(0.0, 0.0, 0.0))
    assert len(io.pending) == 18  # delayed ones fired, freeing room
    call(io, 143, struct.pack("<BBf", 0, 1, 1.0))


@pytest.mark.parametrize("code,params", [
    (142, struct.pack("<BBf", 16, 1, 1.0)),
    (142, struct.pack("<BBf", 0, 2, 1.0)),
    (143, struct.pack("<BBf", 2, 1, 1.0)),
    (142, struct.pack("<BBf", 0, 1, -1.0)),
    (142, struct.pack("<BBf", 0, 1, math.nan)),
    (144, struct.pack("<BB4f", 0, 1, 0, 0, 0, -1.0)),
    (147, struct.pack(">BH", 0, 5000) + struct.pack("<4f", 0, 0, 0, 1)),
    (146, bytes((2, 1))),
])
def test_special_io_parameter_errors(code: int, params: bytes) -> None:
    io = IOModule()
    with pytest.raises(ParameterError):
        call(io, code, params)
    assert not io.pending


def test_stop_clears_outputs_when_configured() -> None:
    io = IOModule()
    clock = Clock(io)
    clock.step(state=0)
    call(io, 146, bytes((0, 1)))
    io.cgpio.set_output(5, 1)
    io.tool.set_output(1, 1)
    call(io, 142, struct.pack("<BBf", 6, 1, 5.0))
    clock.step(state=4)
    assert io.cgpio.output(5) == 0 and io.tool.output(1) == 1  # only the control box was configured
    assert not io.pending  # STOP drops what was waiting
    clock.step(state=0)
    call(io, 146, bytes((1, 1)))
    call(io, 146, bytes((0, 0)))
    io.cgpio.set_output(5, 1)
    clock.step(state=4)
    assert io.cgpio.output(5) == 1 and io.tool.output(1) == 0
    f = io.snapshot_fields()
    assert (f["cgpio_reset_on_stop"], f["tgpio_reset_on_stop"]) == (False, True)
    assert call(io, 146, bytes((1, 1))) == b"\x00\x01"


def test_set_input_rejects_unknown_kind() -> None:
    with pytest.raises(ValueError):
        IOModule().set_input("servo", 0, 1)
