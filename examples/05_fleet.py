"""05: a fleet: three arms at once, each driven by its own SDK instance on its own thread.

The SDK's ports are fixed (502 and the report ports), so each emulated arm gets a loopback address
of its own (Linux routes all of 127.0.0.0/8) with the same port numbers, as ``xarm-emu serve
--fleet`` serves the arms of a fleet file with distinct ``host`` keys. Here an xArm5, xArm6 and
xArm7 start on 127.0.0.1-3; one ``XArmAPI`` per address moves its arm at the same time as the
others, and each arm ends where its own program sent it.

Run: ``python examples/05_fleet.py`` (exit 0 when every check holds).
"""

from __future__ import annotations

import contextlib
import sys
import threading

from xarm.wrapper import XArmAPI

from xarm_emu.testing import running_emulator, sdk_pointed_at

FLEET = {"127.0.0.1": 5, "127.0.0.2": 6, "127.0.0.3": 7}  # host: model
#: running_emulator's keyword of each port its server publishes.
PORT_KEYS = {"command": "port", "normal": "normal_port", "rich": "rich_port", "develop": "develop_port"}


def program(host: str, j1: float, results: dict[str, tuple[str, list[float]]]) -> None:
    """One arm's program: start sequence, J1 to ``j1`` deg, back the version and joints."""
    arm = XArmAPI(host, forbid_uds=True)
    try:
        arm.motion_enable(True)
        arm.set_mode(0)
        arm.set_state(0)
        code = arm.set_servo_angle(servo_id=1, angle=j1, speed=60, wait=True)
        results[host] = (arm.version if code == 0 else f"move failed: {code}", arm.get_servo_angle()[1])
    finally:
        arm.disconnect()


def main() -> int:
    with contextlib.ExitStack() as stack:
        same: dict[str, int] = {}  # the first arm picks free ports; the others take the same numbers
        for host, model in FLEET.items():
            st = stack.enter_context(running_emulator(model=model, speed=5.0, host=host, **same))
            same = same or {PORT_KEYS[kind]: port for kind, port in st.ports.items() if kind in PORT_KEYS}
        stack.enter_context(sdk_pointed_at(st))  # one set of port numbers for every arm
        results: dict[str, tuple[str, list[float]]] = {}
        threads = [threading.Thread(target=program, args=(host, 20.0 * (i + 1), results))
                   for i, host in enumerate(FLEET)]
        for t in threads:
            t.start()
        for t in threads:
            t.join(30)
    ok = True
    for i, (host, model) in enumerate(FLEET.items()):
        version, joints = results.get(host, ("no answer", []))
        print(f"{host}: {version}, joints {[round(q, 2) for q in joints[:model]]}")
        good = version.startswith(f"{model},") and bool(joints) and abs(joints[0] - 20.0 * (i + 1)) < 0.01
        print(f"{'ok  ' if good else 'FAIL'} xArm{model} on {host} moved J1 to {20 * (i + 1)} deg")
        ok &= good
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
