"""The command line of the standard Modbus map: ``xarm-emu modbus-map`` prints it from its table;
``serve --modbus-port N --studio --studio-port M`` serves it and the Studio calls beside the arm."""

from __future__ import annotations

import json
import time
import urllib.request
from pathlib import Path

from helpers import free_ports, port_args, run_cli, serve_subprocess
from pymodbus.client import ModbusTcpClient

from xarm_emu.protocol.modbus import MODBUS_MAP


def test_modbus_map_prints_every_point_of_the_table() -> None:
    code, out = run_cli("modbus-map", "--json")
    assert code == 0
    rows = [json.loads(line) for line in out.splitlines() if line.strip()]
    assert [(r["table"], r["address"], r["count"], r["name"]) for r in rows] == \
        [(p.kind.value, p.address, p.count, p.name) for p in MODBUS_MAP]
    joints = next(r for r in rows if r["name"] == "joints")
    assert (joints["table"], joints["address"], joints["scale"], joints["signed"]) == \
        ("input register", 89, 10.0, True)


def test_modbus_map_table_names_the_addresses() -> None:
    code, out = run_cli("modbus-map")
    assert code == 0
    assert "89-95" in out and "user_registers" in out and "256-511" in out


def test_modbus_port_refuses_a_bad_port(tmp_path: Path) -> None:
    code, out = run_cli("serve", "--modbus-port", "70000", "--config-dir", str(tmp_path))
    assert code == 2 and "--modbus-port" in out


def test_serve_with_modbus_port_and_studio(tmp_path: Path) -> None:
    cmd, normal, rich, develop, mb, studio = free_ports(6)
    with serve_subprocess(tmp_path, *port_args(cmd, normal, rich, develop), "--modbus-port", str(mb),
                          "--studio", "--studio-port", str(studio)):
        client = ModbusTcpClient("127.0.0.1", port=mb, timeout=2)
        deadline = time.monotonic() + 20
        while not client.connect():
            assert time.monotonic() < deadline, "the Modbus port did not come up"
            time.sleep(0.2)
        try:
            assert not client.write_registers(300, [1234], device_id=1).isError()
            assert client.read_holding_registers(300, count=1, device_id=1).registers == [1234]
        finally:
            client.close()
        req = urllib.request.Request(f"http://127.0.0.1:{studio}/v2/api",
                                     json.dumps({"cmd": "XArm.xarm_mount_degrees", "args": []}).encode())
        with urllib.request.urlopen(req, timeout=5) as r:
            assert json.loads(r.read()) == {"code": 0, "data": [0.0, 0.0]}
