"""01: connect the official SDK to an emulator and move.

Starts an emulated xArm6 on free loopback ports (``xarm_emu.testing``, no root needed), points the
unchanged ``xarm-python-sdk`` at it, runs the usual start sequence (motion enable, mode 0, state 0:
manual 2.1.3 registers 11, 19 and 12), moves the joints (register 23) and a straight line
(register 21) with ``wait=True``, then reads the pose back (register 41).

Run: ``python examples/01_connect_and_move.py`` (exit 0 when every check holds).
"""

from __future__ import annotations

import sys

from xarm.wrapper import XArmAPI

from xarm_emu.testing import running_emulator, sdk_pointed_at


def check(label: str, ok: bool) -> bool:
    print(f"{'ok  ' if ok else 'FAIL'} {label}")
    return ok


def main() -> int:
    with running_emulator(model=6, speed=5.0) as st, sdk_pointed_at(st):
        arm = XArmAPI("127.0.0.1", forbid_uds=True)  # the emulator, as if it were a real box
        try:
            print("version:", arm.version)
            codes = [arm.motion_enable(True), arm.set_mode(0), arm.set_state(0)]  # registers 11, 19, 12
            ok = check("start sequence returns 0, 0, 0", codes == [0, 0, 0])
            ok &= check("state 2 (ready)", arm.get_state() == (0, 2))
            code = arm.set_servo_angle(angle=[30, 0, 0, 0, 0, 0], speed=60, wait=True)
            _, angles = arm.get_servo_angle()
            print("joints (deg):", [round(a, 3) for a in angles[:6]])
            ok &= check("joint move reached J1 = 30 deg", code == 0 and abs(angles[0] - 30) < 0.01)
            code = arm.set_position(x=300, y=100, z=200, roll=180, pitch=0, yaw=30, speed=100, wait=True)
            _, pose = arm.get_position()
            print("pose (mm, deg):", [round(p, 3) for p in pose])
            ok &= check("line reached x=300 y=100 z=200",
                        code == 0 and max(abs(pose[0] - 300), abs(pose[1] - 100), abs(pose[2] - 200)) < 0.1)
        finally:
            arm.disconnect()
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
