"""The official SDK's ``robotiq_*`` functions against an emulator with a Robotiq 2F-85 on the tool
RS-485 (``running_emulator(gripper="robotiq-2f85")``, register 124 host 9, slave 9 at 115200 bps):
one test per function, object detection and faults played through the CLI's admin commands, a
gripper that is not the one attached, and the SDK repository's Robotiq example run unchanged."""

from __future__ import annotations

import contextlib
import os
import runpy
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from helpers import SDK_EXAMPLES_MISSING, run_cli, sdk_example, sdk_ready

from xarm_emu.controller.devices.robotiq import PO_CLOSED, PO_OPEN, ROBOTIQ_2F85, RobotiqGripper
from xarm_emu.server.app import ServerThread
from xarm_emu.testing import running_emulator, sdk_pointed_at

SPEED = 5.0  # controller seconds per wall second
END_EFFECTOR_HAS_FAULT = 102  # the SDK's APIState codes
MODBUS_ERR_LENG = 23


@contextlib.contextmanager
def sdk_arm_with(gripper: str, **config: Any) -> Iterator[tuple[Any, ServerThread]]:
    """An emulator with ``gripper`` attached and the official XArmAPI connected and started."""
    from xarm.wrapper import XArmAPI

    with running_emulator(6, gripper=gripper, speed=SPEED, admin=True, **config) as st, sdk_pointed_at(st):
        arm = XArmAPI("127.0.0.1", forbid_uds=True)
        try:
            sdk_ready(arm)
            yield arm, st
        finally:
            arm.disconnect()


@pytest.fixture(scope="module")
def robotiq() -> Iterator[tuple[Any, ServerThread]]:
    with sdk_arm_with("robotiq-2f85") as pair:
        yield pair


def device(st: ServerThread) -> RobotiqGripper:
    dev = st.emulator.gripper.device
    assert isinstance(dev, RobotiqGripper)
    return dev


def addr(st: ServerThread) -> list[str]:
    return ["--port", str(st.ports["command"]), "--admin-port", str(st.ports["admin"])]


def activate(arm: Any) -> None:
    assert arm.robotiq_reset()[0] == 0
    assert arm.robotiq_set_activate()[0] == 0


def test_robotiq_reset_clears_the_activation(robotiq) -> None:
    arm, st = robotiq
    code, reply = arm.robotiq_reset()
    assert code == 0 and reply == [0x09, 0x10, 0x03, 0xE8, 0x00, 0x03]  # the write reply
    assert arm.robotiq_get_status()[0] == 0
    assert (arm.robotiq_status["gACT"], arm.robotiq_status["gSTA"]) == (0, 0)


def test_robotiq_set_activate_waits_for_the_calibration(robotiq) -> None:
    arm, st = robotiq
    assert arm.robotiq_reset()[0] == 0
    t0 = st.call(lambda: st.emulator.time)
    assert arm.robotiq_set_activate()[0] == 0
    elapsed = st.call(lambda: st.emulator.time) - t0
    assert (arm.robotiq_status["gACT"], arm.robotiq_status["gSTA"]) == (1, 3)
    # the wait returned once the activation ended: not before, and within a few of the SDK's polls
    assert ROBOTIQ_2F85.activation_s <= elapsed < ROBOTIQ_2F85.activation_s + 10 * 0.05 * SPEED
    assert arm.robotiq_status["gPO"] == PO_OPEN


def test_robotiq_set_position_waits_for_arrival(robotiq) -> None:
    arm, st = robotiq
    activate(arm)
    code, _ = arm.robotiq_set_position(128, speed=0xFF, force=0x80)
    assert code == 0
    assert st.call(lambda: (device(st).position, device(st).moving)) == (128.0, False)
    s = arm.robotiq_status
    assert (s["gOBJ"], s["gPR"], s["gPO"], s["gFLT"]) == (3, 128, 128, 0)


