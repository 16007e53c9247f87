"""Standard Modbus (protocol id 0) against register 19 and the live state: holding 32 takes the
modes register 19 takes, input 110 is the TCP's actual speed, coil 142 the reduced mode."""

from __future__ import annotations

import struct

import pytest

from xarm_emu.controller.emulator import Emulator
from xarm_emu.controller.modbus_map import answer
from xarm_emu.model import kinematics


def _pdu(emu: Emulator, pdu: bytes) -> bytes:
    frame = answer(emu, 1, 1, pdu)
    return frame[7:]


def _write_holding(emu: Emulator, addr: int, value: int) -> bytes:
    return _pdu(emu, struct.pack(">BHH", 0x06, addr, value))


def _read(emu: Emulator, fc: int, addr: int, n: int = 1) -> bytes:
    return _pdu(emu, struct.pack(">BHH", fc, addr, n))


def _ready(emu: Emulator) -> None:
    for code, params in ((11, bytes([8, 1])), (12, bytes([0]))):
        emu.handle(code, params)


@pytest.mark.parametrize("mode", [4, 5, 6, 7])
def test_holding_32_takes_the_modes_register_19_takes(tmp_path, mode):
    emu = Emulator(6, config_dir=tmp_path, firmware="2.7.103")
    _ready(emu)
    reply = _write_holding(emu, 32, mode)
    assert reply == struct.pack(">BHH", 0x06, 32, mode)  # the echo, no exception
    assert emu.controller.mode == mode
    assert _read(emu, 0x03, 32) == bytes([0x03, 2]) + struct.pack(">H", mode)


def test_holding_32_refuses_what_register_19_refuses(tmp_path):
    emu = Emulator(6, config_dir=tmp_path, firmware="2.7.103")
    assert _write_holding(emu, 32, 3) == bytes([0x86, 0x03])  # Cartesian teaching: not available
    assert _write_holding(emu, 32, 8) == bytes([0x86, 0x03])
    old = Emulator(6, config_dir=tmp_path / "old")  # manual firmware: no modes 4-7
    assert _write_holding(old, 32, 4) == bytes([0x86, 0x03])


def test_input_110_is_the_tcp_speed_of_a_joint_move(tmp_path):
    emu = Emulator(6, config_dir=tmp_path, firmware="2.7.103")
    _ready(emu)
    target = [0.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    emu.handle(23, struct.pack("<7f3f", *target, 1.0, 10.0, 0.0))
    emu.advance(0.4)  # mid-move
    c = emu.controller
    want = kinematics.tcp_speed(c.model, c.data.q, c.data.qd, c.settings.tcp_offset)
    assert want > 50.0  # J1 turns the whole arm: the TCP moves
    (raw,) = struct.unpack(">H", _read(emu, 0x04, 110)[2:])
    assert raw == pytest.approx(want * 10, abs=1.0)


def test_tcp_speed_counts_the_tcp_offset(tmp_path):
    emu = Emulator(6, config_dir=tmp_path)
    m = emu.model
    q = [0.0, -0.5, -0.5, 0.0, 0.5, 0.0]
    qd = [0.0, 0.0, 0.0, 0.0, 0.0, 1.0]  # J6 only: the flange centre stays, an offset TCP circles
    assert kinematics.tcp_speed(m, q, qd) == pytest.approx(0.0, abs=1e-6)
    assert kinematics.tcp_speed(m, q, qd, (100.0, 0, 0, 0, 0, 0)) == pytest.approx(100.0, rel=1e-6)


def test_coil_142_is_the_reduced_mode(tmp_path):
    emu = Emulator(6, config_dir=tmp_path, firmware="2.7.103")
    assert _read(emu, 0x01, 142) == bytes([0x01, 1, 0])
    emu.handle(50, bytes([1]))
    assert _read(emu, 0x01, 142) == bytes([0x01, 1, 1])


def test_sdk_sees_mode_4_written_through_holding_32(make_server, sdk_arm, tmp_path):
    from helpers import sdk_ready, wait_for

    srv = make_server(emulator=Emulator(6, config_dir=tmp_path / "sdk", firmware="2.7.103"))
    arm = sdk_arm(srv)
    sdk_ready(arm)
    assert arm.write_single_holding_register(32, 4) == 0
    assert wait_for(lambda: arm.mode == 4)
    assert arm.read_holding_registers(32, 1) == (0, [4])
