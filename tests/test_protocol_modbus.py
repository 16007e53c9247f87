"""The standard Modbus-TCP map, sans-IO: PDU bytes for each function code and exception, the map's
address rules, scaling round trips against a live in-process emulator and writes taking effect.

Against register 19 and the live state: holding 32 takes the modes register 19 takes, input 110 is
the TCP's actual speed, coil 142 the reduced mode.
"""

from __future__ import annotations

import logging
import math
import struct
from pathlib import Path

import pytest
from helpers import call, ready

from xarm_emu.controller.emulator import Emulator
from xarm_emu.controller.modbus_map import EmulatorDatastore, answer
from xarm_emu.model import kinematics
from xarm_emu.model.rotations import rpy_to_axis_angle
from xarm_emu.protocol import modbus
from xarm_emu.protocol.modbus import Kind, handle_pdu


@pytest.fixture
def emu(tmp_path: Path) -> Emulator:
    return Emulator(6, config_dir=tmp_path / "conf")


@pytest.fixture
def store(emu: Emulator) -> EmulatorDatastore:
    return EmulatorDatastore(emu)


def words(reply: bytes, signed: bool = False) -> list[int]:
    n = reply[1] // 2
    return list(struct.unpack(f">{n}{'h' if signed else 'H'}", reply[2:]))


def test_map_has_no_overlaps_and_covers_the_published_ranges() -> None:
    coils = set(range(0, 40)) | set(range(128, 160)) | set(range(256, 512))
    assert modbus.ADDRESSES[Kind.COIL].keys() >= coils
    assert modbus.ADDRESSES[Kind.INPUT].keys() >= set(range(64, 111))
    assert 40 not in modbus.ADDRESSES[Kind.COIL] and 111 not in modbus.ADDRESSES[Kind.INPUT]


def test_read_coils_bytes(store: EmulatorDatastore, emu: Emulator) -> None:
    call(emu, 134, digital=0xFFF7, digital_hi=0xFF00)  # IO 0-7 = 0xF7, 8-15 = 0
    assert handle_pdu(bytes.fromhex("0100000010"), store) == bytes.fromhex("0102F700")


def test_read_discrete_inputs_idle_high(store: EmulatorDatastore) -> None:
    assert handle_pdu(bytes.fromhex("0200000010"), store) == bytes.fromhex("0202FFFF")
    assert handle_pdu(bytes.fromhex("0200200002"), store) == bytes.fromhex("020100")


def test_write_single_coil_drives_output(store: EmulatorDatastore, emu: Emulator) -> None:
    assert handle_pdu(bytes.fromhex("050009FF00"), store) == bytes.fromhex("050009FF00")
    assert emu.snapshot().cgpio_output_config == 1 << 9
    assert handle_pdu(bytes.fromhex("0500090000"), store) == bytes.fromhex("0500090000")
    assert emu.snapshot().cgpio_output_config == 0


def test_write_single_coil_other_value_is_exception_3(store: EmulatorDatastore) -> None:
    assert handle_pdu(bytes.fromhex("0500091234"), store) == bytes.fromhex("8503")


def test_write_multiple_coils_and_tool_outputs(store: EmulatorDatastore, emu: Emulator) -> None:
    assert handle_pdu(bytes.fromhex("0F0000000A02FF03"), store) == bytes.fromhex("0F0000000A")
    assert emu.snapshot().cgpio_output_config == 0x03FF
    assert handle_pdu(bytes.fromhex("0F0020000201 02".replace(" ", "")), store) == bytes.fromhex("0F00200002")
    assert call(emu, 128, host=9, addr=0x0A18)[1]["value"] == 0b10
    assert handle_pdu(bytes.fromhex("0100200002"), store) == bytes.fromhex("010102")
    assert handle_pdu(bytes.fromhex("0300020001"), store) == bytes.fromhex("03020002")


def test_holding_output_word_and_analog_output(store: EmulatorDatastore, emu: Emulator) -> None:
    assert handle_pdu(bytes.fromhex("0600008001"), store) == bytes.fromhex("0600008001")
    assert emu.snapshot().cgpio_output_config == 0x8001
    assert handle_pdu(bytes.fromhex("06000403E8"), store) == bytes.fromhex("06000403E8")  # AO1 = 1 V
    assert emu.snapshot().analog_outputs[1] == pytest.approx(1.0, abs=10 / 4095)
    reply = handle_pdu(bytes.fromhex("0300030002"), store)
    assert words(reply)[1] == pytest.approx(1000, abs=3)
    assert handle_pdu(bytes.fromhex("0600032711"), store) == bytes.fromhex("8603")  # 10.001 V


