"""07: test that your pick-and-place program puts the part where it belongs.

``pick_and_place`` is a user's program on the unchanged official SDK: open the xArm gripper, go above
the part, down, close on it, lift, carry it over, set it down, open and retreat. The emulator runs the
scene of ``pick_and_place.toml``: a table and a 40 mm cube of 0.1 kg, in the physics engine (an
optional extra: ``pip install 'xarm-emu[physics]'``). The fingers stop on the cube, the cube rides in
the grip by friction and stays where it is let go; the test reads where it ends.

Run: ``pytest examples/07_pick_and_place.py``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("mujoco")

from xarm.wrapper import XArmAPI  # noqa: E402

from xarm_emu.testing import running_emulator, sdk_pointed_at  # noqa: E402

SCENE = Path(__file__).parent / "pick_and_place.toml"
PICK = (300.0, -100.0)
PLACE = (300.0, 100.0)
TABLE_Z = -100.0  # mm: the table top of the scene, 100 mm below the arm's mounting face
GRASP_Z = TABLE_Z + 15.0  # the fingertips (the TCP) 15 mm above the table
TRAVEL_Z = TABLE_Z + 115.0


def pick_and_place(arm: Any) -> int:
    """The user program: 0 when done, else the first failing SDK code."""
    down = {"roll": 180, "pitch": 0, "yaw": 0, "speed": 150, "mvacc": 2000, "wait": True}
    steps = [
        lambda: arm.set_tcp_offset([0, 0, 172, 0, 0, 0]),  # the xArm gripper's fingertips
        lambda: arm.motion_enable(True),
        lambda: arm.set_mode(0),
        lambda: arm.set_state(0),
        lambda: arm.set_gripper_enable(True),
        lambda: arm.set_gripper_speed(3000),
        lambda: arm.set_gripper_position(850, wait=True),
        lambda: arm.set_position(*PICK, TRAVEL_Z, **down),
        lambda: arm.set_position(*PICK, GRASP_Z, **down),
        lambda: arm.set_gripper_position(0, wait=True),
        lambda: arm.set_position(*PICK, TRAVEL_Z, **down),
        lambda: arm.set_position(*PLACE, TRAVEL_Z, **down),
        lambda: arm.set_position(*PLACE, GRASP_Z + 1, **down),
        lambda: arm.set_gripper_position(850, wait=True),
        lambda: arm.set_position(*PLACE, TRAVEL_Z, **down),
    ]
    for step in steps:
        code = step()
        if code:
            return int(code)
    return 0


def run_program() -> dict[str, Any]:
    """Run the user program against an emulator of the scene; the cube's pose at the end."""
    with running_emulator(6, scene=SCENE, speed=4.0) as st, sdk_pointed_at(st):
        arm = XArmAPI("127.0.0.1")
        try:
            assert pick_and_place(arm) == 0
        finally:
            arm.disconnect()
        (cube,) = st.call(st.emulator.scene_objects)
    return dict(cube)


def test_the_cube_ends_where_the_program_put_it() -> None:
    cube = run_program()
    assert cube["position"][:2] == pytest.approx(PLACE, abs=3.0)  # where the program set it down
    assert cube["position"][2] == pytest.approx(TABLE_Z + 20.0, abs=1.0)  # resting on the table
    assert abs(cube["rpy"][0]) < 2.0 and abs(cube["rpy"][1]) < 2.0  # upright
    assert not cube["held"]


def test_a_grip_on_nothing_leaves_the_cube_on_the_table() -> None:
    """The program's grasp height is wrong (the fingers close 100 mm above the cube)."""
    global GRASP_Z
    saved, GRASP_Z = GRASP_Z, TABLE_Z + 100.0
    try:
        cube = run_program()
    finally:
        GRASP_Z = saved
    assert cube["position"][:2] == pytest.approx(PICK, abs=0.5)  # never moved
