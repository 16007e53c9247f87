"""Checkpoint and restore keep every register that stores something, read back through the unchanged
official SDK and through standard Modbus-TCP: the tool bus's Modbus timeouts (registers 123 and
240) and baud rate, the Modbus user coils and registers, the TCP offset and load, reduced mode,
the collision sensitivity, the report's counter, the xArm gripper's and the linear track's settings
(an emulator feature: no real control box has checkpoints)."""

from __future__ import annotations

from typing import Any

from helpers import wait_for
from pymodbus.client import ModbusTcpClient

from xarm_emu.client.admin import AdminClient
from xarm_emu.controller.emulator import Emulator


def _observe(arm: Any, mb: ModbusTcpClient) -> dict[str, Any]:
    """Every stored value, as the SDK and a Modbus client read it."""

    def value(got: Any) -> Any:
        code, v = got
        assert code == 0, got
        return v

    reduced = value(arm.get_reduced_states())
    coils = mb.read_coils(256, count=8, device_id=1)
    regs = mb.read_holding_registers(256, count=4, device_id=1)
    assert not coils.isError() and not regs.isError()
    return {  # the tool bus baud rate first: the SDK's gripper calls set their own
        "tool baud": value(arm.get_tgpio_modbus_baudrate()),
        "modbus timeout": value(arm.get_tgpio_modbus_timeout()),
        "transparent timeout": value(arm.get_tgpio_modbus_timeout(is_transparent_transmission=True)),
        "user coils": list(coils.bits[:8]),
        "user registers": list(regs.registers),
        "tcp offset": [round(x, 3) for x in arm.tcp_offset],
        "tcp load": [round(arm.tcp_load[0], 3), [round(x, 3) for x in arm.tcp_load[1]]],
        "reduced mode": value(arm.get_reduced_mode()),
        "reduced tcp speed": round(reduced[2], 3),
        "collision sensitivity": arm.collision_sensitivity,
        "counter": arm.count,
        "gripper": [value(arm.get_gripper_position()), arm.get_gripper_status()[1]],
        "track": [value(arm.get_linear_motor_is_enabled()), round(value(arm.get_linear_motor_pos()), 1),
                  value(arm.get_linear_motor_sci())],
    }


def _settle(arm: Any, mb: ModbusTcpClient, counter: int) -> dict[str, Any]:
    """The observation once the reports the SDK reads show ``counter`` (the last value written)."""
    assert wait_for(lambda: arm.count == counter, timeout=5.0), (arm.count, counter)
    return _observe(arm, mb)


def _store(arm: Any, mb: ModbusTcpClient, n: int) -> None:
    """Write a set of values (``n`` = 1 or 2 gives two different sets, neither the power-on one)."""
    assert arm.set_tgpio_modbus_timeout(30 + 40 * n) == 0
    assert arm.set_tgpio_modbus_timeout(25 + 30 * n, is_transparent_transmission=True) == 0
    assert not mb.write_coils(256, [bool(n & 1), True, bool(n & 2)], device_id=1).isError()
    assert not mb.write_registers(256, [1234 * n, 7 + n], device_id=1).isError()
    assert arm.set_tcp_offset([0, 0, 40.0 * n, 0, 0, 0], wait=False) == 0
    assert arm.set_state(0) == 0  # settings changes stop the arm (state 4), as on the box
    assert arm.set_tcp_load(0.3 * n, [0, 0, 20.0 * n], wait=False) == 0
    assert arm.set_state(0) == 0
    assert arm.set_reduced_max_tcp_speed(100.0 * n) == 0
    assert arm.set_reduced_mode(n == 1) == 0
    assert arm.set_collision_sensitivity(n + 1, wait=False) == 0
    assert arm.set_state(0) == 0
    for _ in range(n):
        assert arm.set_counter_increase() == 0
    assert arm.set_gripper_enable(True) == 0
    assert arm.set_gripper_speed(3000) == 0
    assert arm.set_gripper_position(200 * n, wait=True) == 0
    if n == 1:
        assert arm.set_linear_motor_back_origin(wait=True) == 0  # homes, then enables
    assert arm.set_linear_motor_speed(500) == 0
    assert arm.set_linear_motor_pos(100.0 * n, wait=True) == 0
    # Last: the SDK's gripper calls set the gripper's baud rate first (a change costs 1.3 s in the SDK).
    assert arm.set_tgpio_modbus_baudrate((1000000, 921600)[n - 1]) == 0
    arm.set_state(0)


def test_restore_brings_back_every_stored_register_through_the_sdk_and_modbus(
        make_server: Any, sdk_arm: Any, tmp_path: Any) -> None:
    emu = Emulator(6, firmware="2.7.103", linear_track=700, config_dir=tmp_path / "conf")
    st = make_server(emulator=emu, admin=True)
    arm = sdk_arm(st)
    mb = ModbusTcpClient("127.0.0.1", port=st.ports["command"], timeout=3)
    assert mb.connect()
    try:
        assert arm.motion_enable(True) == 0 and arm.set_mode(0) == 0 and arm.set_state(0) == 0
        power_on = _settle(arm, mb, 0)  # the SDK's counter is -1 until the first report
        with AdminClient("127.0.0.1", st.ports["admin"]) as admin:
            _store(arm, mb, 1)
            admin.request("checkpoint-save", name="stored")
            first = _settle(arm, mb, power_on["counter"] + 1)
            assert [k for k in first if first[k] == power_on[k]] == []
            _store(arm, mb, 2)
            second = _settle(arm, mb, first["counter"] + 2)
            assert [k for k in second if second[k] == first[k]] == []
            admin.request("checkpoint-restore", name="stored")
        assert _settle(arm, mb, first["counter"]) == first
    finally:
        mb.close()