def test_mask_write_bytes_and_result(store: EmulatorDatastore, emu: Emulator) -> None:
    handle_pdu(bytes.fromhex("06010000F0"), store)  # user register 256 = 0x00F0
    assert handle_pdu(bytes.fromhex("160100000F0F00"), store) == bytes.fromhex("160100000F0F00")
    # (0x00F0 & 0x000F) | (0x0F00 & ~0x000F)
    assert handle_pdu(bytes.fromhex("0301000001"), store) == bytes.fromhex("03020F00")


def test_read_write_multiple_registers(store: EmulatorDatastore) -> None:
    req = struct.pack(">BHHHHB2H", 0x17, 256, 3, 257, 2, 4, 0x04D1, 0x0D7F)
    assert handle_pdu(req, store) == bytes.fromhex("1706" "0000" "04D1" "0D7F")


def test_write_multiple_registers_user_storage(store: EmulatorDatastore) -> None:
    req = struct.pack(">BHHB3H", 0x10, 509, 3, 6, 1, 2, 0xFFFF)
    assert handle_pdu(req, store) == bytes.fromhex("1001FD0003")
    assert handle_pdu(bytes.fromhex("0301FD0003"), store) == bytes.fromhex("0306" "0001" "0002" "FFFF")
    assert handle_pdu(struct.pack(">BHHB", 0x0F, 300, 3, 1) + b"\x05", store) == bytes.fromhex("0F012C0003")
    assert handle_pdu(bytes.fromhex("01012B0005"), store) == bytes.fromhex("01010A")


@pytest.mark.parametrize("pdu, reply", [
    ("07", "8701"),                     # unsupported function
    ("2B0E0100", "AB01"),
    ("0100280001", "8102"),             # reserved coil 40
    ("01001F000A", "8102"),             # coils 31-40: the range reaches reserved coil 40
    ("0300000000", "8303"),             # quantity 0
    ("030000007E", "8303"),             # quantity 126
    ("04006F0001", "8402"),             # input register 111 reserved
    ("050080FF00", "8502"),             # brake coil 128 is read-only
    ("0600200003", "8603"),             # mode 3 is not available
    ("0600300001", "8601"),             # Blockly trigger takes FC 10 only
    ("1000310001020001", "9002"),       # Blockly trigger writes start at 48
    ("100030000103000100", "9003"),     # byte count does not match
    ("03000B0001", "8302"),             # reserved holding register 11
    ("0300", "8303"),                   # truncated
])
def test_exceptions(store: EmulatorDatastore, pdu: str, reply: str) -> None:
    assert handle_pdu(bytes.fromhex(pdu), store) == bytes.fromhex(reply)


def test_triggers_are_recorded(store: EmulatorDatastore) -> None:
    assert handle_pdu(struct.pack(">BHHB2H", 0x10, 48, 2, 4, 1, 12), store) == bytes.fromhex("1000300002")
    assert handle_pdu(struct.pack(">BHHB1H", 0x10, 64, 1, 2, 20), store) == bytes.fromhex("1000400001")
    assert store.triggered == [("blockly", "00001"), ("blockly", "00012"), ("gcode", "00020")]


def test_mode_and_state_writes_act_as_registers_19_and_12(store: EmulatorDatastore, emu: Emulator) -> None:
    ready(emu)
    assert handle_pdu(bytes.fromhex("0600200001"), store) == bytes.fromhex("0600200001")
    assert emu.snapshot().mode == 1
    state = emu.snapshot().state
    assert state != 2  # a mode change resets the system (register 19)
    assert handle_pdu(bytes.fromhex("0300200002"), store) == struct.pack(">BB2H", 3, 4, 1, state)
    assert handle_pdu(bytes.fromhex("0100920004"), store) == bytes.fromhex("010102")  # mode bit 1
    assert handle_pdu(bytes.fromhex("0600210000"), store) == bytes.fromhex("0600210000")
    assert emu.snapshot().state == 2


