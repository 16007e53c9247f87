"""``serve --modbus-port``: the standard Modbus map on a port of its own, through pymodbus's own sync
client, each table checked against the state the private protocol reports; frames that cannot be
framed close only their connection.

The same port through pymodbus's async client, the pose and tool outputs against what the private
protocol reports, one state shared by both ports, and random protocol-0 frames that always get a
well-formed answer and never stall the port.
"""

from __future__ import annotations

import asyncio
import math
import socket
import struct
from typing import Any

import pytest
from helpers import wait_for
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pymodbus.client import AsyncModbusTcpClient, ModbusTcpClient

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


# -- the async client, both ports on one state, random frames ----------------------------------------

def signed(words: list[int]) -> list[int]:
    return [w - 0x10000 if w & 0x8000 else w for w in words]


def test_async_client_reads_and_writes_every_table(srv: ServerThread) -> None:
    async def session() -> tuple[Any, ...]:
        c = AsyncModbusTcpClient("127.0.0.1", port=srv.ports["modbus"], timeout=3)
        await c.connect()
        try:
            assert not (await c.write_coil(300, True, device_id=1)).isError()
            assert not (await c.write_register(4, 1500, device_id=1)).isError()  # AO1 = 1.5 V
            coils = (await c.read_coils(300, count=1, device_id=1)).bits[0]
            inputs = (await c.read_discrete_inputs(0, count=8, device_id=1)).bits[:8]
            holding = (await c.read_holding_registers(4, count=1, device_id=1)).registers[0]
            error = (await c.read_input_registers(32, count=2, device_id=1)).registers
            return coils, inputs, holding, error
        finally:
            c.close()

    coil, inputs, holding, error = asyncio.run(session())
    snap = srv.call(lambda: srv.emulator.snapshot())
    assert coil is True
    assert inputs == [bool(snap.cgpio_input_config >> i & 1) for i in range(8)]  # type: ignore[attr-defined]
    assert abs(holding - 1500) <= 3 and abs(snap.analog_outputs[1] - 1.5) < 0.01  # type: ignore[attr-defined]
    assert error == [snap.error, snap.warning]  # type: ignore[attr-defined]


def test_pose_reads_the_reported_tcp_pose(srv: ServerThread) -> None:
    def move() -> None:
        srv.emulator.controller.q[:] = [math.radians(a) for a in (20, -10, -15, 0, 25, 30)]
        srv.emulator.touch()

    srv.call(move)
    snap = srv.call(lambda: srv.emulator.snapshot())
    with ModbusTcpClient("127.0.0.1", port=srv.ports["modbus"], timeout=3) as c:
        pose = signed(c.read_input_registers(64, count=6, device_id=1).registers)
    expect = [v if i < 3 else math.degrees(v) for i, v in enumerate(snap.pose)]  # type: ignore[attr-defined]
    assert all(abs(p / 10 - e) <= 0.051 for p, e in zip(pose, expect, strict=True))


def test_tool_output_coils_and_the_command_port_share_one_state(srv: ServerThread) -> None:
    from xarm_emu.client import Client

    with ModbusTcpClient("127.0.0.1", port=srv.ports["modbus"], timeout=3) as c:
        assert not c.write_coils(32, [False, True], device_id=1).isError()
        assert wait_for(lambda: srv.call(lambda: srv.emulator.io.tool.digital_outputs) == 0b10)
        with Client("127.0.0.1", srv.ports["command"]) as private:
            private.call(19, mode=2)
        assert wait_for(lambda: c.read_holding_registers(32, count=1, device_id=1).registers == [2])


FUNCTIONS = [0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x0F, 0x10, 0x16, 0x17, 0x07, 0x2B, 0x00, 0x81]


def recv_frame(s: socket.socket) -> bytes:
    buf = b""
    while len(buf) < 6 or len(buf) < 6 + struct.unpack(">H", buf[4:6])[0]:
        chunk = s.recv(4096)
        assert chunk, "connection closed"
        buf += chunk
    return buf


def test_random_frames_are_answered_and_never_stall_the_port(srv: ServerThread) -> None:
    port = srv.ports["modbus"]

    @settings(max_examples=100, deadline=None,
              suppress_health_check=[HealthCheck.function_scoped_fixture])
    @given(f=st.sampled_from(FUNCTIONS), body=st.binary(max_size=24), tid=st.integers(0, 0xFFFF),
           unit=st.integers(0, 255))
    def run(f: int, body: bytes, tid: int, unit: int) -> None:
        pdu = bytes((f,)) + body
        with socket.create_connection(("127.0.0.1", port), timeout=2) as fuzz:
            fuzz.sendall(struct.pack(">HHHB", tid, 0, 1 + len(pdu), unit) + pdu)
            raw = recv_frame(fuzz)
            assert struct.unpack(">HHHB", raw[:7]) == (tid, 0, len(raw) - 6, unit)
            assert raw[7] in (f, (f | 0x80) & 0xFF)
            if screen(pdu)[2]:  # a length its function's layout disagrees with: then a close
                assert fuzz.recv(64) == b""

    run()
    with ModbusTcpClient("127.0.0.1", port=port, timeout=3) as c:  # still serving
        assert not c.read_input_registers(89, count=7, device_id=1).isError()
