"""The stepped clock's jump over idle control periods with the Robotiq 2F gripper, the BIO gripper or
the F/T sensor mounted: each device says when it is idle (``idle_until``), and the same program run
with the jump and with every period stepped (``Emulator(exact_steps=True)``) shows the same report
bytes (develop, normal, rich; manual 2.1.6), the same register replies, the same device registers
and the same clock at every instant a client could look, while most of the long rests are jumped."""

from __future__ import annotations

import struct
from collections.abc import Callable
from typing import Any

import numpy as np
from helpers import report_frames, step_both

from xarm_emu.controller.core.interface import NOT_IDLE, idle_until
from xarm_emu.controller.devices import bio_gripper as bio
from xarm_emu.controller.devices import ft_sensor as ft
from xarm_emu.controller.devices import robotiq
from xarm_emu.controller.emulator import Emulator
from xarm_emu.protocol.rtu import TOOL_HOST

Action = Callable[[Emulator], object]
#: Parameterless reads: version, state, cmdnum, errors, poses, torques, the gripper's error (106).
READS = (1, 13, 14, 15, 41, 42, 43, 106, 131)


def send(emu: Emulator, code: int, **values: Any) -> tuple[int, bytes]:
    reg = emu.controller.registers[code]
    return emu.handle(code, reg.request.encode(values))


def tool_pdu(emu: Emulator, pdu: bytes) -> tuple[int, bytes]:
    """Register 124: one Modbus-RTU PDU on the tool RS-485, as the SDK sends it."""
    return emu.handle(124, bytes([TOOL_HOST]) + pdu)


def tool_baud(index: int) -> Action:
    """Register 127, 0x1A0B: the tool RS-485 baud index (the SDK switches it before a gripper)."""
    return lambda e: send(e, 127, host=TOOL_HOST, addr=0x1A0B, value=float(index), sync=0)


def ready(emu: Emulator) -> None:
    for code, values in ((11, {"joint": 8, "enable": 1}), (19, {"mode": 0}), (12, {"state": 0})):
        send(emu, code, **values)


def move(joints: tuple[float, ...]) -> Action:
    return lambda e: send(e, 23, joints=(*joints, 0.0), speed=1.5, acc=10.0, mvtime=0.0)


def observe(emu: Emulator, device_reads: tuple[bytes, ...]) -> tuple[Any, ...]:
    """Everything a client can see now: every report frame, the replies of the reads and of the
    device's own registers, the F/T registers when mounted, the clock to the bit and the thermal
    state behind the rich report's temperatures."""
    frames = report_frames(emu)
    regs = emu.controller.registers
    replies = tuple(emu.handle(code, b"") for code in READS if code in regs)
    device = tuple(tool_pdu(emu, pdu) for pdu in device_reads)
    sensor = tuple(emu.handle(code, arg) for code, arg in ((150, b""), (200, b""), (200, b"\x01"))
                   if code in regs)
    return (frames, replies, device, sensor, emu.time.hex(), emu.controller.steps,
            emu.thermal.temperatures.tobytes())


def run_both(script: dict[int, list[Action]], total: int, pattern: tuple[int, ...],
             device_reads: tuple[bytes, ...] = (), **kw: Any) -> tuple[int, Emulator]:
    """Run ``script`` (period count -> actions before stepping on) on a jumping and an exact emulator
    built with ``kw``, comparing what both show at every instant; returns the instants compared and
    the jumping emulator."""
    fast = Emulator(6, **kw)
    exact = Emulator(6, exact_steps=True, **kw)
    for emu in (fast, exact):
        emu.controller.strict = True
    instants = step_both(fast, exact, script, total, pattern, lambda emu: observe(emu, device_reads))
    assert exact.periods_jumped == 0
    return instants, fast


# -- the Robotiq 2F-85 ---------------------------------------------------------------------------

def robotiq_action(action: int, pos: int = 0, speed: int = 0, force: int = 0) -> Action:
    """The SDK's frame: 09 10 03E8 0003 06 [action 0 0 pos speed force]."""
    pdu = bytes([robotiq.ROBOTIQ_ID, 0x10, 0x03, 0xE8, 0x00, 0x03, 0x06, action, 0, 0, pos, speed, force])
    return lambda e: tool_pdu(e, pdu)


