"""The simulated xArm Gripper through register 124 PDUs as the SDK sends them (manual section 3.3),
and the Modbus-RTU codec's handling of malformed data."""

from __future__ import annotations

import math
import struct

import pytest
from helpers import FakeView as View
from hypothesis import given, settings
from hypothesis import strategies as st

from xarm_emu.controller.core.interface import PERIOD, ParameterError
from xarm_emu.controller.devices.gripper import (
    G_POSITION_DEVIATION,
    G_SOFT_LIMIT,
    G_SPEED_OVERLIMIT,
    GripperModule,
    XArmGripper,
)
from xarm_emu.protocol import rtu
from xarm_emu.protocol.registers import REGISTERS


def send(mod: GripperModule, pdu: bytes, host: int = 9) -> bytes:
    """Through the register table: request params -> handler -> reply params, minus the host byte."""
    reg = REGISTERS[124]
    values = mod.handlers()[124](reg.request.decode(bytes([host]) + pdu))
    out = reg.reply.encode(values)
    assert out[0] == host
    return out[1:]


def write(mod: GripperModule, addr: int, *words: int) -> bytes:
    return send(mod, rtu.write_multiple_request(8, addr, words))


def read(mod: GripperModule, addr: int, count: int = 1) -> tuple[int, ...]:
    slave, func, values = rtu.parse_reply(send(mod, rtu.read_request(8, addr, count)))
    assert (slave, func) == (8, 3)
    return values


def position(mod: GripperModule) -> int:
    hi, lo = read(mod, 0x0702, 2)
    return struct.unpack(">i", struct.pack(">HH", hi, lo))[0]


def set_position(mod: GripperModule, pulse: int) -> bytes:
    # Exactly the SDK's frame: 08 10 0700 0002 04 <s32 BE>.
    pdu = bytes.fromhex("08 10 07 00 00 02 04") + struct.pack(">i", pulse)
    assert pdu == rtu.write_multiple_request(8, 0x0700, struct.unpack(">HH", struct.pack(">i", pulse)))
    return send(mod, pdu)


def test_enable_speed_move_reaches_target_in_predicted_time() -> None:
    mod = GripperModule()
    assert send(mod, bytes.fromhex("08 10 01 00 00 01 02 00 01")) == bytes.fromhex("08 10 01 00 00 01")
    assert write(mod, 0x0101, 0) == bytes.fromhex("08 10 01 01 00 01")
    write(mod, 0x0303, 5000)
    assert set_position(mod, 400) == bytes.fromhex("08 10 07 00 00 02")
    assert read(mod, 0x000F) == (0,)
    # Speed 5000 r/min crosses the whole 0..850 stroke in 1 s, so 400 pulses take 400/850 s.
    predicted = 400 / 850
    view, t, steps, last = View(), 0.0, 0, -1
    assert read(mod, 0x0000)[0] & 0x03 == 1  # moving
    while read(mod, 0x0000)[0] & 0x03 == 1:  # arrival = the status leaves "moving"
        now = position(mod)
        assert last < now < 400  # short of the target and advancing on every period
        last = now
        mod.step(PERIOD, view)
        t += PERIOD
        steps += 1
        assert steps < 1000
    assert position(mod) == 400
    assert predicted <= t + 1e-9 < predicted + PERIOD
    assert steps == math.ceil(predicted / PERIOD)
    assert read(mod, 0x0000) == ((2 << 2) | 0,)  # enabled, stopped
    # Closing back at speed 1500 (the manual's example speed) takes 400 / 255 s.
    write(mod, 0x0303, 1500)
    set_position(mod, 0)
    n = 0
    while read(mod, 0x0000)[0] & 0x03 == 1:
        mod.step(PERIOD, view)
        n += 1
    assert position(mod) == 0
    assert n == math.ceil(400 / 850 * (5000 / 1500) / PERIOD)  # the time scales as 1 / speed


def test_full_range_at_speed_5000_takes_a_second() -> None:
    g = XArmGripper()
    g.set_enable(1)
    g.set_speed(5000)
    g.set_target(850)
    n = 0
    while g.position_pulses != 850:
        g.step(PERIOD, View())
        n += 1
    assert n * PERIOD == pytest.approx(1.0, abs=PERIOD)


def test_position_command_to_disabled_gripper_is_g23() -> None:
    mod = GripperModule()
    write(mod, 0x0303, 5000)
    set_position(mod, 300)
    assert read(mod, 0x000F) == (G_POSITION_DEVIATION,) == (0x17,)
    mod.step(PERIOD, View())
    assert position(mod) == 0
    assert read(mod, 0x0000)[0] & 0x03 == 3  # fault


@pytest.mark.parametrize("pulse", [851, -1, 100000])
def test_out_of_range_position_is_g25(pulse: int) -> None:
    mod = GripperModule()
    write(mod, 0x0100, 1)
    write(mod, 0x0303, 5000)
    set_position(mod, pulse)
    assert read(mod, 0x000F) == (G_SOFT_LIMIT,) == (0x19,)
    assert not mod.gripper.enabled
    for _ in range(10):
        mod.step(PERIOD, View())
    assert position(mod) == 0


