"""The first-generation BIO gripper (``--gripper bio-g1``): its register map through register 124
PDUs, and the official SDK's BIO calls, which tell it from a G2 by its missing serial number and
send it the targets 130 (open) and 50 (close); the SDK's example 5009 run unchanged."""

from __future__ import annotations

import struct
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from helpers import FakeView
from test_robotiq_sdk import MODBUS_ERR_LENG, run_sdk_example, sdk_arm_with

from xarm_emu.controller.devices.bio_gripper_g1 import CLOSED, OPEN, REGISTER_MAP, BioGripperG1
from xarm_emu.controller.devices.gripper import GripperModule
from xarm_emu.protocol import rtu
from xarm_emu.protocol.registers import REGISTERS
from xarm_emu.server.app import ServerThread
from xarm_emu.testing import running_emulator


def module() -> tuple[GripperModule, BioGripperG1]:
    dev = BioGripperG1()
    return GripperModule(device=dev, tool_baud=lambda: 11), dev


def send(mod: GripperModule, pdu: bytes) -> bytes:
    reg = REGISTERS[124]
    return reg.reply.encode(mod.handlers()[124](reg.request.decode(bytes([9]) + pdu)))[1:]


def read(mod: GripperModule, addr: int, count: int = 1) -> bytes:
    return send(mod, struct.pack(">BBhh", 8, 3, addr, count))


def target(mod: GripperModule, value: int) -> bytes:
    return send(mod, bytes.fromhex("08 10 07 00 00 02 04") + struct.pack(">i", value))


def position(mod: GripperModule) -> int:
    slave, func, (hi, lo) = rtu.parse_reply(read(mod, 0x0700, 2))
    return struct.unpack(">i", struct.pack(">HH", hi, lo))[0]


def run(mod: GripperModule, dev: BioGripperG1, seconds: float) -> None:
    for _ in range(round(seconds / 0.004)):
        dev.step(0.004, FakeView())


def test_the_g1_has_its_own_map() -> None:
    mod, dev = module()
    for addr in REGISTER_MAP:
        assert rtu.parse_reply(read(mod, addr))[1] == 3
    for addr in (0x0B10, 0x010A, 0x0506, 0x0702, 0x0801):  # serial number, mode, force, G2 position
        assert read(mod, addr) == bytes((8, 0x83, rtu.ILLEGAL_ADDRESS))
    assert send(mod, bytes.fromhex("08 10 0C 00 00 05 0A 00 01 07 D0 00 64 00 00 00 32")) == \
        bytes((8, 0x90, rtu.ILLEGAL_ADDRESS))


def test_the_g1_moves_between_50_and_130_and_refuses_beyond() -> None:
    mod, dev = module()
    assert send(mod, bytes.fromhex("08 06 01 00 00 01")) == bytes.fromhex("08 06 01 00 00 01")
    run(mod, dev, 0.5)
    assert position(mod) == OPEN
    assert target(mod, CLOSED) == bytes.fromhex("08 10 07 00 00 02")
    run(mod, dev, 0.5)
    assert CLOSED < position(mod) < OPEN  # about a second for the stroke at speed 2000
    run(mod, dev, 1.0)
    assert position(mod) == CLOSED
    for bad in (49, 131, 150):
        assert target(mod, bad) == bytes((8, 0x90, rtu.ILLEGAL_VALUE))
    run(mod, dev, 1.0)
    assert position(mod) == CLOSED


@pytest.fixture(scope="module")
def g1() -> Iterator[tuple[Any, ServerThread]]:
    with sdk_arm_with("bio-g1") as pair:
        yield pair


def test_the_sdk_opens_and_closes_a_g1(g1: tuple[Any, ServerThread]) -> None:
    arm, st = g1
    assert arm._arm.get_bio_gripper_sn()[0] == MODBUS_ERR_LENG  # how the SDK knows a G1
    assert arm.set_bio_gripper_enable(True) == 0
    assert arm.set_bio_gripper_speed(3000) == 0
    assert arm.close_bio_gripper() == 0
    assert arm.get_bio_gripper_g2_position() == (0, 71)  # the SDK's reading of a closed G1
    assert st.call(lambda: st.emulator.gripper.device.position) == CLOSED
    assert arm.open_bio_gripper() == 0
    assert arm.get_bio_gripper_g2_position() == (0, 150)
    assert st.call(lambda: st.emulator.gripper.device.position) == OPEN
    code, status = arm.get_bio_gripper_status()
    assert code == 0 and status == 2 << 2  # stopped, enabled


def test_sdk_example_5009_runs_unchanged_on_a_g1(tmp_path: Path) -> None:
    with running_emulator(6, gripper="bio-g1", speed=5.0) as st:
        env, out = run_sdk_example("wrapper/common/5009-set_bio_gripper.py", st, tmp_path, 5.0,
                                   lambda: st.emulator.inject_error(31))
        try:
            assert "set_bio_gripper_enable, code=0" in out
            assert out.count("open_bio_gripper, code=0") >= 2, out
            assert out.count("close_bio_gripper, code=0") >= 2, out
        finally:
            env["arm"].disconnect()
