"""The report frames on the stepped clock (``testing.sdk_on_stepped_clock``): what the SDK takes from
reports (``arm.angles``, ``arm.position``, ``arm.state``) is, after each sleep, the state of the last
frame due by then, and two runs see the same values to the last bit."""

from __future__ import annotations

import time
from typing import Any

from xarm.wrapper import XArmAPI

from xarm_emu.controller.core.interface import PERIOD
from xarm_emu.testing import running_emulator, sdk_on_stepped_clock, sdk_pointed_at

FRAME_PERIODS = round(0.2 / PERIOD)  # the rich report's 5 Hz in control periods


def watch_a_move(report_type: str = "rich") -> list[dict[str, Any]]:
    """A program that starts a joint move and reads the SDK's report properties and the box's
    replies every 0.2 s, on report deadlines of the stepped clock."""
    seen: list[dict[str, Any]] = []
    with running_emulator(6, stepped=True, admin=True) as st, sdk_pointed_at(st):
        arm = XArmAPI("127.0.0.1", report_type=report_type)
        try:
            with sdk_on_stepped_clock(st, arm):
                assert arm.motion_enable(True) == 0 and arm.set_mode(0) == 0 and arm.set_state(0) == 0
                time.sleep(0.5)
                assert arm.set_servo_angle(angle=[40, -20, -30, 10, 30, 20], speed=30, wait=False) == 0
                steps = st.emulator.controller.data.steps
                time.sleep((FRAME_PERIODS - steps % FRAME_PERIODS) * PERIOD)  # onto a frame's deadline
                for _ in range(12):
                    time.sleep(0.2)
                    code_j, joints = arm.get_servo_angle()
                    code_p, pose = arm.get_position()
                    assert code_j == code_p == 0
                    seen.append({"angles": list(arm.angles), "position": list(arm.position),
                                 "state": arm.state, "joints": joints, "pose": pose,
                                 "steps": st.emulator.controller.data.steps})
        finally:
            arm.disconnect()
    return seen


def test_report_properties_follow_the_move_on_the_stepped_clock() -> None:
    first = watch_a_move()
    assert all(s["steps"] % FRAME_PERIODS == 0 for s in first)  # every read on a frame's deadline
    for s in first:  # the frame of this instant: the replies read now, to the frame's float32
        assert all(abs(a - b) < 1e-3 for a, b in zip(s["angles"], s["joints"], strict=False)), s
        assert all(abs(a - b) < 1e-3 for a, b in zip(s["position"], s["pose"], strict=False)), s
    moving = [s for s in first if s["state"] == 1]
    assert len(moving) >= 3 and first[-1]["state"] != 1  # seen moving, then done
    angles = [s["angles"][0] for s in moving]
    assert angles == sorted(angles) and angles[0] < angles[-1]  # fresh frames, not one stale state
    assert first == watch_a_move()  # two runs: the same to the last bit


def test_the_normal_report_flows_too() -> None:
    seen = watch_a_move("normal")
    assert any(s["state"] == 1 for s in seen)
    for s in seen:
        assert all(abs(a - b) < 1e-3 for a, b in zip(s["angles"], s["joints"], strict=False)), s
