"""04: the in-process emulator on a stepped clock: minutes of arm time in a fraction of a second.

No sockets and no threads: ``Emulator.handle(code, params)`` takes a register's parameter bytes and
returns the reply state byte and reply bytes (manual 2.1.2), encoded and decoded with the register
table's layouts (``xarm_emu.protocol.registers``). The program queues a long pick-and-place cycle
(joint moves, register 23; lines, 21; dwells, 26) and ``emu.advance(seconds)`` runs controller time
as fast as the CPU goes. Run twice, it ends on the same control period with the same joints.

Run: ``python examples/04_stepped_time.py`` (exit 0 when every check holds).
"""

from __future__ import annotations

import math
import sys
import time
from typing import Any

from xarm_emu.controller.emulator import Emulator
from xarm_emu.protocol.frame import STATE_ERROR, STATE_WARNING
from xarm_emu.protocol.registers import REGISTERS

CYCLES = 25
HOME = (0.0, -0.3, -0.6, 0.0, 0.9, 0.0, 0.0)  # joints, rad (register 23 always carries 7)


def call(emu: Emulator, code: int, **values: Any) -> dict[str, Any]:
    """One command through the register table; refuses a reply with the error or warning bit."""
    reg = REGISTERS[code]
    state, reply = emu.handle(code, reg.request.encode(values))
    if state & (STATE_ERROR | STATE_WARNING):
        raise RuntimeError(f"register {code} ({reg.name}) answered state 0x{state:02x}")
    return reg.reply.decode(reply) if reg.reply.fields else {}


def run_program() -> tuple[float, tuple[float, ...], float]:
    """The whole program; returns (controller seconds, final joints, wall seconds)."""
    wall = time.perf_counter()
    emu = Emulator(6)
    call(emu, 11, joint=8, enable=1)  # motion enable, all joints
    call(emu, 19, mode=0)             # position mode
    call(emu, 12, state=0)            # ready
    move = {"speed": 1.0, "acc": 10.0, "mvtime": 0.0}
    line = {"speed": 200.0, "acc": 2000.0, "mvtime": 0.0}
    for i in range(CYCLES):
        y = 150.0 if i % 2 else -150.0
        call(emu, 23, joints=HOME, **move)
        call(emu, 21, pose=(300.0, y, 250.0, math.pi, 0.0, 0.0), **line)
        call(emu, 21, pose=(300.0, y, 120.0, math.pi, 0.0, 0.0), **line)
        call(emu, 26, seconds=0.5)    # the gripper closes
        call(emu, 21, pose=(300.0, y, 250.0, math.pi, 0.0, 0.0), **line)
    print(f"queued {call(emu, 14)['cmdnum']} commands")
    while call(emu, 13)["state"] == 1 or call(emu, 14)["cmdnum"]:  # state 1: moving
        emu.advance(0.1)
    error = call(emu, 15)
    if error["error"]:
        raise RuntimeError(f"the program ended with error C{error['error']}")
    joints = call(emu, 42)["joints"]
    return emu.time, tuple(joints), time.perf_counter() - wall


def check(label: str, ok: bool) -> bool:
    print(f"{'ok  ' if ok else 'FAIL'} {label}")
    return ok


def main() -> int:
    first = run_program()
    second = run_program()
    controller, joints, wall = first
    print(f"controller time {controller:.3f} s, wall time {wall:.2f} s: {controller / wall:.0f}x real time")
    print("final joints (rad):", [round(q, 4) for q in joints[:6]])
    ok = check("faster than real time", controller > 10 * wall)
    ok &= check("deterministic: same end time and joints on a second run", first[:2] == second[:2])
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