def test_robotiq_close_and_open_reach_the_mechanical_limits(robotiq) -> None:
    arm, st = robotiq
    activate(arm)
    assert arm.robotiq_close()[0] == 0
    assert (arm.robotiq_status["gPR"], arm.robotiq_status["gPO"]) == (255, PO_CLOSED)
    assert st.call(lambda: device(st).opening_mm) == pytest.approx(0.0)
    assert arm.robotiq_open()[0] == 0
    assert (arm.robotiq_status["gPR"], arm.robotiq_status["gPO"]) == (0, PO_OPEN)
    assert st.call(lambda: device(st).opening_mm) == pytest.approx(85.0)


def test_robotiq_open_without_wait_returns_while_the_fingers_move(robotiq) -> None:
    arm, st = robotiq
    activate(arm)
    assert arm.robotiq_close(speed=0, wait=False)[0] == 0  # 20 mm/s: 4.25 s of controller time
    assert st.call(lambda: device(st).moving) is True
    assert arm.robotiq_get_status()[0] == 0 and arm.robotiq_status["gOBJ"] == 0
    assert arm.robotiq_close()[0] == 0


@pytest.mark.parametrize(("n", "length"), [(1, 5), (2, 7), (3, 9)])
def test_robotiq_get_status_reads_one_two_or_three_registers(robotiq, n: int, length: int) -> None:
    arm, st = robotiq
    activate(arm)
    code, ret = arm.robotiq_get_status(number_of_registers=n)
    assert code == 0 and ret[:3] == [0x09, 0x03, 2 * n] and len(ret) == length
    assert ret[3] == 0x31  # gACT 1, gSTA 3
    assert arm.robotiq_status["gSTA"] == 3


def test_object_detection_played_through_set_input(robotiq) -> None:
    arm, st = robotiq
    activate(arm)
    code, out = run_cli("set-input", "gripper-object", "0", "40", *addr(st))
    assert code == 0 and "40 mm" in out
    try:
        assert arm.robotiq_close(force=0xFF)[0] == 0
        s = arm.robotiq_status
        assert s["gOBJ"] == 2  # stopped by a contact while closing
        dev = device(st)
        assert s["gPO"] == round(st.call(lambda: dev.position)) < PO_CLOSED
        assert st.call(lambda: dev.opening_mm) == pytest.approx(40.0)
        assert st.call(lambda: dev.grip_force) == pytest.approx(ROBOTIQ_2F85.force_max)
        assert s["gCU"] > 0
        assert st.call(lambda: st.emulator.gripper_status())["object"] is True
    finally:
        assert run_cli("set-input", "gripper-object", "0", "0", *addr(st))[0] == 0
    arm.robotiq_get_status()
    assert arm.robotiq_status["gOBJ"] in (0, 3)  # carrying on to the request once the object is gone


def test_bad_object_width_is_refused_by_the_cli(robotiq) -> None:
    arm, st = robotiq
    code, out = run_cli("set-input", "gripper-object", "0", "90", *addr(st))
    assert code != 0 and "opens 0..85 mm" in out


def test_injected_fault_ends_the_wait_and_reset_clears_it(robotiq) -> None:
    arm, st = robotiq
    activate(arm)
    code, out = run_cli("inject", "gripper-error", "0x0E", *addr(st))
    assert code == 0 and "Overcurrent" in out
    assert arm.robotiq_open()[0] == END_EFFECTOR_HAS_FAULT
    assert arm.robotiq_status["gFLT"] == 0x0E
    activate(arm)  # the manual's cure for a major fault: reset, activate again
    assert arm.robotiq_status["gFLT"] == 0
    assert arm.robotiq_close()[0] == 0


def test_codes_of_another_gripper_are_refused(robotiq) -> None:
    arm, st = robotiq
    code, out = run_cli("inject", "gripper-error", "G25", *addr(st))
    assert code != 0 and "not an error code of the robotiq-2f85 gripper" in out
    assert st.call(lambda: device(st).error) == 0


def test_xarm_and_bio_gripper_calls_get_no_answer(robotiq) -> None:
    arm, st = robotiq
    assert arm.get_bio_gripper_status() == (MODBUS_ERR_LENG, -1)  # nothing answers as slave 8
    code, pos = arm.get_gripper_position()
    assert code != 0 and pos is None
    assert arm.robotiq_get_status()[0] == 0  # and the Robotiq still answers afterwards