@pytest.mark.parametrize("speed", [0, 10001, 65535])
def test_out_of_range_speed_is_g12(speed: int) -> None:
    mod = GripperModule()
    write(mod, 0x0100, 1)
    write(mod, 0x0303, speed)
    assert read(mod, 0x000F) == (G_SPEED_OVERLIMIT,) == (0x0C,)


def test_injected_error_stops_motion_clear_and_reenable() -> None:
    mod = GripperModule()
    write(mod, 0x0100, 1)
    write(mod, 0x0303, 5000)
    set_position(mod, 800)
    for _ in range(50):
        mod.step(PERIOD, View())
    mid = position(mod)
    assert 0 < mid < 800
    mod.gripper.inject_error(0x22)
    for _ in range(50):
        mod.step(PERIOD, View())
    assert position(mod) == mid
    assert read(mod, 0x000F) == (0x22,)
    write(mod, 0x0100, 1)  # enabling does not override an error
    assert read(mod, 0x0100) == (0,)
    send(mod, bytes.fromhex("08 10 01 09 00 01 02 00 01"))  # the manual's clear frame
    assert read(mod, 0x000F) == (0,)
    write(mod, 0x0100, 1)
    set_position(mod, 800)
    for _ in range(300):
        mod.step(PERIOD, View())
    assert position(mod) == 800


def test_versions_and_status_registers() -> None:
    mod = GripperModule()
    assert read(mod, 0x0801, 3) == mod.gripper.version
    assert read(mod, 0x0000) == (0,)  # disabled, stopped


def test_wrong_baud_means_no_answer() -> None:
    baud = [11]
    mod = GripperModule(tool_baud=lambda: baud[0])
    assert rtu.parse_reply(send(mod, rtu.read_request(8, 0x000F, 1)))[1] == 0x03
    baud[0] = 5
    assert send(mod, rtu.read_request(8, 0x000F, 1)) == bytes((8, 0x83, rtu.GATEWAY_NO_RESPONSE))


def test_other_hosts() -> None:
    mod = GripperModule()
    assert send(mod, rtu.read_request(8, 0x000F, 1), host=11) == bytes((8, 0x83, 0x0B))
    with pytest.raises(ParameterError):
        mod.rtu(3, rtu.read_request(8, 0, 1))


# --- RTU codec ------------------------------------------------------------------------------------


@pytest.mark.parametrize("pdu,reply", [
    ("08", "08 80 01"),  # no function code
    ("08 05 00 00 FF 00", "08 85 01"),  # unsupported function
    ("08 03 00 0F", "08 83 03"),  # truncated read
    ("08 03 00 0F 00 00", "08 83 03"),  # zero quantity
    ("08 03 00 0F 00 7E", "08 83 03"),  # above 125 registers
    ("08 03 12 34 00 01", "08 83 02"),  # unknown register
    ("08 10 01 00 00 01 02 00", "08 90 03"),  # byte count says 2, 1 given
    ("08 10 01 00 00 02 02 00 01", "08 90 03"),  # quantity/byte count mismatch
    ("08 10 07 02 00 02 04 00 00 00 01", "08 90 02"),  # current position is read-only
    ("08 06 01 00 00 02", "08 86 03"),  # enable must be 0/1
    ("07 03 00 00 00 01", "07 83 0B"),  # nobody at slave 7
])
def test_malformed_rtu_gets_exception_reply(pdu: str, reply: str) -> None:
    mod = GripperModule()
    assert send(mod, bytes.fromhex(pdu)) == bytes.fromhex(reply)


def test_empty_rtu_never_raises() -> None:
    assert GripperModule().rtu(9, b"") == bytes((0, 0x80, rtu.ILLEGAL_VALUE))


def test_write_single_echo() -> None:
    mod = GripperModule()
    assert send(mod, bytes.fromhex("08 06 01 00 00 01")) == bytes.fromhex("08 06 01 00 00 01")
    assert mod.gripper.enabled


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=40))
def test_fuzzed_rtu_always_answers(pdu: bytes) -> None:
    mod = GripperModule()
    out = mod.rtu(9, pdu)
    slave, func, _ = rtu.parse_reply(out)
    if pdu[:1]:
        assert slave == pdu[0]
    if func & 0x80:
        assert out[2] in (1, 2, 3, 4, 0x0B)


def test_position_without_a_speed_first_moves_at_the_power_on_speed() -> None:
    from xarm_emu.controller.devices.gripper import DEFAULT_SPEED, XArmGripper

    g = XArmGripper()
    g.set_enable(1)
    g.set_target(500)
    steps = 0
    while g.position != 500 and steps < 10000:
        g.step(0.004, View())
        steps += 1
    assert g.position == 500
    assert steps * 0.004 == pytest.approx(500 / 850 * (5000 / DEFAULT_SPEED), abs=0.008)


@pytest.mark.parametrize("speed", [8000, 10000])
def test_speed_above_5000_is_accepted_and_moves_at_the_top_speed(speed: int) -> None:
    g = XArmGripper()
    g.set_enable(1)
    g.set_speed(speed)
    assert (g.error, g.speed) == (0, speed)
    g.set_target(850)
    n = 0
    while g.position_pulses != 850:
        g.step(PERIOD, View())
        n += 1
    assert n * PERIOD == pytest.approx(1.0, abs=PERIOD)  # as at 5000: the fingers top out there
