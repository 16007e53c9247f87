"""``serve --modbus-port``: the standard Modbus map on a port of its own, through pymodbus's own sync
client, each table checked against the state the private protocol reports; frames that cannot be
framed close only their connection."""

from __future__ import annotations

import socket
import struct
from typing import Any

import pytest
from helpers import wait_for
from pymodbus.client import ModbusTcpClient

from xarm_emu.protocol.modbus import screen
from xarm_emu.server.app import ServerThread
from xarm_emu.server.modbus_port import attach_modbus_port, split_frames


@pytest.fixture
def srv(tmp_path: Any) -> Any:
    from xarm_emu.controller.emulator import Emulator
    from xarm_emu.server.app import ServerConfig

    emu = Emulator(6, config_dir=tmp_path / "config")
    cfg = ServerConfig(host="127.0.0.1", port=0, normal_port=0, rich_port=0, develop_port=0)
    st = ServerThread(emu, cfg, compose=(lambda s: attach_modbus_port(s, "127.0.0.1", 0),)).start()
    yield st
    st.stop()


@pytest.fixture
def client(srv: ServerThread) -> Any:
    c = ModbusTcpClient("127.0.0.1", port=srv.ports["modbus"], timeout=3)
    assert c.connect()
    yield c
    c.close()


def private(srv: ServerThread, register: int, params: bytes = b"") -> bytes:
    code, body = srv.call(lambda: srv.emulator.handle(register, params))  # type: ignore[misc]
    return bytes(body)


def test_the_port_is_its_own(srv: ServerThread) -> None:
    assert srv.ports["modbus"] not in (srv.ports["command"], 0)


def test_coils_drive_the_control_box_outputs(srv: ServerThread, client: Any) -> None:
    assert not client.write_coil(3, True, device_id=1).isError()
    assert not client.write_coils(8, [True, False, True], device_id=1).isError()
    assert wait_for(lambda: srv.call(lambda: srv.emulator.snapshot().cgpio_output_config)
                    == (1 << 3) | (1 << 8) | (1 << 10))
    r = client.read_coils(0, count=16, device_id=1)
    assert r.bits[:16] == [i in (3, 8, 10) for i in range(16)]


def test_discrete_inputs_follow_the_box_inputs(srv: ServerThread, client: Any) -> None:
    def set_inputs() -> None:
        srv.emulator.io.cgpio.digital_inputs = 0xFFFF & ~(1 << 2) & ~(1 << 9)
        srv.emulator.touch()

    srv.call(set_inputs)
    r = client.read_discrete_inputs(0, count=16, device_id=1)
    assert r.bits[:16] == [i not in (2, 9) for i in range(16)]


def test_holding_registers_set_the_analog_outputs_and_read_mode_and_state(srv: ServerThread,
                                                                          client: Any) -> None:
    assert not client.write_register(3, 2500, device_id=1).isError()  # AO0 = 2.5 V
    assert wait_for(lambda: abs(srv.call(lambda: srv.emulator.snapshot().analog_outputs[0]) - 2.5) < 0.01)
    assert abs(client.read_holding_registers(3, count=1, device_id=1).registers[0] - 2500) <= 3
    mode_state = client.read_holding_registers(32, count=2, device_id=1).registers
    state = private(srv, 13)[-1]  # register 13: the state as the private protocol reports it
    assert mode_state == [srv.call(lambda: srv.emulator.snapshot().mode), state]
    assert not client.write_registers(256, [7, 8, 9], device_id=1).isError()
    assert client.read_holding_registers(256, count=3, device_id=1).registers == [7, 8, 9]


def test_input_registers_read_the_joints_with_their_scaling(srv: ServerThread, client: Any) -> None:
    import math

    def move() -> None:
        srv.emulator.controller.q[:] = [math.radians(a) for a in (20, -10, -15, 0, 25, 30)]
        srv.emulator.touch()

    srv.call(move)
    regs = client.read_input_registers(89, count=7, device_id=1).registers
    signed = [r - 0x10000 if r & 0x8000 else r for r in regs]
    assert signed == [200, -100, -150, 0, 250, 300, 0]


def test_exceptions_come_back_over_the_port(client: Any) -> None:
    r = client.read_coils(40, count=1, device_id=1)  # reserved coil
    assert r.isError() and r.exception_code == 2
    r = client.write_register(3, 10001, device_id=1)  # above 10 V
    assert r.isError() and r.exception_code == 3


def connect(port: int) -> socket.socket:
    return socket.create_connection(("127.0.0.1", port), timeout=2.0)


def test_a_private_frame_closes_only_its_connection(srv: ServerThread, client: Any) -> None:
    with connect(srv.ports["modbus"]) as s:
        s.sendall(struct.pack(">HHHB", 1, 2, 1, 13))  # protocol 2: not standard Modbus
        assert s.recv(64) == b""
    assert client.read_holding_registers(256, count=1, device_id=1).registers == [0]


def test_split_frames_keeps_a_partial_frame() -> None:
    buf = bytearray(bytes.fromhex("000100000006010300200002" "00020000"))
    frames, ok = split_frames(buf)
    assert ok and frames == [(1, 1, bytes.fromhex("0300200002"))]
    assert buf == bytearray(bytes.fromhex("00020000"))
    assert split_frames(bytearray(bytes.fromhex("00010000000101"))) == ([(1, 1, b"")], True)
    assert screen(b"") == (False, b"", True)  # an empty PDU: no reply, the connection closes


def test_coil_142_reads_reduced_mode(srv: ServerThread, client: Any) -> None:
    from xarm_emu.controller.applications.reduced import reduced_of

    assert client.read_coils(142, count=1, device_id=1).bits[0] is False
    srv.call(lambda: setattr(reduced_of(srv.emulator.controller), "on", True))  # as register 50 sets it
    assert client.read_coils(142, count=1, device_id=1).bits[0] is True
