"""The Modbus port beside the command port: pymodbus's async client, the pose and tool outputs against
what the private protocol reports, one state shared by both ports, and random protocol-0 frames that
always get a well-formed answer and never stall the port."""

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
from xarm_emu.server.modbus_port import attach_modbus_port


@pytest.fixture
def srv(tmp_path: Any) -> Any:
    from xarm_emu.controller.emulator import Emulator
    from xarm_emu.server.app import ServerConfig

    emu = Emulator(6, config_dir=tmp_path / "config")
    cfg = ServerConfig(host="127.0.0.1", port=0, normal_port=0, rich_port=0, develop_port=0)
    st_ = ServerThread(emu, cfg, compose=(lambda s: attach_modbus_port(s, "127.0.0.1", 0),)).start()
    yield st_
    st_.stop()


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
