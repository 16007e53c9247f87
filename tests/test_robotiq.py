"""The simulated Robotiq 2F-85/2F-140 through register 124 PDUs as the SDK's ``robotiq_*`` functions
send them: Robotiq's register map (action request at 0x03E8, status at 0x07D0), the activation and
reset sequences, motion at the requested speed, object detection and faults; stepped time."""

from __future__ import annotations

import math

import pytest
from helpers import FakeView as View

from xarm_emu.controller.core.interface import PERIOD
from xarm_emu.controller.devices.gripper import GripperModule
from xarm_emu.controller.devices.robotiq import (
    PO_CLOSED,
    PO_OPEN,
    ROBOTIQ_2F85,
    ROBOTIQ_2F140,
    RobotiqGripper,
)
from xarm_emu.controller.emulator import Emulator
from xarm_emu.protocol import rtu
from xarm_emu.protocol.registers import REGISTERS

BAUD_115200 = 5


def module(model=ROBOTIQ_2F85) -> tuple[GripperModule, RobotiqGripper]:
    dev = RobotiqGripper(model)
    return GripperModule(device=dev, tool_baud=lambda: BAUD_115200), dev


def send(mod: GripperModule, pdu: bytes) -> bytes:
    reg = REGISTERS[124]
    out = reg.reply.encode(mod.handlers()[124](reg.request.decode(bytes([9]) + pdu)))
    return out[1:]


def command(mod: GripperModule, action: int, pos: int = 0, speed: int = 0, force: int = 0) -> bytes:
    """The SDK's frame: 09 10 03E8 0003 06 [action 0 0 pos speed force]."""
    pdu = bytes([0x09, 0x10, 0x03, 0xE8, 0x00, 0x03, 0x06, action, 0, 0, pos, speed, force])
    return send(mod, pdu)


def status(mod: GripperModule) -> bytes:
    """The six status bytes the SDK reads (09 03 07D0 0003)."""
    reply = send(mod, bytes.fromhex("09 03 07 D0 00 03"))
    assert reply[:3] == bytes((9, 3, 6))
    return reply[3:]


def run(mod: GripperModule, seconds: float) -> None:
    for _ in range(round(seconds / PERIOD)):
        mod.step(PERIOD, View())


def steps_until(mod: GripperModule, done, limit: float = 10.0) -> int:
    n = 0
    while not done():
        mod.step(PERIOD, View())
        n += 1
        assert n * PERIOD < limit, "never finished"
    return n


def activated(model=ROBOTIQ_2F85) -> tuple[GripperModule, RobotiqGripper]:
    mod, dev = module(model)
    command(mod, 0x00)
    command(mod, 0x01)
    run(mod, model.activation_s + PERIOD)
    return mod, dev


def test_write_reply_echoes_address_and_count() -> None:
    mod, _ = module()
    assert command(mod, 0x00) == bytes.fromhex("09 10 03 E8 00 03")


@pytest.mark.parametrize("model", [ROBOTIQ_2F85, ROBOTIQ_2F140])
def test_activation_takes_its_time_then_reports_gsta_3(model) -> None:
    mod, _ = module(model)
    command(mod, 0x00)
    assert status(mod)[0] == 0x00  # reset: gACT 0, gSTA 0
    command(mod, 0x01)
    assert status(mod)[0] == 0x11  # gACT 1, gSTA 1: activation in progress (Robotiq's example reply)
    n = steps_until(mod, lambda: status(mod)[0] == 0x31)  # gSTA 3: activation completed
    assert n * PERIOD == pytest.approx(model.activation_s, abs=PERIOD)
    assert status(mod)[4] == PO_OPEN  # the calibration ends with the fingers open


def test_motion_at_full_speed_takes_stroke_over_top_speed() -> None:
    mod, dev = activated()
    command(mod, 0x09, 255, 255, 255)
    first = status(mod)
    assert first[0] & 0xC0 == 0 and first[0] & 0x08  # gOBJ 0 (moving), gGTO 1
    assert first[3] == 255  # gPR echoes the request
    n = steps_until(mod, lambda: status(mod)[0] >> 6 == 3)
    s = status(mod)
    assert s[0] == 0xF9 and s[4] == PO_CLOSED  # at the requested position, as Robotiq's example reads
    assert n * PERIOD == pytest.approx(ROBOTIQ_2F85.stroke_mm / ROBOTIQ_2F85.speed_max, abs=PERIOD)
    assert dev.opening_mm == pytest.approx(0.0)


