"""08: test your conveyor program: every part the belt brings ends in the bin.

``conveyor_cell`` is a user's program on the unchanged official SDK for the cell of
``conveyor_cell.toml``: it switches the belt on (control-box output 0), waits for the photo-eye
(control-box input 0 reads 0 while a part cuts the beam), switches the belt off, picks the part with
the xArm gripper, puts it into the next free place in the bin and counts it, then starts the belt
again. A part that does not arrive within its timeout ends the shift. The scene's feeder puts a new
40 mm cube on the belt each time output 0 switches on, three in all, so the fourth wait times out.

The emulator runs on the stepped clock and the program's waits (the SDK's polls, its own timeout)
count controller time (:func:`xarm_emu.testing.sdk_on_stepped_clock`): the whole shift runs as fast as
the emulator steps, and two runs end with every part in the same place to the last bit.

Run: ``pytest examples/08_conveyor_cell.py``.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("mujoco")

from xarm.wrapper import XArmAPI  # noqa: E402

from xarm_emu.client.admin import AdminClient  # noqa: E402
from xarm_emu.testing import running_emulator, sdk_on_stepped_clock, sdk_pointed_at  # noqa: E402

SCENE = Path(__file__).parent / "conveyor_cell.toml"
BELT, EYE = 0, 0  # control-box output and input numbers
#: Where a part stops: its leading face just past the beam at x = 300, on the belt (top z = -60).
PICK = (318.0, 300.0)
GRASP_Z = -60.0 + 15.0  # the fingertips 15 mm above the belt
#: The bin's floor is at z = -90; its inside spans x 200..400, y -330..-170.
BIN_FLOOR = -90.0
SLOTS = [(250.0, -250.0), (300.0, -250.0), (350.0, -250.0)]
PLACE_Z = BIN_FLOOR + 15.0 + 1.0
TRAVEL_Z = 40.0
PART_TIMEOUT = 3.0  # s: a part takes about 1 s from the feeder to the eye


class CellError(RuntimeError):
    """An SDK call failed: its name and code."""


def conveyor_cell(arm: Any) -> int:
    """The user program: the number of parts put in the bin (CellError if a call fails)."""
    move = {"roll": 180, "pitch": 0, "yaw": 0, "speed": 300, "mvacc": 3000, "wait": True}

    def do(name: str, code: int) -> None:
        if code:
            raise CellError(f"{name} failed with code {code}")

    def wait_for_part(timeout: float) -> bool:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            code, level = arm.get_cgpio_digital(EYE)
            do("get_cgpio_digital", code)
            if level == 0:
                return True
            time.sleep(0.02)
        return False

    do("set_tcp_offset", arm.set_tcp_offset([0, 0, 172, 0, 0, 0]))  # the xArm gripper's fingertips
    do("motion_enable", arm.motion_enable(True))
    do("set_mode", arm.set_mode(0))
    do("set_state", arm.set_state(0))
    do("set_gripper_enable", arm.set_gripper_enable(True))
    do("set_gripper_speed", arm.set_gripper_speed(5000))
    do("open", arm.set_gripper_position(850, wait=True))
    do("above the belt", arm.set_position(*PICK, TRAVEL_Z, **move))
    count = 0
    while count < len(SLOTS):
        do("belt on", arm.set_cgpio_digital(BELT, 1))
        arrived = wait_for_part(PART_TIMEOUT)
        do("belt off", arm.set_cgpio_digital(BELT, 0))
        if not arrived:
            break
        do("down to the part", arm.set_position(*PICK, GRASP_Z, **move))
        do("close", arm.set_gripper_position(0, wait=True))
        do("lift", arm.set_position(*PICK, TRAVEL_Z, **move))
        x, y = SLOTS[count]
        do("over the bin", arm.set_position(x, y, TRAVEL_Z, **move))
        do("into the bin", arm.set_position(x, y, PLACE_Z, **move))
        do("open", arm.set_gripper_position(850, wait=True))
        do("out of the bin", arm.set_position(x, y, TRAVEL_Z, **move))
        do("back over the belt", arm.set_position(*PICK, TRAVEL_Z, **move))
        count += 1
    return count


def run_shift() -> dict[str, Any]:
    """The program on a stepped-clock emulator of the cell: what it counted, every object where it
    ended, the cell's state (``xarm-emu scene --json``), controller and wall seconds."""
    with running_emulator(6, scene=SCENE, stepped=True, admin=True) as st, sdk_pointed_at(st):
        arm = XArmAPI("127.0.0.1")
        try:
            wall = time.perf_counter()
            with sdk_on_stepped_clock(st, arm):
                count = conveyor_cell(arm)
            wall = time.perf_counter() - wall
        finally:
            arm.disconnect()
        with AdminClient("127.0.0.1", st.ports["admin"]) as admin:  # what `xarm-emu scene --json` shows
            cell = json.loads(admin.request("scene-objects"))
    return {"count": count, "cell": cell, "seconds": cell["time"], "wall": wall}


@pytest.fixture(scope="module")
def shifts() -> list[dict[str, Any]]:
    return [run_shift(), run_shift()]


def test_every_part_ends_in_the_bin(shifts: list[dict[str, Any]]) -> None:
    shift = shifts[0]
    assert shift["count"] == 3
    parts = shift["cell"]["objects"]
    assert [p["name"] for p in parts] == ["part-1", "part-2", "part-3"]
    for p, (x, y) in zip(parts, SLOTS, strict=True):
        px, py, pz = p["position"]
        assert 200 + 20 < px < 400 - 20 and -330 + 20 < py < -170 - 20  # inside the walls
        assert abs(px - x) < 5 and abs(py - y) < 5  # in its place
        assert pz == pytest.approx(BIN_FLOOR + 20.0, abs=1.0)  # resting on the floor
        assert not p["held"]


def test_the_cell_reports_every_element(shifts: list[dict[str, Any]]) -> None:
    cell = shifts[0]["cell"]
    assert cell["conveyors"] == [{"name": "belt", "running": False, "speed": 200.0, "output": "CO0"}]
    assert cell["sensors"] == [{"name": "eye", "input": "CI0", "interrupted": False, "level": 1}]
    assert cell["feeders"] == [{"name": "part", "count": 3, "of": 3}]


def test_two_shifts_end_the_same_to_the_last_bit(shifts: list[dict[str, Any]]) -> None:
    first, second = shifts
    assert first["seconds"] == second["seconds"]
    assert first["cell"]["objects"] == second["cell"]["objects"]


def test_the_shift_runs_faster_than_real_time(shifts: list[dict[str, Any]]) -> None:
    """About 36 s of arm time; 7 to 10 times real time on a busy 2-core machine (the SDK's round
    trips, its report threads and the engine share it)."""
    best = max(s["seconds"] / s["wall"] for s in shifts)
    assert best >= 3.0, f"{best:.1f} times real time"