def test_robotiq_calls_with_the_xarm_gripper_attached_get_no_answer() -> None:
    with sdk_arm_with("xarm") as (arm, st):
        code, ret = arm.robotiq_get_status()
        assert code == MODBUS_ERR_LENG and ret[:2] == [0x09, 0x83]
        code, _ = arm.robotiq_set_activate(wait=False)
        assert code == MODBUS_ERR_LENG


# -- the SDK repository's example programs, run unchanged ---------------------------------------------

def sdk_example_source(path: str) -> str | None:
    """An example program of the SDK's ``example`` directory (``example/<path>``), or None."""
    found = sdk_example(path)
    return found.read_text(encoding="utf-8") if found is not None else None


def run_sdk_example(path: str, st: ServerThread, tmp_path: Path, stop_after: float,
                    stop: Callable[[], object]) -> tuple[dict[str, Any], str]:
    """Run the example ``path`` unchanged in this process, pointed at ``st``: its ``../robot.conf``
    names 127.0.0.1; ``stop`` runs in the server's thread ``stop_after`` wall seconds in and every
    0.5 s after (the example programs loop until something goes wrong). Returns its globals and
    what it printed."""
    import io
    from contextlib import redirect_stdout

    source = sdk_example_source(path)
    if source is None:
        pytest.skip(SDK_EXAMPLES_MISSING)
    workdir = tmp_path / "wrapper" / "common"
    workdir.mkdir(parents=True)
    (tmp_path / "wrapper" / "robot.conf").write_text("[xArm]\nip = 127.0.0.1\n", encoding="utf-8")
    script = workdir / Path(path).name
    script.write_text(source, encoding="utf-8")
    done = threading.Event()

    def stopper() -> None:  # again and again: a reset in the program may clear a device fault
        if not done.wait(stop_after):
            while not done.is_set():
                st.call(stop)
                done.wait(0.5)

    thread = threading.Thread(target=stopper, name="example-stopper", daemon=True)
    out = io.StringIO()
    cwd = os.getcwd()
    os.chdir(workdir)
    thread.start()
    try:
        with sdk_pointed_at(st), redirect_stdout(out):
            result = runpy.run_path(str(script), run_name="__main__")
    finally:
        done.set()
        thread.join()
        os.chdir(cwd)
    return result, out.getvalue()


def test_sdk_robotiq_example_runs_unchanged(tmp_path: Path) -> None:
    with running_emulator(6, gripper="robotiq-2f85", speed=SPEED) as st:
        t0 = time.monotonic()
        env, out = run_sdk_example("wrapper/thridparty/set_robotiq_gripper.py", st, tmp_path, 6.0,
                                   lambda: st.emulator.inject_gripper_error(0x0E))
        assert time.monotonic() - t0 < 30
        assert "robotiq_set_activate, code=0" in out
        closes = out.count("robotiq_close, code=0")
        opens = out.count("robotiq_open, code=0")
        assert closes >= 2 and opens >= 2, out
        assert "robotiq fault code: 14" in out  # the loop ended on the injected overcurrent
        assert not env["arm"].connected  # the program disconnected itself


def test_status_shows_the_robotiq_it_finds_on_the_tool_bus(robotiq) -> None:
    import json

    arm, st = robotiq
    activate(arm)
    assert arm.robotiq_close()[0] == 0
    code, out = run_cli("status", "--json", "--port", str(st.ports["command"]),
                        "--report-port", str(st.ports["develop"]))
    assert code == 0, out
    assert json.loads(out)["gripper"] == {"type": "robotiq", "gSTA": 3, "gOBJ": 3, "gPO": PO_CLOSED,
                                          "gFLT": 0}
    code, out = run_cli("status", "--port", str(st.ports["command"]),
                        "--report-port", str(st.ports["develop"]))
    assert code == 0 and "robotiq" in out
