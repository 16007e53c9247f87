"""``set_position(wait=True)`` round trips through the unchanged official SDK: a firmware 2.x box
(the SDK waits for the move's 0xFF feedback frame, registers 253/254) against the same loop on the
manual's 1.6.0 box (the SDK polls the state), measured in the same run at speed 10."""

from __future__ import annotations

import time
from typing import Any

from xarm_emu.testing import running_emulator, sdk_pointed_at

MOVES = 20
SPEED = 10.0


def _loop(firmware: str) -> tuple[float, int]:
    """Seconds for :data:`MOVES` short ``wait=True`` lines, and how many returned 0."""
    from xarm.wrapper import XArmAPI

    with running_emulator(firmware=firmware, speed=SPEED) as st, sdk_pointed_at(st):
        arm: Any = XArmAPI("127.0.0.1", forbid_uds=True)
        try:
            arm.motion_enable(True)
            arm.set_mode(0)
            arm.set_state(0)
            arm.set_position(x=300, y=0, z=200, roll=180, pitch=0, yaw=0, speed=200, wait=True)
            ok = 0
            t0 = time.perf_counter()
            for i in range(MOVES):
                y = 20.0 if i % 2 else -20.0
                ok += arm.set_position(x=300, y=y, z=200, roll=180, pitch=0, yaw=0, speed=200, wait=True) == 0
            return time.perf_counter() - t0, ok
        finally:
            arm.disconnect()


def run() -> list[str]:
    old, ok_old = _loop("1.6.0")
    new, ok_new = _loop("2.7.103")
    return [
        f"1.6.0  : {MOVES} set_position(wait=True) in {old:.2f} s ({MOVES / old:.1f}/s, {ok_old} returned 0)",
        f"2.7.103: {MOVES} set_position(wait=True) in {new:.2f} s ({MOVES / new:.1f}/s, {ok_new} returned 0)",
        f"ratio 2.7.103 / 1.6.0 moves per second: {old / new:.2f} (speed {SPEED:g}, 40 mm lines at 200 mm/s)",
    ]
