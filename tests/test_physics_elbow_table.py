"""The elbow driven down into a table, through the unchanged SDK on the stepped clock: a table given
as a ``[[plane]]`` or as a table-top ``[[box]]`` (what a user writes for a table), or a belt, stops
the arm with C31 at collision sensitivity 3 (``set_collision_sensitivity``), and at 0 the arm,
position-driven, goes on to its target. The xArm 6's forearm is folded up (J3 -3.5 rad) so that the
upper arm is the lowest part of the arm; J2 at 0.16 rad/s then turns its lowest point (about 290 mm
from the shoulder) down at some 45 mm/s."""

from __future__ import annotations

import math
import time
from typing import Any

import pytest

pytest.importorskip("mujoco")

from xarm.wrapper import XArmAPI  # noqa: E402

from xarm_emu.testing import running_emulator, sdk_on_stepped_clock, sdk_pointed_at  # noqa: E402

TOP = 60.0  # mm: the table's top, above the arm's mounting face (the arm on a lower stand)
#: A cube far off: the engine runs for a scene with objects (docs/physics.md).
FAR_CUBE = {"name": "cube", "shape": "box", "size": [40, 40, 40], "mass": 0.1,
            "position": [-300, 300, TOP + 20]}
TABLES: dict[str, dict[str, Any]] = {
    "plane": {"plane": [{"name": "table", "point": [0, 0, TOP], "normal": [0, 0, 1], "stiffness": 10.0}]},
    "table-top box": {"box": [{"name": "table", "min": [150, -600, 0], "max": [900, 600, TOP],
                               "stiffness": 10.0}]},
    "belt": {"conveyor": [{"name": "belt", "min": [150, -600, 0], "max": [900, 600, TOP],
                           "direction": [1, 0, 0], "speed": 0}]},  # the links touch a belt as any fixture
}
ABOVE = [0.0, 1.9, -3.5, 0.0, 0.0, 0.0]  # rad: the upper arm's underside some 15 mm above the top
INTO = [0.0, 2.05, -3.5, 0.0, 0.0, 0.0]  # rad: about 25 mm into it


def drive_the_elbow_down(tables: dict[str, Any], sensitivity: int) -> tuple[int, int, float]:
    """The SDK's error code after the elbow's move, its error code before it, and J2 (rad) at the end."""
    with running_emulator(6, scene={**tables, "object": [FAR_CUBE]}, stepped=True, admin=True) as st, \
            sdk_pointed_at(st):
        arm = XArmAPI("127.0.0.1")
        try:
            with sdk_on_stepped_clock(st, arm):
                assert arm.motion_enable(True) == 0 and arm.set_mode(0) == 0 and arm.set_state(0) == 0
                assert arm.set_collision_sensitivity(sensitivity) == 0
                for angles in ([0.0, 0.0, -3.5, 0.0, 0.0, 0.0], ABOVE):  # forearm up, then down
                    assert arm.set_servo_angle(angle=angles, speed=1.0, is_radian=True, wait=True) == 0
                before = arm.error_code
                arm.set_servo_angle(angle=INTO, speed=0.16, mvacc=10.0, is_radian=True, wait=True)
                time.sleep(0.2)
                _, angles = arm.get_servo_angle(is_radian=True)
                return arm.error_code, before, float(angles[1])
        finally:
            arm.disconnect()


@pytest.mark.parametrize("table", sorted(TABLES))
@pytest.mark.parametrize("sensitivity", [3, 0])
def test_the_elbow_driven_into_the_table_raises_c31_at_3_not_0(table: str, sensitivity: int) -> None:
    error, before, j2 = drive_the_elbow_down(TABLES[table], sensitivity)
    assert before == 0  # clear of the table above it
    if sensitivity:
        assert error == 31
        assert ABOVE[1] < j2 < INTO[1] - 0.05  # stopped in the table, short of the target
    else:
        assert error == 0
        assert math.isclose(j2, INTO[1], abs_tol=1e-4)  # no contact pushes it off its path