def test_speed_byte_maps_onto_the_speed_range() -> None:
    mod, _ = activated(ROBOTIQ_2F140)
    command(mod, 0x09, 255, 0, 0)  # rSP 0: the slowest speed, 30 mm/s on the 2F-140
    n = steps_until(mod, lambda: status(mod)[0] >> 6 == 3, limit=10.0)
    assert n * PERIOD == pytest.approx(140.0 / 30.0, abs=PERIOD)
    command(mod, 0x09, 0, 128, 0)
    n = steps_until(mod, lambda: status(mod)[0] >> 6 == 3)
    assert n * PERIOD == pytest.approx(140.0 / (30.0 + 220.0 * 128 / 255), abs=PERIOD)
    assert status(mod)[4] == PO_OPEN


def test_request_beyond_the_travel_stops_at_the_mechanical_limits() -> None:
    mod, _ = activated()
    command(mod, 0x09, 250, 255, 255)
    run(mod, 1.0)
    assert status(mod)[3:5] == bytes((250, PO_CLOSED))
    command(mod, 0x09, 1, 255, 255)
    run(mod, 1.0)
    assert status(mod)[3:5] == bytes((1, PO_OPEN))


def test_closing_on_an_object_stops_with_gobj_2_and_the_grip_force() -> None:
    mod, dev = activated()
    dev.set_object(40.0)
    command(mod, 0x09, 255, 255, 128)
    run(mod, 1.0)
    s = status(mod)
    assert s[0] >> 6 == 2  # stopped by a contact while closing
    assert s[4] == round(PO_OPEN + (85.0 - 40.0) / (85.0 / (PO_CLOSED - PO_OPEN)))
    assert dev.opening_mm == pytest.approx(40.0)
    assert dev.grip_force == pytest.approx(20.0 + 215.0 * 128 / 255)
    assert s[5] > 0  # the motor draws current while it holds
    # the object is taken away: the fingers carry on to the request (gOBJ 3: lost or dropped)
    dev.set_object(None)
    run(mod, 1.0)
    assert status(mod)[0] >> 6 == 3 and status(mod)[4] == PO_CLOSED
    assert dev.grip_force == 0.0


def test_an_object_the_request_stops_short_of_is_not_touched() -> None:
    mod, dev = activated()
    dev.set_object(40.0)
    command(mod, 0x09, 60, 255, 255)
    run(mod, 1.0)
    assert status(mod)[0] >> 6 == 3 and status(mod)[4] == 60


def test_opening_onto_an_inner_object_stops_with_gobj_1() -> None:
    mod, dev = activated()
    command(mod, 0x09, 255, 255, 255)
    run(mod, 1.0)
    dev.set_object(30.0, inner=True)
    command(mod, 0x09, 0, 255, 255)
    run(mod, 1.0)
    assert status(mod)[0] >> 6 == 1
    assert dev.opening_mm == pytest.approx(30.0)


def test_motion_during_activation_is_delayed_with_fault_5_then_runs() -> None:
    mod, _ = module()
    command(mod, 0x00)
    command(mod, 0x01)
    command(mod, 0x09, 100, 255, 255)
    s = status(mod)
    assert s[0] >> 4 & 0x03 == 1 and s[2] == 0x05  # activating, "action delayed"
    run(mod, ROBOTIQ_2F85.activation_s + 1.0)
    s = status(mod)
    assert s[2] == 0 and s[0] >> 6 == 3 and s[4] == 100


def test_motion_without_activation_is_fault_7_and_reset_clears_it() -> None:
    mod, _ = module()
    command(mod, 0x08, 100, 255, 255)  # rGTO without rACT
    assert status(mod)[2] == 0x07
    run(mod, 1.0)
    assert status(mod)[4] == PO_OPEN  # nothing moved
    command(mod, 0x00)
    assert status(mod)[2] == 0


