"""Stepped-clock speed, each figure against a baseline measured in the same run:

- a 60 s mixed program (joint, linear, circular moves, a dwell) and a 60 s mostly idle program (one
  move, delayed outputs, scheduled actions) run in process, as factors of real time, with the jump
  over idle periods and with every period stepped (``Emulator(exact_steps=True)``, the baseline);
- the mostly idle program with the F/T sensor, the Robotiq or the BIO gripper mounted, the same way;
- the cost of one ``step(25)`` (what a 100 Hz report reader makes the server run) of an idle arm
  against one of an arm in motion.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

from xarm_emu.controller.emulator import Emulator
from xarm_emu.protocol.registers import REGISTERS

PROGRAM_SECONDS = 60.0
PERIODS = round(PROGRAM_SECONDS / 0.004)
REPEATS = 5


def _call(emu: Emulator, code: int, **values: object) -> None:
    emu.handle(code, REGISTERS[code].request.encode(values))


def _ready(emu: Emulator) -> None:
    for code, values in ((11, {"joint": 8, "enable": 1}), (19, {"mode": 0}), (12, {"state": 0})):
        _call(emu, code, **values)


def _program(emu: Emulator) -> None:
    """The mixed program: four rounds of a joint move, blended lines, a circle, a dwell, home."""
    _ready(emu)
    pi = math.pi
    for k in range(4):
        _call(emu, 23, joints=(0.4, 0.1, -0.3, 0.0, 0.2, 0.0, 0.0), speed=1.0, acc=8.0, mvtime=0.0)
        _call(emu, 22, pose=(300.0, 50.0, 200.0 + 10 * k, pi, 0.0, 0.0), speed=150.0, acc=2000.0, mvtime=0.0,
              radius=20.0)
        _call(emu, 21, pose=(300.0, -50.0, 200.0, pi, 0.0, 0.0), speed=150.0, acc=2000.0, mvtime=0.0)
        _call(emu, 27, pose1=(330.0, 0.0, 200.0, pi, 0.0, 0.0), pose2=(300.0, 50.0, 230.0, pi, 0.0, 0.0),
              speed=150.0, acc=2000.0, mvtime=0.0, percent=120.0)
        _call(emu, 26, seconds=1.0)
        _call(emu, 25, speed=1.0, acc=8.0, mvtime=0.0)


def _idle_program(emu: Emulator) -> None:
    """The mostly idle program: one joint move, then rest with delayed outputs and scheduled actions
    (a warning, an input, an error and its clearing) every few seconds."""
    _ready(emu)
    _call(emu, 23, joints=(0.0, -0.3, -0.4, 0.0, 0.7, 0.0, 0.0), speed=1.0, acc=8.0, mvtime=0.0)
    for k in range(6):
        _call(emu, 142, ionum=k, on=1, delay=5.0 + 9.0 * k)
    for k in range(10):
        t = 3.0 + 5.7 * k
        emu.at(t, lambda: emu.inject_warning(12))
        emu.at(t + 0.5, lambda: _call(emu, 17))
        emu.at(t + 1.0, lambda k=k: emu.set_input("cgpio", k % 8, k % 2))


def _sensor_on_program(emu: Emulator) -> None:
    """The mostly idle program with the F/T sensor switched on (register 201) first."""
    emu.handle(201, b"\x01")
    _idle_program(emu)


def _speed(setup: Callable[[Emulator], None], exact: bool, **devices: Any) -> float:
    """Best of :data:`REPEATS`: seconds of wall time for the program's 60 s, in one ``advance``
    (``devices``: the emulator's keyword arguments for what is mounted)."""
    best = math.inf
    for _ in range(REPEATS):
        emu = Emulator(6, exact_steps=exact, **devices)
        setup(emu)
        t0 = time.perf_counter()
        emu.advance(PROGRAM_SECONDS)
        best = min(best, time.perf_counter() - t0)
    return best


def _step25(busy: bool) -> float:
    """Microseconds of one ``step(25)`` (a 100 Hz develop reader's catch-up), idle or in motion."""
    emu = Emulator(6)
    _ready(emu)
    emu.step(2)
    calls = 200
    if busy:  # a long joint move that lasts through the whole measurement
        _call(emu, 23, joints=(2.0, 0.5, -1.0, 1.0, 1.0, 2.0, 0.0), speed=0.05, acc=1.0, mvtime=0.0)
        emu.step(25)
    t0 = time.perf_counter()
    for _ in range(calls):
        emu.step(25)
    wall = time.perf_counter() - t0
    assert emu.controller.is_moving == busy
    return wall / calls * 1e6


def run() -> list[str]:
    lines = []
    for name, setup, target in (("mixed", _program, 500), ("mostly idle", _idle_program, 5000)):
        exact = _speed(setup, True)
        fast = _speed(setup, False)
        lines.append(f"stepped clock, 60 s {name} program (xArm6): {PROGRAM_SECONDS / fast:.0f}x real time "
                     f"(target >= {target}x); every period stepped (baseline, same run): "
                     f"{PROGRAM_SECONDS / exact:.0f}x; jump speed-up {exact / fast:.1f}x")
    # the F/T sensor on the first firmware of the manual's frames that drives it, switched on
    mounted = (("F/T sensor", _sensor_on_program, {"ft_sensor": True, "firmware": "1.11.100"}),
               ("Robotiq gripper", _idle_program, {"gripper": "robotiq-2f85"}),
               ("BIO gripper", _idle_program, {"gripper": "bio"}))
    for name, program, devices in mounted:
        exact = _speed(program, True, **devices)
        fast = _speed(program, False, **devices)
        lines.append(f"stepped clock, 60 s mostly idle program with the {name} mounted: "
                     f"{PROGRAM_SECONDS / fast:.0f}x real time; every period stepped (baseline, same run): "
                     f"{PROGRAM_SECONDS / exact:.0f}x; jump speed-up {exact / fast:.1f}x")
    idle = min(_step25(False) for _ in range(REPEATS))
    busy = min(_step25(True) for _ in range(REPEATS))
    lines.append(f"step(25) (one 100 Hz reader's catch-up): idle arm {idle:.1f} us, arm in motion "
                 f"{busy:.0f} us: idle costs {idle / busy:.3f} of busy; idle arm with a 100 Hz reader: "
                 f"{idle * 100 / 1e4:.3f} % of a core")
    return lines


if __name__ == "__main__":
    print("\n".join(run()))
