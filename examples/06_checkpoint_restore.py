"""06: checkpoint and restore: rewind a scenario to just before a fault and try another recovery.

No real control box can do this. ``Emulator.checkpoint()`` copies the whole emulator (controller,
motion buffer and plan, settings, IO, gripper, thermal model, clock); ``restore(cp)`` puts it back
exactly, as often as you like. The program runs a move, checkpoints mid-move, lets a collision
stop the arm (error C31, manual 3.2.1), then rewinds to the checkpoint and finishes the move
instead. Reports after the restore are the same bytes as the first time round.
(``xarm-emu checkpoint save NAME`` / ``restore NAME`` do the same over the admin channel.)

Run: ``python examples/06_checkpoint_restore.py`` (exit 0 when every check holds).
"""

from __future__ import annotations

import sys
from typing import Any

from xarm_emu.controller.emulator import Emulator
from xarm_emu.protocol.registers import REGISTERS
from xarm_emu.protocol.reports import ENCODERS

TARGET = (1.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)  # joints, rad


def call(emu: Emulator, code: int, **values: Any) -> dict[str, Any]:
    """One command through the register table (manual 2.1.3); returns the decoded reply."""
    reg = REGISTERS[code]
    _, reply = emu.handle(code, reg.request.encode(values))
    return reg.reply.decode(reply) if reg.reply.fields else {}


def reports(emu: Emulator) -> list[bytes]:
    """The normal, rich and develop report frames of this instant (manual 2.1.6)."""
    snap = emu.snapshot()
    return [encode(snap) for encode in ENCODERS.values()]


def check(label: str, ok: bool) -> bool:
    print(f"{'ok  ' if ok else 'FAIL'} {label}")
    return ok


def main() -> int:
    emu = Emulator(6)
    call(emu, 11, joint=8, enable=1)
    call(emu, 19, mode=0)
    call(emu, 12, state=0)
    call(emu, 23, joints=TARGET, speed=1.0, acc=10.0, mvtime=0.0)
    emu.advance(0.5)
    cp = emu.checkpoint()
    print(f"checkpoint at t = {emu.time:.3f} s, J1 = {emu.joints[0]:.3f} rad")
    emu.advance(0.2)
    after = reports(emu)

    emu.inject_collision(joint=2, torque=40.0)  # detected at the default sensitivity
    err = call(emu, 15)["error"]
    ok = check(f"collision stops the arm with C{err}", err == 31 and call(emu, 13)["state"] == 4)

    emu.restore(cp)
    print(f"restored to t = {emu.time:.3f} s")
    ok &= check("error gone and the move still under way", call(emu, 15)["error"] == 0
                and call(emu, 13)["state"] == 1)
    emu.advance(0.2)
    ok &= check("reports 0.2 s later are the same bytes as the first time", reports(emu) == after)
    emu.advance(3.0)
    ok &= check(f"the move finished instead: J1 = {emu.joints[0]:.3f} rad",
                abs(emu.joints[0] - TARGET[0]) < 1e-6 and call(emu, 13)["state"] == 2)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