ROBOTIQ_STATUS = bytes([robotiq.ROBOTIQ_ID, 0x03, 0x07, 0xD0, 0x00, 0x03])


def robotiq_device(emu: Emulator) -> robotiq.RobotiqGripper:
    dev = emu.gripper.device
    assert isinstance(dev, robotiq.RobotiqGripper)
    return dev


def test_robotiq_program_identical_and_jumped() -> None:
    """Reset, activate (with a request that waits for it), close on an object, lose it, open, with
    arm moves and long rests in between."""
    script: dict[int, list[Action]] = {
        0: [ready, tool_baud(robotiq.ROBOTIQ_BAUD_INDEX), robotiq_action(0x00), robotiq_action(0x01),
            robotiq_action(0x09, 200, 128, 100)],  # requested during the activation: fault 5, then runs
        900: [lambda e: e.set_input("gripper-object", 0, 40.0), robotiq_action(0x09, 255, 255, 200)],
        1500: [move((0.3, -0.2, -0.3, 0.0, 0.4, 0.0))],
        2600: [lambda e: e.set_input("gripper-object", 0, 0.0)],  # dropped: the fingers carry on
        3400: [robotiq_action(0x09, 0, 64, 50)],
        4800: [robotiq_action(0x00)],
    }
    _, fast = run_both(script, 6000, (1, 7, 250, 3, 600, 25), (ROBOTIQ_STATUS,),
                       gripper="robotiq-2f85")
    dev = robotiq_device(fast)
    assert dev.gSTA == robotiq.STA_RESET and dev.position == robotiq.PO_OPEN
    assert fast.periods_jumped > 0.6 * fast.controller.steps


def test_robotiq_is_idle_only_when_nothing_runs() -> None:
    emu = Emulator(6, gripper="robotiq-2f85")
    ctl, dev = emu.controller, robotiq_device(emu)
    tool_baud(robotiq.ROBOTIQ_BAUD_INDEX)(emu)
    assert idle_until(dev, ctl) == np.inf  # reset, at rest
    robotiq_action(0x01)(emu)
    assert idle_until(dev, ctl) == NOT_IDLE  # activating
    emu.advance(robotiq.ROBOTIQ_2F85.activation_s + 0.1)
    assert dev.gSTA == robotiq.STA_ACTIVATED and idle_until(dev, ctl) == np.inf
    robotiq_action(0x09, 255, 255, 0)(emu)
    assert idle_until(dev, ctl) == NOT_IDLE  # the fingers move
    emu.advance(3.0)
    assert dev.gOBJ == robotiq.OBJ_AT_POSITION and idle_until(dev, ctl) == np.inf
    jumped = emu.periods_jumped
    emu.advance(10.0)
    assert emu.periods_jumped - jumped == 2499  # all but the last period of the call


# -- the BIO gripper -------------------------------------------------------------------------------

def bio_write(addr: int, value: int) -> Action:
    return lambda e: tool_pdu(e, bytes([bio.BIO_ID, 0x06]) + struct.pack(">HH", addr, value))


def bio_move(pos: int, speed: int = 2000, force: int = 100) -> Action:
    """The SDK's 08 10 0C00 0005 0A 0001 <speed> <force> <s32 pos>."""
    pdu = bytes.fromhex("08 10 0C 00 00 05 0A 00 01") + struct.pack(">hhi", speed, force, pos)
    return lambda e: tool_pdu(e, pdu)


BIO_READS = (struct.pack(">BBHH", bio.BIO_ID, 0x03, bio.REG_STATUS, 1),
             struct.pack(">BBHH", bio.BIO_ID, 0x03, bio.REG_POSITION, 2),
             struct.pack(">BBHH", bio.BIO_ID, 0x03, bio.REG_ERROR, 1))


