"""02: test your own SDK program with pytest, against an emulator instead of a real arm.

``pick_and_place`` is the kind of program a user writes: wait for the part sensor on control box
input DI3 (the box's inputs read 1 while open, so a sensor that sees a part pulls it to 0), open
the xArm gripper, go down, close on the part, carry it over and set output DO2 to tell the next
station (manual 2.1.3 registers 21/23, 2.1.4 registers 124 gripper, 131/134 GPIO). The tests run
it unchanged through the pytest plugin that comes with xarm-emu (docs/pytest-plugin.md): the
``xarm_sdk`` fixture is the official SDK connected to an emulator on free ports, ``xarm_emulator``
that emulator, on whose side the tests play the sensor.

Run: ``pytest examples/02_test_a_user_program.py``; over two firmware profiles:
``pytest examples/02_test_a_user_program.py --xarm-firmware 1.6.0 --xarm-firmware 2.7.103``.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import pytest

PICK = (300.0, -100.0, 150.0)
PLACE = (300.0, 100.0, 150.0)


def pick_and_place(arm: Any, timeout: float = 5.0) -> int:
    """The user program: 0 when the part was placed, else the first failing SDK code (or -1 on no part)."""
    deadline = time.monotonic() + timeout
    while arm.get_cgpio_digital(3) != (0, 0):  # wait for the part sensor to pull DI3 low
        if time.monotonic() > deadline:
            return -1
        time.sleep(0.05)
    steps: list[Callable[[], int]] = [
        lambda: arm.set_gripper_enable(True),
        lambda: arm.set_gripper_position(850, wait=True),
        lambda: arm.set_position(*PICK, 180, 0, 0, speed=200, wait=True),
        lambda: arm.set_position(z=-50, relative=True, speed=100, wait=True),
        lambda: arm.set_gripper_position(200, wait=True),
        lambda: arm.set_position(*PLACE, 180, 0, 0, speed=200, wait=True),
        lambda: arm.set_cgpio_digital(2, 1),
    ]
    for step in steps:
        code = step()
        if code != 0:
            return int(code)
    return 0


def do_word(arm: Any) -> int:
    """The control box's configurable digital outputs, one bit each (register 139; the SDK's
    ``get_cgpio_state`` lists the word as ``states[5]``)."""
    code, states = arm.get_cgpio_state()
    assert code == 0
    return int(states[5])


#: The box of every test here: an xArm6 at ten times real time.
pytestmark = pytest.mark.xarm(model=6, speed=10.0)


@pytest.fixture
def arm(xarm_sdk: Any) -> Any:
    """The SDK connected to the emulated box, the arm enabled and ready (state 2) as the program
    expects to find it."""
    assert xarm_sdk.motion_enable(True) == 0
    assert xarm_sdk.set_mode(0) == 0
    assert xarm_sdk.set_state(0) == 0
    return xarm_sdk


def test_part_is_placed_and_the_next_station_is_told(arm: Any, xarm_emulator: Any) -> None:
    xarm_emulator.call(lambda: xarm_emulator.emulator.set_input("cgpio", 3, 0))  # the part arrives
    assert pick_and_place(arm) == 0
    code, pose = arm.get_position()
    assert code == 0 and pose[:3] == pytest.approx(PLACE, abs=0.1)
    assert arm.get_gripper_position() == (0, pytest.approx(200, abs=1))
    assert do_word(arm) & (1 << 2)  # DO2 on


def test_no_part_means_no_motion(arm: Any) -> None:
    start = arm.get_position()[1]
    assert pick_and_place(arm, timeout=0.3) == -1
    assert arm.get_position()[1] == pytest.approx(start)
    assert not do_word(arm) & (1 << 2)
