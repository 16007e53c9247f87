"""03: a collision in the middle of a move, seen by the SDK, and the recovery a real program does.

While the SDK waits on a joint move, an obstacle pushes on joint 2 with 40 N m as joint 1 passes
30 deg (a probe scheduled with ``Emulator.at`` on every control period, so it happens at the same
point of the move at any speed and however late the command arrives). At collision sensitivity 3
(register 37) that is detected as error C31 (manual 3.2.1): the arm stops within one control
period, state 4; the SDK's wait returns non-zero (1 for the error or -9 for the stop, whichever its
report shows first) and ``get_err_warn_code`` (register 15) reads 31. The program then recovers as
on a real box: ``clean_error`` (register 16), ``motion_enable`` (11), ``set_state(0)`` (12), waits
for a report frame that shows the box ready, and finishes the move.

Why the wait: the SDK keeps the error code its report thread last read, and a wait on a move gives
up as soon as that is non-zero. The frame the box sent just before ``clean_error`` was answered
still shows C31; on a busy computer the report thread may read it only after the recovery, and
the next move would then stop at once with "xarm has error, error=31". Frames arrive in order, so
once the SDK has read one that shows no error and state 2 (sent after ``set_state(0)``), none from
before the recovery is left.

Run: ``python examples/03_fault_injection_and_recovery.py`` (exit 0 when every check holds).
"""

from __future__ import annotations

import math
import sys
import threading
from collections.abc import Callable
from typing import Any

from xarm.wrapper import XArmAPI

from xarm_emu.controller.emulator import Emulator
from xarm_emu.testing import running_emulator, sdk_pointed_at

TARGET = [90, 0, 0, 0, 0, 0]
OBSTACLE_J1 = 30.0  # deg
PERIOD = 0.004  # one control period, s
REPORT_WAIT = 5.0  # s; the SDK's default (rich) report comes at 5 Hz


def when_j1_passes(emu: Emulator, deg: float, action: Callable[[], object]) -> None:
    """Run ``action`` on the first control period where joint 1 is at or beyond ``deg``."""
    def probe() -> None:
        if emu.joints[0] >= math.radians(deg):
            action()
        else:
            emu.at(emu.time + PERIOD, probe)

    emu.at(emu.time + PERIOD, probe)


def report_shows_ready(arm: XArmAPI, timeout: float = REPORT_WAIT) -> bool:
    """Wait until the SDK's report thread has read a frame that shows no error and state 2 (ready);
    ``False`` when none came within ``timeout`` seconds."""
    ready = threading.Event()

    def on_report(report: dict[str, Any]) -> None:
        if report["error_code"] == 0 and report["state"] == 2:
            ready.set()

    arm.register_report_callback(on_report, report_cartesian=False, report_joints=False,
                                 report_warn_code=False, report_mtable=False, report_mtbrake=False,
                                 report_cmd_num=False)
    try:
        return ready.wait(timeout)
    finally:
        arm.release_report_callback(on_report)


def check(label: str, ok: bool) -> bool:
    print(f"{'ok  ' if ok else 'FAIL'} {label}")
    return ok


def main() -> int:
    with running_emulator(model=6, speed=2.0) as st, sdk_pointed_at(st):
        emu = st.emulator
        arm = XArmAPI("127.0.0.1", forbid_uds=True)
        try:
            arm.motion_enable(True)
            arm.set_mode(0)
            arm.set_state(0)
            arm.set_collision_sensitivity(3)
            st.call(lambda: when_j1_passes(emu, OBSTACLE_J1, lambda: emu.inject_collision(2, 40.0)))
            code = arm.set_servo_angle(angle=TARGET, speed=30, wait=True)
            _, angles = arm.get_servo_angle()
            _, (error, warning) = arm.get_err_warn_code()
            print(f"move returned {code}: error C{error}, warning {warning}, state {arm.get_state()[1]}, "
                  f"J1 stopped at {angles[0]:.1f} deg")
            ok = check("the SDK reads error C31 (collision)", code != 0 and error == 31)
            ok &= check("the arm stopped at the obstacle, state 4", arm.get_state() == (0, 4)
                        and OBSTACLE_J1 <= angles[0] < OBSTACLE_J1 + 1)
            print("recovering: clean_error, motion_enable, set_state(0)")
            ok &= check("error cleared", arm.clean_error() == 0 and arm.get_err_warn_code() == (0, [0, 0]))
            ok &= check("ready again (state 2)", arm.motion_enable(True) == 0 and arm.set_state(0) == 0
                        and arm.get_state() == (0, 2))
            ok &= check("a report shows the box ready", report_shows_ready(arm))
            code = arm.set_servo_angle(angle=TARGET, speed=30, wait=True)
            _, angles = arm.get_servo_angle()
            ok &= check(f"move finished after recovery (J1 = {angles[0]:.1f} deg)",
                        code == 0 and abs(angles[0] - TARGET[0]) < 0.01)
        finally:
            arm.disconnect()
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
