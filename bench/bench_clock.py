"""Stepped-clock speed: a 60-second program of mixed moves run in process, as a factor
of real time (the baseline: the program's own 60 s of controller time)."""

from __future__ import annotations

import math
import time

from xarm_emu.controller.emulator import Emulator
from xarm_emu.protocol.registers import REGISTERS

PROGRAM_SECONDS = 60.0


def _call(emu: Emulator, code: int, **values: object) -> None:
    emu.handle(code, REGISTERS[code].request.encode(values))


def _program(emu: Emulator) -> None:
    for code, values in ((11, {"joint": 8, "enable": 1}), (19, {"mode": 0}), (12, {"state": 0})):
        _call(emu, code, **values)
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


def run() -> list[str]:
    emu = Emulator(6)
    _program(emu)
    t0 = time.perf_counter()
    emu.advance(PROGRAM_SECONDS)
    wall = time.perf_counter() - t0
    busy = emu.controller.executor.cmdnum
    return [f"stepped clock: {PROGRAM_SECONDS:.0f} s mixed program (xArm6) in {wall:.3f} s wall: "
            f"{PROGRAM_SECONDS / wall:.0f}x real time (target >= 100x; {busy} commands still queued)"]


if __name__ == "__main__":
    print("\n".join(run()))