def test_joints_pose_and_state_follow_motion(store: EmulatorDatastore, emu: Emulator) -> None:
    ready(emu)
    target = [0.5, -0.3, -0.4, 0.2, 0.6, -0.7, 0.0]
    call(emu, 23, joints=target, speed=1.0, acc=10.0, mvtime=0.0)
    emu.advance(0.3)
    s = emu.snapshot()
    assert s.state == 1
    assert handle_pdu(bytes.fromhex("0300210001"), store) == bytes.fromhex("03020001")
    emu.advance(5.0)
    s = emu.snapshot()
    joints = words(handle_pdu(bytes.fromhex("0400590007"), store), signed=True)
    assert joints == [round(math.degrees(q) * 10) for q in list(s.joints)[:7]]
    assert [j / 10 for j in joints[:6]] == pytest.approx([math.degrees(q) for q in target[:6]], abs=0.051)
    pose = words(handle_pdu(bytes.fromhex("0400400009"), store), signed=True)
    p = list(s.pose)
    aa = rpy_to_axis_angle(p[3], p[4], p[5])
    expect = p[:3] + [math.degrees(a) for a in p[3:6]] + [math.degrees(a) for a in aa]
    assert [v / 10 for v in pose] == pytest.approx(expect, abs=0.051)
    assert handle_pdu(bytes.fromhex("0100800007"), store) == bytes.fromhex("01013F")  # brakes J1-J6
    assert handle_pdu(bytes.fromhex("0100870007"), store) == bytes.fromhex("01013F")  # enabled J1-J6


def test_error_warning_and_counter(store: EmulatorDatastore, emu: Emulator) -> None:
    ready(emu)
    for _ in range(3):
        call(emu, 26, seconds=0.01)  # each completed command counts once
    emu.advance(0.5)
    emu.inject_warning(11)
    s = emu.snapshot()
    assert s.counter == 3
    assert words(handle_pdu(bytes.fromhex("0400200004"), store)) == [s.error, 11, 0, 3]


@pytest.mark.parametrize("value, raw", [(12.34, 123), (-0.25, 0xFFFD), (0.25, 3), (1e6, 0x7FFF),
                                        (-1e6, 0x8000), (float("nan"), 0)])
def test_scaling_rounds_half_away_and_saturates(value: float, raw: int) -> None:
    p = modbus.POINTS["joints"]
    assert p.encode(value) == raw


def test_unsigned_points_saturate_at_zero() -> None:
    assert modbus.POINTS["tcp_speed"].encode(-1.0) == 0
    assert modbus.POINTS["tcp_speed"].encode(7000.0) == 0xFFFF


def test_write_the_register_refuses_is_exception_3(tmp_path: Path) -> None:
    emu = Emulator(6, box_sn="AC1200", config_dir=tmp_path / "conf")  # a box with 8 digital IO
    store = EmulatorDatastore(emu)
    assert handle_pdu(bytes.fromhex("050003FF00"), store) == bytes.fromhex("050003FF00")
    assert handle_pdu(bytes.fromhex("050009FF00"), store) == bytes.fromhex("8503")  # DO1 is absent
    assert emu.snapshot().cgpio_output_config & 0xFF == 1 << 3


def test_user_storage_is_per_emulator_and_not_saved(tmp_path: Path) -> None:
    emu = Emulator(6, config_dir=tmp_path / "conf")
    first = EmulatorDatastore(emu)
    handle_pdu(bytes.fromhex("06010A1234"), first)
    call(emu, 40)  # save_conf
    again = Emulator(6, config_dir=tmp_path / "conf")
    assert handle_pdu(bytes.fromhex("03010A0001"), EmulatorDatastore(again)) == bytes.fromhex("03020000")
    assert handle_pdu(bytes.fromhex("03010A0001"), first) == bytes.fromhex("03021234")


def test_malformed_requests_are_answered_quietly(store: EmulatorDatastore,
                                                 caplog: pytest.LogCaptureFixture) -> None:
    with caplog.at_level(logging.WARNING):
        assert handle_pdu(bytes.fromhex("0100000000"), store) == bytes.fromhex("8103")  # quantity 0
        assert handle_pdu(bytes.fromhex("0F000007D1"), store) == bytes.fromhex("8F03")  # short
        assert handle_pdu(bytes.fromhex("1000000080FF"), store) == bytes.fromhex("9003")  # 128 registers
    assert [r for r in caplog.records if r.levelno >= logging.WARNING] == []


# -- against register 19 and the live state ---------------------------------------------------------

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
