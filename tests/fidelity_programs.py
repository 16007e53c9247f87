"""A library of ordinary SDK programs for the fidelity tests: each is run by the unchanged SDK through
the recording proxy against an emulator, with readers on every report port (two on 30002 and 30003),
and the recording is then compared with the emulator itself, which must show no difference."""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from proxy_session import sdk_through_proxy

from xarm_emu.model.calibration import Calibration
from xarm_emu.protocol.firmware import SERVE_VERSION
from xarm_emu.server.thread import ServerThread

#: A reader on every report port, two on the rich (the SDK's own is a third) and develop reports.
READERS = ("realtime", "normal", "rich", "develop", "rich", "develop")


def recorded(path: Path, model: int | str = 6, firmware: str = SERVE_VERSION,
             calibration: Calibration | None = None, check_joint_limit: bool = True,
             **emulator: Any) -> contextlib.AbstractContextManager[tuple[ServerThread, Any]]:
    """``(server, arm)``: an SDK ``XArmAPI`` through the recording proxy (to ``path``) in front of an
    emulator of ``model`` at ``firmware``, enabled, in mode 0 and state 0; the report readers of
    :data:`READERS` that the firmware serves read through the proxy too; ``check_joint_limit=False``
    lets the SDK send joints beyond the arm's limits (the box refuses them)."""
    return sdk_through_proxy(path, calibration, READERS, model=model, firmware=firmware,
                             check_joint_limit=check_joint_limit, **emulator)


def wait_still(arm: Any, timeout: float = 5.0) -> None:
    """Until the arm has stopped (state not 1), then a little more, so that the end is recorded."""
    end = time.monotonic() + timeout
    time.sleep(0.05)
    while arm.get_state()[1] == 1 and time.monotonic() < end:
        time.sleep(0.02)
    time.sleep(0.05)


def payload_tcp_gripper_io(arm: Any) -> None:
    """Payload and TCP offset changed between joint and linear moves, the gripper, IO."""
    assert arm.set_servo_angle(angle=[5, -5, -10, 0, 15, 0], speed=150, wait=True) == 0
    arm.set_tcp_load(1.5, [0, 0, 60])
    arm.set_tcp_offset([0, 0, 50, 0, 0, 0])
    arm.set_state(0)
    pose = arm.get_position()[1]
    assert arm.set_position(x=pose[0] + 30, y=pose[1], z=pose[2] - 20, roll=pose[3], pitch=pose[4],
                            yaw=pose[5], speed=300, wait=True) == 0
    arm.set_gripper_enable(True)
    arm.set_gripper_position(400, wait=False)
    arm.set_cgpio_digital(2, 1)
    arm.get_cgpio_state()
    arm.set_tcp_load(0.2, [0, 0, 20])
    arm.set_state(0)
    assert arm.set_servo_angle(angle=[-5, 0, -15, 0, 10, 0], speed=150, wait=True) == 0


def servo_stream(arm: Any, mode: int = 1, n: int = 25) -> None:
    """A 100 Hz ``set_servo_angle_j`` stream in servo mode."""
    arm.set_mode(mode)
    arm.set_state(0)
    time.sleep(0.05)
    for k in range(n):
        arm.set_servo_angle_j([k * 0.05, 0, 0, 0, 0, 0])
        time.sleep(0.01)
    time.sleep(0.05)
    arm.set_mode(0)
    arm.set_state(0)


def blended_lines(arm: Any) -> None:
    """Four linear moves blended with a radius of 20 mm, then a circle."""
    x, y, z, roll, pitch, yaw = arm.get_position()[1]
    for dx, dy in ((40, 0), (40, 40), (0, 40), (0, 0)):
        arm.set_position(x=x + dx, y=y + dy, z=z, roll=roll, pitch=pitch, yaw=yaw, speed=400, radius=20,
                         wait=False)
    wait_still(arm)
    arm.move_circle([x + 15, y + 15, z, roll, pitch, yaw], [x + 30, y, z, roll, pitch, yaw], 50, speed=400,
                    wait=True)
    wait_still(arm)


def velocity(arm: Any) -> None:
    """Joint velocity control (mode 4), then Cartesian velocity control (mode 5)."""
    arm.set_mode(4)
    arm.set_state(0)
    time.sleep(0.05)
    arm.vc_set_joint_velocity([20, 0, 0, 0, 0, 0])
    time.sleep(0.2)
    arm.vc_set_joint_velocity([0, 0, 0, 0, 0, 0])
    time.sleep(0.1)
    arm.set_mode(5)
    arm.set_state(0)
    time.sleep(0.05)
    arm.vc_set_cartesian_velocity([30, 0, 0, 0, 0, 0])
    time.sleep(0.2)
    arm.vc_set_cartesian_velocity([0, 0, 0, 0, 0, 0])
    time.sleep(0.1)
    arm.set_mode(0)
    arm.set_state(0)


def refused_and_recovered(arm: Any) -> None:
    """Moves the box refuses (a joint beyond its limit, a pose out of reach), the error read and
    cleared, then a move."""
    arm.set_servo_angle(angle=[400, 0, 0, 0, 0, 0], speed=50, wait=True)
    arm.get_err_warn_code()
    arm.clean_error()
    arm.motion_enable(True)
    arm.set_state(0)
    time.sleep(0.25)  # the SDK learns that the error is gone from its report (5 Hz)
    arm.set_position(x=1200, y=0, z=200, roll=180, pitch=0, yaw=0, speed=100, wait=True)
    arm.get_err_warn_code()
    arm.clean_error()
    arm.clean_warn()
    arm.motion_enable(True)
    arm.set_state(0)
    time.sleep(0.25)  # the SDK learns that the error is gone from its report (5 Hz)
    assert arm.set_servo_angle(angle=[5, 0, 0, 0, 0, 0], speed=150, wait=True) == 0