def test_bio_program_identical_and_jumped() -> None:
    """Enable, close on an object, let it slip out (error 12), clear, open, with rests and a move."""
    script: dict[int, list[Action]] = {
        0: [ready, bio_write(bio.REG_ENABLE, 1), bio_move(150)],  # sent while enabling: not followed
        400: [lambda e: e.set_input("gripper-object", 0, 100.0), bio_move(71, 1500, 80)],
        1300: [move((-0.2, 0.1, -0.2, 0.0, 0.3, 0.0))],
        2500: [lambda e: e.set_input("gripper-object", 0, 0.0)],  # slips out: error 12
        2900: [bio_write(bio.REG_ERROR, 0), bio_move(150, 3000)],
        4000: [bio_write(bio.REG_ENABLE, 0)],
    }
    _, fast = run_both(script, 5000, (2, 9, 300, 1, 500, 40), BIO_READS, gripper="bio")
    dev = fast.gripper.device
    assert isinstance(dev, bio.BioGripper)
    assert dev.enable == bio.ENABLE_OFF and dev.position == bio.PULSE_MAX and dev.error == 0
    assert fast.periods_jumped > 0.6 * fast.controller.steps


def test_bio_is_idle_only_when_nothing_runs() -> None:
    emu = Emulator(6, gripper="bio")
    ctl, dev = emu.controller, emu.gripper.device
    assert isinstance(dev, bio.BioGripper)
    assert idle_until(dev, ctl) == np.inf
    bio_write(bio.REG_ENABLE, 1)(emu)
    assert idle_until(dev, ctl) == NOT_IDLE  # enabling
    emu.advance(bio.ENABLE_TIME + 0.1)
    assert dev.enabled and idle_until(dev, ctl) == np.inf
    bio_move(71)(emu)
    assert idle_until(dev, ctl) == NOT_IDLE  # moving
    emu.advance(5.0)
    assert not dev.moving and idle_until(dev, ctl) == np.inf


# -- the F/T sensor ------------------------------------------------------------------------------------

def sensor_on(emu: Emulator) -> None:
    assert emu.handle(201, b"\x01")[0] & 0x60 == 0


def test_ft_sensor_program_identical_and_jumped() -> None:
    """Firmware 2.x with the sensor switched on and its noise and drift: a ramped wrench with an end
    (the ramp jumped over at rest), a held one cleared, a zero (register 206), a payload, the noise
    off and on again, moves and long rests."""
    script: dict[int, list[Action]] = {
        0: [ready, sensor_on],
        300: [lambda e: e.apply_wrench((0.0, 0.0, -12.0, 0.0, 0.1, 0.0), ramp_s=0.5, duration_s=6.3)],
        1200: [move((0.3, -0.2, -0.3, 0.0, 0.4, 0.0))],
        2500: [lambda e: e.apply_wrench((2.0, -1.0, 0.0, 0.0, 0.0, 0.05), frame="base")],
        3600: [lambda e: e.handle(206, b""), lambda e: e.set_payload(0.8, (0.0, 0.0, 50.0))],
        4300: [lambda e: e.clear_wrench()],
        5000: [lambda e: e.set_ft_noise(False)],
        5600: [lambda e: e.set_ft_noise(True)],
    }
    _, fast = run_both(script, 7000, (1, 5, 250, 2, 700, 25, 3), firmware="2.7.103", ft_sensor=True)
    assert ft.enabled(fast.controller)
    assert fast.periods_jumped > 0.6 * fast.controller.steps


def test_ft_sensor_on_a_1x_firmware_identical_and_jumped() -> None:
    """Firmware 1.11.100 (the manual's frames): the sensor switched on, a wrench that ends."""
    script: dict[int, list[Action]] = {
        0: [ready, sensor_on, lambda e: e.apply_wrench((1.0, 2.0, 3.0, 0.0, 0.0, 0.0), duration_s=2.0)],
        1000: [move((0.1, 0.1, -0.1, 0.0, 0.2, 0.0))],
    }
    _, fast = run_both(script, 3000, (1, 3, 400, 50), firmware="1.11.100", ft_sensor=True)
    assert not ft.state_of(fast.controller).wrenches  # it ended and was removed
    assert fast.periods_jumped > 0.6 * fast.controller.steps


