"""03: a collision in the middle of a move, seen by the SDK, and the recovery a real program does.

While the SDK waits on a joint move, the emulator pushes on joint 2 with 40 N m at controller time
t0 + 0.5 s (scheduled with ``Emulator.at``, so it lands on the same control period at any speed).
At collision sensitivity 3 (register 37) that is detected as error C31 (manual 3.2.1): the arm
stops within one control period, state 4, the SDK's wait returns and ``get_err_warn_code`` (register
15) reads 31. The program then
recovers as on a real box: ``clean_error`` (register 16), ``motion_enable`` (11), ``set_state(0)``
(12), and finishes the move.

Run: ``python examples/03_fault_injection_and_recovery.py`` (exit 0 when every check holds).
"""

from __future__ import annotations

import sys

from xarm.wrapper import XArmAPI

from xarm_emu.testing import running_emulator, sdk_pointed_at

TARGET = [90, 0, 0, 0, 0, 0]


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
            st.call(lambda: emu.at(emu.time + 0.5, lambda: emu.inject_collision(2, 40.0)))
            code = arm.set_servo_angle(angle=TARGET, speed=30, wait=True)
            _, angles = arm.get_servo_angle()
            _, (error, warning) = arm.get_err_warn_code()
            print(f"move returned {code}: error C{error}, warning {warning}, state {arm.get_state()[1]}, "
                  f"J1 stopped at {angles[0]:.1f} deg")
            ok = check("the SDK reads error C31 (collision)", error == 31)
            ok &= check("the arm stopped short of the target, state 4", arm.get_state() == (0, 4)
                        and 10 < angles[0] < 80)
            print("recovering: clean_error, motion_enable, set_state(0)")
            ok &= check("error cleared", arm.clean_error() == 0 and arm.get_err_warn_code() == (0, [0, 0]))
            ok &= check("ready again (state 2)", arm.motion_enable(True) == 0 and arm.set_state(0) == 0
                        and arm.get_state() == (0, 2))
            code = arm.set_servo_angle(angle=TARGET, speed=30, wait=True)
            _, angles = arm.get_servo_angle()
            ok &= check(f"move finished after recovery (J1 = {angles[0]:.1f} deg)",
                        code == 0 and abs(angles[0] - TARGET[0]) < 0.01)
        finally:
            arm.disconnect()
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
