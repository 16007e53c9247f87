"""The standard Modbus-TCP map on the command port: MBAP framing on the wire, the unchanged official
SDK's Modbus calls against a real server, and random protocol-0 PDUs that always get a well-formed
answer without disturbing a second client."""

from __future__ import annotations

import struct
from typing import Any

from helpers import connect, recv_frame, sdk_ready, wait_for
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from xarm_emu.protocol.modbus import screen
from xarm_emu.server.app import ServerThread


def adu(tid: int, unit: int, pdu: bytes) -> bytes:
    return struct.pack(">HHHB", tid, 0, 1 + len(pdu), unit) + pdu


def test_read_coils_frame_on_the_wire(make_server: Any) -> None:
    srv: ServerThread = make_server()
    srv.call(lambda: srv.emulator.handle(134, struct.pack(">HH", 0xFFF7, 0xFF00)))
    with connect(srv.ports["command"]) as s:
        s.sendall(bytes.fromhex("000100000006010100000010"))
        assert recv_frame(s) == bytes.fromhex("00010000000501" "0102F700")


def test_exception_frame_echoes_tid_and_unit(make_server: Any) -> None:
    srv: ServerThread = make_server()
    with connect(srv.ports["command"]) as s:
        s.sendall(adu(0xBEEF, 7, bytes.fromhex("0100280001")))  # reserved coil 40
        assert recv_frame(s) == bytes.fromhex("BEEF0000000307" "8102")


def test_user_registers_outlive_the_connection(make_server: Any) -> None:
    srv: ServerThread = make_server()
    with connect(srv.ports["command"]) as s:
        s.sendall(adu(3, 1, bytes.fromhex("1001FF000102ABCD")))
        assert recv_frame(s) == bytes.fromhex("00030000000601" "1001FF0001")
    with connect(srv.ports["command"]) as s:
        s.sendall(adu(4, 1, bytes.fromhex("0301FF0001")))
        assert recv_frame(s) == bytes.fromhex("00040000000501" "0302ABCD")


def test_pipelined_modbus_and_private_frames_in_one_write(make_server: Any) -> None:
    srv: ServerThread = make_server()
    with connect(srv.ports["command"]) as s:
        private = struct.pack(">HHHB", 9, 2, 1, 13)  # register 13, get state
        s.sendall(adu(1, 1, bytes.fromhex("0300200002")) + private + adu(2, 1, bytes.fromhex("07")))
        first = recv_frame(s)
        second = recv_frame(s)
        third = recv_frame(s)
    state = first[-1]
    assert first[:9] == bytes.fromhex("0001000000070103" "04")
    assert struct.unpack(">HHHBBB", second) == (9, 2, 3, 13, second[7], state)
    assert third == bytes.fromhex("0002000000030187" "01")


def test_official_sdk_modbus_calls(make_server: Any, sdk_arm: Any) -> None:
    srv: ServerThread = make_server()
    arm = sdk_arm(srv)
    sdk_ready(arm)
    assert arm.write_single_coil_bit(3, 1) == 0
    assert wait_for(lambda: srv.call(lambda: srv.emulator.snapshot().cgpio_output_config) == 1 << 3)
    assert arm.write_multiple_coil_bits(8, [1, 0, 1]) == 0
    assert arm.read_coil_bits(0, 16) == (0, [0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 1, 0, 0, 0, 0, 0])
    assert arm.read_input_bits(0, 4) == (0, [1, 1, 1, 1])
    assert arm.write_single_holding_register(4, 2500) == 0  # AO1 = 2.5 V
    code, regs = arm.read_holding_registers(3, 2)
    assert code == 0 and abs(regs[1] - 2500) <= 3
    assert arm.write_multiple_holding_registers(256, [7, 8, 9]) == 0
    assert arm.mask_write_holding_register(256, 0x0003, 0x0F00) == 0
    assert arm.write_and_read_holding_registers(256, 3, 258, [0xFFFF], is_signed=True) == (0, (0x0F03, 8, -1))
    assert arm.read_coil_bits(40, 1)[0] == 0x80 + 2
    assert arm.set_servo_angle(angle=[20, -10, -15, 0, 25, 30], speed=100, wait=True) == 0
    code, joints = arm.read_input_registers(89, 7, is_signed=True)
    assert code == 0
    assert all(abs(j / 10 - a) <= 0.11 for j, a in zip(joints, [20, -10, -15, 0, 25, 30, 0], strict=True))
    code, pose = arm.read_input_registers(64, 6, is_signed=True)
    code2, sdk_pose = arm.get_position(is_radian=False)
    assert code == 0 and code2 == 0
    assert all(abs(p / 10 - q) <= 0.11 for p, q in zip(pose, sdk_pose, strict=True))
    assert arm.read_holding_registers(32, 2) == (0, [arm.mode, arm.state])


FUNCTIONS = [0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x0F, 0x10, 0x16, 0x17, 0x07, 0x08, 0x2B, 0x00, 0x81]


def pdus() -> st.SearchStrategy[bytes]:
    return st.builds(lambda f, body: bytes((f,)) + body, st.sampled_from(FUNCTIONS),
                     st.binary(min_size=0, max_size=24))


def well_formed(request: bytes, reply: bytes) -> bool:
    f = request[0]
    if reply[0] == (f | 0x80) & 0xFF:
        return len(reply) == 2 and reply[1] in (1, 2, 3)
    if reply[0] != f:
        return False
    if f in (0x01, 0x02, 0x03, 0x04, 0x17):
        return reply[1] == len(reply) - 2
    if f in (0x05, 0x06, 0x0F, 0x10):
        return len(reply) == 5 and reply[1:3] == request[1:3]
    return f == 0x16 and reply == request


def test_random_pdus_get_well_formed_answers_and_spare_a_second_client(make_server: Any) -> None:
    srv: ServerThread = make_server()
    port = srv.ports["command"]
    with connect(port) as other:

        @settings(max_examples=150, deadline=None,
                  suppress_health_check=[HealthCheck.function_scoped_fixture])
        @given(pdu=pdus(), tid=st.integers(0, 0xFFFF), unit=st.integers(0, 255))
        def run(pdu: bytes, tid: int, unit: int) -> None:
            with connect(port) as fuzz:
                fuzz.sendall(adu(tid, unit, pdu))
                raw = recv_frame(fuzz)
                assert struct.unpack(">HHHB", raw[:7]) == (tid, 0, len(raw) - 6, unit)
                assert well_formed(pdu, raw[7:]), (pdu.hex(), raw.hex())
                if screen(pdu)[2]:  # a length its function's layout disagrees with: then a close
                    assert fuzz.recv(64) == b""
            other.sendall(struct.pack(">HHHB", tid, 2, 1, 13))  # register 13, get state
            reply = recv_frame(other)
            assert struct.unpack(">HHHB", reply[:7]) == (tid, 2, 3, 13)

        run()
    with connect(port) as s:  # the port still serves new clients
        s.sendall(adu(1, 1, bytes.fromhex("0400590001")))
        assert recv_frame(s)[:9] == bytes.fromhex("0001000000050104" "02")