def first_program(arm: Any) -> None:
    """A joint move and a linear move, as a first program on a new arm does."""
    q = arm.get_servo_angle()[1]
    assert arm.set_servo_angle(angle=[q[0] + 10, *q[1:4], q[4] + 10, *q[5:]], speed=150, wait=True) == 0
    pose = arm.get_position()[1]  # (an arm at a singular pose refuses it: the replay must too)
    arm.set_position(x=pose[0] + 30, y=pose[1] + 20, z=pose[2], roll=pose[3], pitch=pose[4], yaw=pose[5],
                     speed=300, wait=True)


def online_planning(arm: Any) -> None:
    """Online trajectory planning: joint targets in mode 6, a Cartesian target in mode 7."""
    arm.set_mode(6)
    arm.set_state(0)
    time.sleep(0.05)
    arm.set_servo_angle(angle=[15, 0, -10, 0, 10, 0], speed=60, wait=False)
    time.sleep(0.15)
    arm.set_servo_angle(angle=[-5, 0, -10, 0, 10, 0], speed=60, wait=False)
    time.sleep(0.3)
    arm.set_mode(7)
    arm.set_state(0)
    time.sleep(0.05)
    pose = arm.get_position()[1]
    arm.set_position(x=pose[0] + 20, y=pose[1], z=pose[2], roll=pose[3], pitch=pose[4], yaw=pose[5],
                     speed=100, wait=False)
    time.sleep(0.4)
    arm.set_mode(0)
    arm.set_state(0)


def world_offset_save_reset(arm: Any) -> None:
    """A world offset and a TCP offset, the settings saved, a move, then the arm reset home."""
    arm.set_world_offset([0, 0, 0, 0, 0, 10])
    arm.set_tcp_offset([0, 0, 30, 0, 0, 0])
    arm.set_state(0)
    arm.save_conf()
    assert arm.set_position(x=300, y=-40, z=220, roll=180, pitch=0, yaw=0, speed=300, wait=True) == 0
    arm.set_world_offset([0, 0, 0, 0, 0, 0])
    arm.set_state(0)
    arm.reset(wait=True, speed=120)


def two_clients_reconnect(arm: Any) -> None:
    """A second command client reads while the first moves; the first disconnects and connects again."""
    from xarm.wrapper import XArmAPI

    assert arm.set_servo_angle(angle=[10, -5, -5, 0, 10, 0], speed=120, wait=False) == 0
    other = XArmAPI("127.0.0.1", is_radian=False)
    try:
        for _ in range(5):
            other.get_servo_angle()
            other.get_position()
            time.sleep(0.02)
    finally:
        other.disconnect()
    wait_still(arm)
    arm.disconnect()
    time.sleep(0.05)
    arm.connect()
    arm.set_state(0)
    assert arm.set_servo_angle(angle=[0, 0, 0, 0, 0, 0], speed=120, wait=True) == 0


@dataclass(frozen=True)
class Program:
    """An SDK program and the emulator it runs against (``recorded`` keywords)."""

    run: Callable[[Any], None]
    emulator: dict[str, Any] = field(default_factory=dict)


#: Programs of every kind a user writes: payload and TCP changes with the gripper and IO, a 100 Hz servo
#: stream, blended lines, velocity control, a move the box refuses at 1.6.0 and a Lite 6 first, then
#: online planning, world offset with save and reset, and two clients with a reconnect.
PROGRAMS = {
    "payload": Program(payload_tcp_gripper_io),
    "servo_mode1": Program(servo_stream),
    "blends": Program(blended_lines),
    "velocity": Program(velocity),
    "refused_1.6.0": Program(refused_and_recovered, {"firmware": "1.6.0", "check_joint_limit": False}),
    "lite6": Program(first_program, {"model": "lite6"}),
    "online_6_7": Program(online_planning),
    "world_offset_save_reset": Program(world_offset_save_reset, {"model": 7}),
    "two_clients": Program(two_clients_reconnect, {"model": 5}),
}


#: The programs ``make test`` runs, grouped by the emulator they need, each group one recording (the
#: SDK's connection costs most of a second): the first six kinds of :data:`PROGRAMS` and a few more.
SESSIONS = {
    "xarm6": ("payload", "servo_mode1", "blends", "velocity", "online_6_7"),
    "xarm6_1.6.0": ("refused_1.6.0",),
    "lite6": ("lite6",),
    "xarm5": ("two_clients",),
}


def record(names: str | tuple[str, ...], path: Path, **emulator: Any) -> int:
    """Run program ``names`` (one, or several in turn, needing the same emulator) through the proxy,
    recorded to ``path``; the report frames the emulator behind the proxy missed (due, never sent: the
    process was starved of the processor)."""
    names = (names,) if isinstance(names, str) else names
    progs = [PROGRAMS[n] for n in names]
    with recorded(path, **{**progs[0].emulator, **emulator}) as (st, arm):
        for prog in progs:
            prog.run(arm)
            if arm.connected:
                arm.set_mode(0)
                arm.set_state(0)
        return sum(st.server.reports.frames_missed.values())
