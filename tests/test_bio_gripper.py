"""The simulated BIO gripper through register 124 PDUs as the SDK's ``*_bio_gripper*`` functions
send them: enable, speed, force, positions in both control modes, status, errors, object detection,
serial number and version; stepped time."""

from __future__ import annotations

import struct

import pytest
from helpers import FakeView as View

from xarm_emu.controller.core.interface import PERIOD
from xarm_emu.controller.devices.bio_gripper import (
    ENABLE_TIME,
    PULSE_MAX,
    SERIAL,
    SPEED_TO_PULSES,
    VERSION,
    BioGripper,
    mm_to_pulses,
)
from xarm_emu.controller.devices.gripper import GripperModule
from xarm_emu.controller.emulator import Emulator
from xarm_emu.protocol import rtu
from xarm_emu.protocol.registers import REGISTERS


def module() -> tuple[GripperModule, BioGripper]:
    dev = BioGripper()
    return GripperModule(device=dev, tool_baud=lambda: 11), dev


def send(mod: GripperModule, pdu: bytes) -> bytes:
    reg = REGISTERS[124]
    return reg.reply.encode(mod.handlers()[124](reg.request.decode(bytes([9]) + pdu)))[1:]


def write1(mod: GripperModule, addr: int, value: int) -> bytes:
    return send(mod, bytes([0x08, 0x06]) + struct.pack(">HH", addr, value))


def read(mod: GripperModule, addr: int, count: int = 1) -> tuple[int, ...]:
    slave, func, values = rtu.parse_reply(send(mod, struct.pack(">BBhh", 8, 3, addr, count)))
    assert (slave, func) == (8, 3)
    return values


def target(mod: GripperModule, value: int) -> bytes:
    """The SDK's 08 10 0700 0002 04 <s32 BE>."""
    return send(mod, bytes.fromhex("08 10 07 00 00 02 04") + struct.pack(">i", value))


def g2_move(mod: GripperModule, pos: int, speed: int = 2000, force: int = 100) -> bytes:
    """The SDK's 08 10 0C00 0005 0A 0001 <speed> <force> <s32 pos>."""
    return send(mod, bytes.fromhex("08 10 0C 00 00 05 0A 00 01") + struct.pack(">hhi", speed, force, pos))


def position(mod: GripperModule) -> int:
    hi, lo = read(mod, 0x0702, 2)
    return struct.unpack(">i", struct.pack(">HH", hi, lo))[0]


def run(mod: GripperModule, seconds: float) -> None:
    for _ in range(round(seconds / PERIOD)):
        mod.step(PERIOD, View())


def enabled() -> tuple[GripperModule, BioGripper]:
    mod, dev = module()
    write1(mod, 0x0100, 1)
    run(mod, ENABLE_TIME + PERIOD)
    return mod, dev


def test_enable_goes_through_enabling() -> None:
    mod, _ = module()
    assert read(mod, 0x0000) == (0,)
    assert write1(mod, 0x0100, 1) == bytes.fromhex("08 06 01 00 00 01")  # a write single is echoed
    assert read(mod, 0x0000)[0] >> 2 & 0x03 == 1  # enabling
    run(mod, ENABLE_TIME + PERIOD)
    assert read(mod, 0x0000) == (2 << 2,)  # enabled, stopped
    write1(mod, 0x0100, 0)
    assert read(mod, 0x0000) == (0,)


def test_open_close_mode_moves_in_mm_at_the_set_speed() -> None:
    mod, dev = enabled()
    assert position(mod) == PULSE_MAX
    write1(mod, 0x0303, 1000)
    target(mod, 71)  # the SDK's close_bio_gripper on this version
    assert read(mod, 0x0000)[0] & 0x03 == 1  # moving
    n = 0
    while read(mod, 0x0000)[0] & 0x03 == 1:
        mod.step(PERIOD, View())
        n += 1
    assert position(mod) == 0 and dev.opening_mm == pytest.approx(71.0, abs=0.01)
    assert n * PERIOD == pytest.approx(PULSE_MAX / (1000 * SPEED_TO_PULSES), abs=PERIOD)
    assert read(mod, 0x0700, 2) == (0, 71)  # the target register reads back as written


def test_g2_move_sets_speed_force_and_position_at_once() -> None:
    mod, dev = enabled()
    assert g2_move(mod, 100, speed=3000, force=40) == bytes.fromhex("08 10 0C 00 00 05")
    run(mod, 2.0)
    assert (read(mod, 0x0303), read(mod, 0x0506)) == ((3000,), (40,))
    assert position(mod) == round(mm_to_pulses(100))


def test_position_loop_mode_takes_pulses_after_the_reboot() -> None:
    mod, dev = enabled()
    write1(mod, 0x110A, 1)
    assert read(mod, 0x010A) == (0,)  # takes effect at the reboot
    write1(mod, 0x0607, 1)
    assert read(mod, 0x010A) == (1,) and read(mod, 0x0000) == (0,)  # back disabled
    write1(mod, 0x0100, 1)
    run(mod, ENABLE_TIME + PERIOD)
    target(mod, 120)
    run(mod, 2.0)
    assert position(mod) == 120