def test_injected_fault_stops_the_fingers_until_reset_and_activation() -> None:
    mod, dev = activated()
    command(mod, 0x09, 255, 0, 255)
    run(mod, 0.5)
    dev.inject_error(0x0E)
    where = status(mod)[4]
    run(mod, 0.5)
    assert status(mod)[2] == 0x0E and status(mod)[4] == where
    command(mod, 0x09, 0, 255, 255)  # refused while the fault holds
    run(mod, 0.5)
    assert status(mod)[4] == where
    command(mod, 0x00)
    command(mod, 0x01)
    run(mod, 2.0)
    assert status(mod)[2] == 0 and status(mod)[0] == 0x31
    with pytest.raises(ValueError):
        dev.inject_error(3)  # not a Robotiq fault code


def test_partial_status_reads_and_output_readback() -> None:
    mod, _ = activated()
    assert send(mod, bytes.fromhex("09 03 07 D0 00 01")) == bytes.fromhex("09 03 02 31 00")
    command(mod, 0x09, 0x40, 0x80, 0xC0)
    assert send(mod, bytes.fromhex("09 03 03 E8 00 03")) == bytes.fromhex("09 03 06 09 00 00 40 80 C0")


def test_addresses_outside_the_map_get_illegal_address() -> None:
    mod, _ = module()
    assert send(mod, bytes.fromhex("09 03 00 00 00 01")) == bytes((9, 0x83, rtu.ILLEGAL_ADDRESS))
    assert send(mod, rtu.write_single_request(9, 0x07D0, 1)) == bytes((9, 0x86, rtu.ILLEGAL_ADDRESS))


def test_wrong_baud_rate_or_slave_id_gets_no_answer() -> None:
    dev = RobotiqGripper()
    mod = GripperModule(device=dev, tool_baud=lambda: 11)  # the bus at 2 Mbps, the gripper at 115200
    assert send(mod, bytes.fromhex("09 03 07 D0 00 03")) == bytes((9, 0x83, rtu.GATEWAY_NO_RESPONSE))
    mod = GripperModule(device=dev, tool_baud=lambda: BAUD_115200)
    assert send(mod, bytes.fromhex("08 03 00 00 00 01")) == bytes((8, 0x83, rtu.GATEWAY_NO_RESPONSE))


def test_emulator_attaches_the_model_and_checkpoints_it() -> None:
    emu = Emulator(6, gripper="robotiq-2f140")
    dev = emu.gripper.device
    assert isinstance(dev, RobotiqGripper) and dev.model is ROBOTIQ_2F140
    cp = emu.checkpoint()
    dev.inject_error(0x0E)
    dev.position = 100.0
    emu.restore(cp)
    assert (dev.error, dev.position) == (0, PO_OPEN)
    assert emu.gripper_status()["gripper"] == "robotiq-2f140"
    with pytest.raises(ValueError, match="one end tool"):
        Emulator(6, gripper="robotiq-2f85", vacuum=True)
    with pytest.raises(ValueError, match="gripper 'robotiq'"):
        Emulator(6, gripper="robotiq")


def test_object_width_beyond_the_stroke_is_refused() -> None:
    emu = Emulator(6, gripper="robotiq-2f85")
    with pytest.raises(ValueError, match="opens 0..85 mm"):
        emu.check_input("gripper-object", 0, 90.0)
    with pytest.raises(ValueError, match="finite"):
        emu.check_input("gripper-object", 0, math.nan)
    with pytest.raises(ValueError, match="index 0"):
        emu.check_input("gripper-object", 2, 10.0)


@pytest.mark.parametrize("kind", ["robotiq-2f85", "robotiq-2f140", "bio"])
def test_the_view_draws_the_fingers_apart_by_the_opening(kind: str) -> None:
    import numpy as np

    from xarm_emu.model import kinematics as kin
    from xarm_emu.viewer import scene

    emu = Emulator(6, gripper=kind)
    q = np.array([0.3, -0.2, -0.3, 0.0, 0.5, 0.1])
    axis_y = kin.fk(emu.model, q)[:3, 1]
    opening = emu.gripper_status()["opening_mm"]
    body, a, b = scene.end_gripper_parts(emu.model, q, kind, opening)
    assert body.name == "tool_body"
    finger_y = scene.GRIPPER_SHAPES[kind].finger_half[1]
    gap = float(np.dot(np.array(a.position) - np.array(b.position), axis_y)) - 2 * finger_y
    assert gap == pytest.approx(opening / 1000.0, abs=1e-9)