def test_ft_sensor_idle_conditions() -> None:
    emu = Emulator(6, firmware="2.7.103", ft_sensor=True)
    ctl = emu.controller
    ready(emu)
    sensor_on(emu)
    (comp,) = [c for c in ctl.components if isinstance(c, ft.FtSensorComponent)]
    assert idle_until(comp, ctl) == NOT_IDLE  # switched on, no periods measured yet
    emu.step(3)
    assert idle_until(comp, ctl) == np.inf
    start = ctl.time
    emu.apply_wrench((0.0, 0.0, 5.0, 0.0, 0.0, 0.0), ramp_s=1.0, duration_s=3.0)
    # a ramp is a function of the clock, computed afresh by the period that runs: idle up to its end
    assert abs(idle_until(comp, ctl) - (start + 3.0)) < 1e-6
    jumped = emu.periods_jumped
    emu.advance(0.5)
    assert emu.periods_jumped - jumped == 124
    emu.advance(3.0)  # the period in which it ends runs in full and removes it
    assert not ft.state_of(ctl).wrenches and idle_until(comp, ctl) == np.inf
    assert emu.periods_jumped - jumped == 124 + 748
    emu.set_payload(1.0, (0.0, 0.0, 40.0))
    assert idle_until(comp, ctl) == NOT_IDLE  # the load's centre moved: its acceleration shows
    emu.clear_wrench()
    emu.step(3)
    assert idle_until(comp, ctl) == np.inf
    # a force control application (register 202) acts on every reading: never idle while set
    assert send(emu, 202, app=1, on=1)[0] & 0x60 == 0
    assert idle_until(comp, ctl) == NOT_IDLE


def test_ft_noise_is_a_function_of_the_period_and_keeps_its_statistics() -> None:
    """The noise of a period does not depend on the periods drawn before it; seeded and
    repeatable; its amplitude is the sensor's; the drift starts from zero and stays bounded."""
    a = np.array([ft.white_noise(ft.NOISE_SEED, n) for n in range(3000)])
    assert np.array_equal(ft.white_noise(ft.NOISE_SEED, 2717), a[2717])  # any order, same value
    assert not np.array_equal(ft.white_noise(ft.NOISE_SEED + 1, 2717), a[2717])
    assert not np.array_equal(a[1], a[2]) and not np.array_equal(a[249], a[250])
    sd = a.std(axis=0)
    assert np.allclose(sd[:3], ft.NOISE_FORCE, rtol=0.1) and np.allclose(sd[3:], ft.NOISE_TORQUE, rtol=0.1)
    assert np.all(np.abs(a.mean(axis=0)) < 3 * sd / np.sqrt(len(a)) + 1e-12)
    assert np.array_equal(ft.drift(ft.NOISE_SEED, 0.0), np.zeros(6))
    walk = np.array([ft.DRIFT_RATE[0]] * 3 + [ft.DRIFT_RATE[1]] * 3)
    d = np.array([ft.drift(ft.NOISE_SEED, t) for t in np.arange(0.0, 3000.0, 0.5)])
    assert np.all(np.abs(d) <= ft.DRIFT_LIMIT * walk + 1e-15)
    assert np.all(d.std(axis=0) > 2 * walk)  # it does drift
    small = np.abs(np.array([ft.drift(seed, 1.0) for seed in range(100)]))
    assert np.all(small.mean(axis=0) < 3 * walk)  # about the random walk's size after 1 s


def test_ft_reading_after_a_jump_equals_the_stepped_one_and_noise_off_is_exact() -> None:
    def box(exact: bool, noise: bool) -> Emulator:
        emu = Emulator(6, firmware="2.7.103", ft_sensor=True, ft_noise=noise, exact_steps=exact)
        ready(emu)
        sensor_on(emu)
        return emu

    fast, exact = box(False, True), box(True, True)
    for emu in (fast, exact):
        emu.step(5)
        emu.step(1234)
    assert fast.periods_jumped > 1200
    assert fast.handle(200, b"\x01") == exact.handle(200, b"\x01")
    quiet = box(False, False)
    quiet.advance(10.0)
    state, reply = quiet.handle(200, b"")
    assert state & 0x60 == 0 and struct.unpack("<6f", reply) == (0.0,) * 6