@pytest.mark.parametrize(("addr", "value"), [(0x0303, 0), (0x0303, 4501), (0x0506, 0), (0x0506, 101)])
def test_out_of_range_speed_or_force_is_illegal_value_and_changes_nothing(addr: int, value: int) -> None:
    mod, _ = enabled()
    before = read(mod, addr)
    assert write1(mod, addr, value) == bytes((8, 0x86, rtu.ILLEGAL_VALUE))
    assert read(mod, addr) == before


@pytest.mark.parametrize(("pos", "end"), [(70, 0), (50, 0), (-5, 0), (151, PULSE_MAX), (130, None)])
def test_a_target_beyond_the_stroke_is_clamped_to_its_end(pos: int, end: int | None) -> None:
    """A first-generation program's close (50) closes a G2 fully; its open (130) is inside the
    G2's stroke and goes there."""
    mod, _ = enabled()
    assert target(mod, 100) == bytes.fromhex("08 10 07 00 00 02")
    run(mod, 2.0)
    assert target(mod, pos) == bytes.fromhex("08 10 07 00 00 02")
    run(mod, 2.0)
    want = end if end is not None else round(mm_to_pulses(pos))
    assert position(mod) == want
    assert g2_move(mod, pos) == bytes.fromhex("08 10 0C 00 00 05")


def test_target_while_disabled_is_accepted_but_does_not_move() -> None:
    mod, _ = module()
    assert target(mod, 71) == bytes.fromhex("08 10 07 00 00 02")
    run(mod, 2.0)
    assert position(mod) == PULSE_MAX and read(mod, 0x0000) == (0,)


def test_object_stops_closing_with_status_2_and_slipping_out_is_error_12() -> None:
    mod, dev = enabled()
    dev.set_object(100.0)
    target(mod, 71)
    run(mod, 2.0)
    assert read(mod, 0x0000) == ((2 << 2) | 2,)  # enabled, stopped on the object
    assert dev.opening_mm == pytest.approx(100.0)
    dev.set_object(None)
    assert read(mod, 0x0000)[0] & 0x03 == 3 and read(mod, 0x000F) == (12,)
    assert write1(mod, 0x000F, 0) == bytes.fromhex("08 06 00 0F 00 00")
    assert read(mod, 0x000F) == (0,) and read(mod, 0x0000)[0] & 0x03 == 0


def test_injected_error_stops_the_fingers() -> None:
    mod, dev = enabled()
    target(mod, 71)
    run(mod, 0.2)
    dev.inject_error(11)
    where = position(mod)
    run(mod, 1.0)
    assert position(mod) == where and read(mod, 0x000F) == (11,)
    with pytest.raises(ValueError):
        dev.inject_error(25)


def test_serial_number_and_version_as_the_sdk_decodes_them() -> None:
    mod, _ = module()
    words = read(mod, 0x0B10, 16)
    raw = [b for w in words for b in struct.pack(">H", w)]
    # the SDK joins each register's two bytes as decimal strings: one character per register
    assert "".join(chr(int(str(raw[i]) + str(raw[i + 1]))) for i in range(0, 28, 2)) == SERIAL
    assert read(mod, 0x0801, 3) == VERSION


def test_emulator_attaches_it_and_the_xarm_gripper_is_not_on_the_bus() -> None:
    emu = Emulator(6, gripper="bio")
    assert isinstance(emu.gripper.device, BioGripper)
    emu.inject_gripper_error(12)
    assert emu.gripper_status()["error"] == 12 and emu.snapshot().tgpio_code == (0, 0)
    emu.clear_faults()
    assert emu.gripper.device.error == 0
    with pytest.raises(ValueError, match="opens 71..150 mm"):
        emu.check_input("gripper-object", 0, 60.0)
    with pytest.raises(ValueError, match="index 0"):
        emu.check_input("gripper-object", 1, 100.0)


def test_fleet_key_gripper_picks_each_arms_gripper() -> None:
    from xarm_emu.server.fleet import FleetError, parse_fleet

    ports = {"port": 0, "normal_port": 0, "rich_port": 0, "develop_port": 0}
    fleet = parse_fleet({"arm": [{"model": 6, "gripper": "bio", **ports},
                                 {"model": 6, "gripper": "robotiq-2f140", **ports}, {"model": 7, **ports}]})
    assert [a.gripper for a in fleet.arms] == ["bio", "robotiq-2f140", "xarm"]
    with pytest.raises(FleetError, match="gripper is one of"):
        parse_fleet({"arm": [{"model": 6, "gripper": "robotiq"}]})
    with pytest.raises(FleetError, match="one end tool at a time"):
        parse_fleet({"arm": [{"model": 6, "gripper": "bio", "vacuum": True}]})
