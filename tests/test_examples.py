"""The numbered programs of ``examples/``: each runs as a newcomer would run it, in a child process,
exits 0 and prints the lines that show its checks held."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
from pathlib import Path

import pytest

import xarm_emu

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def run(*args: str) -> tuple[int, str]:
    """Run ``python ARGS`` from the repository root with this process's ``xarm_emu`` importable."""
    package_root = str(Path(xarm_emu.__file__).resolve().parent.parent)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in (package_root, os.environ.get("PYTHONPATH"))
                                                        if p)}
    proc = subprocess.run([sys.executable, *args], cwd=EXAMPLES.parent, env=env, capture_output=True,
                          text=True, timeout=60)
    return proc.returncode, proc.stdout + proc.stderr


#: The lines each program prints when its checks hold (02 runs under pytest, below).
PRINTED = {
    "01_connect_and_move.py": [
        "version: 6,6,XI1300,AC1300,v1.6.0", "ok   start sequence returns 0, 0, 0", "ok   state 2 (ready)",
        "joints (deg): [30.0, 0.0, 0.0, 0.0, 0.0, 0.0]", "ok   joint move reached J1 = 30 deg",
        "pose (mm, deg): [300.0, 100.0, 200.0, -180.0, -0.0, 30.0]", "ok   line reached x=300 y=100 z=200"],
    "03_fault_injection_and_recovery.py": [
        "error C31, warning 0, state 4", "ok   the SDK reads error C31 (collision)",
        "ok   the arm stopped at the obstacle, state 4", "ok   error cleared",
        "ok   ready again (state 2)", "ok   a report shows the box ready",
        "ok   move finished after recovery (J1 = 90.0 deg)"],
    "04_stepped_time.py": [
        "queued 125 commands", "ok   faster than real time",
        "ok   deterministic: same end time and joints on a second run"],
    "05_fleet.py": [
        "127.0.0.1: 5,5,XF1300,", "127.0.0.2: 6,6,XI1300,", "127.0.0.3: 7,7,XS1300,",
        "ok   xArm5 on 127.0.0.1 moved J1 to 20 deg", "ok   xArm6 on 127.0.0.2 moved J1 to 40 deg",
        "ok   xArm7 on 127.0.0.3 moved J1 to 60 deg"],
    "06_checkpoint_restore.py": [
        "checkpoint at t = 0.500 s", "ok   collision stops the arm with C31", "restored to t = 0.500 s",
        "ok   error gone and the move still under way",
        "ok   reports 0.2 s later are the same bytes as the first time",
        "ok   the move finished instead: J1 = 1.200 rad"],
}


def loopback_routed(host: str) -> bool:
    """Whether this system routes ``host`` (Linux routes all of 127.0.0.0/8)."""
    try:
        with socket.socket() as s:
            s.bind((host, 0))
    except OSError:
        return False
    return True


@pytest.mark.parametrize("name", PRINTED)
def test_example_runs_and_its_checks_hold(name: str) -> None:
    if name == "05_fleet.py" and not loopback_routed("127.0.0.3"):
        pytest.skip("this system routes only 127.0.0.1: run on Linux, which routes all of 127.0.0.0/8")
    code, out = run(str(EXAMPLES / name))
    assert code == 0, out
    for line in PRINTED[name]:
        assert line in out, f"{line!r} missing from the output of {name}:\n{out}"
    assert "FAIL" not in out


def test_user_program_example_passes_under_pytest() -> None:
    """Through the pytest plugin (named: this suite does not load plugins automatically)."""
    code, out = run("-m", "pytest", "-p", "no:cacheprovider", "-p", "xarm_emu.pytest_plugin",
                    str(EXAMPLES / "02_test_a_user_program.py"))
    assert code == 0, out
    assert "2 passed" in out and "Logging error" not in out and "[SDK]" not in out


def test_pick_and_place_example_passes_under_pytest() -> None:
    pytest.importorskip("mujoco")
    code, out = run("-m", "pytest", "-p", "no:cacheprovider", str(EXAMPLES / "07_pick_and_place.py"))
    assert code == 0, out
    assert "2 passed" in out


def test_conveyor_cell_example_passes_under_pytest() -> None:
    pytest.importorskip("mujoco")
    code, out = run("-m", "pytest", "-p", "no:cacheprovider", str(EXAMPLES / "08_conveyor_cell.py"))
    assert code == 0, out
    assert "6 passed" in out


def test_every_example_is_run_here_and_listed_in_the_readme() -> None:
    names = sorted(p.name for p in EXAMPLES.glob("[0-9][0-9]_*.py"))
    assert names == sorted([*PRINTED, "02_test_a_user_program.py", "07_pick_and_place.py",
                            "08_conveyor_cell.py"])
    readme = (EXAMPLES / "README.md").read_text()
    assert all(name in readme for name in names)


#: Run an example with the SDK's report thread starved of the CPU at the worst moment, as on a busy
#: machine: the thread stops at the first report frame that shows error C31 (the normal and rich
#: frames carry the error code in byte 89, manual 2.1.6) and handles nothing until the program's
#: recovery (its ``set_state`` after that frame) has returned; then it takes 0.3 s for each of the
#: next three frames. ``clean_error`` is sent once that frame has arrived (a program a little slower
#: to react than the example), so a frame sent before it shows the error. The frames and their order
#: are the emulator's own; only the SDK thread that reads them is late, so the SDK learns of a frame
#: sent before ``clean_error`` after the recovery.
STARVED_REPORT_THREAD = """
import runpy, sys, threading, time
from xarm.x3.base import Base
from xarm.wrapper import XArmAPI

held, released, slow = threading.Event(), threading.Event(), [3]
handle, set_state, clean_error = Base._handle_report_data, XArmAPI.set_state, XArmAPI.clean_error

def late_handle(self, data):
    if not held.is_set() and len(data) > 89 and data[89] == 31:
        held.set()
        released.wait(20)
    if released.is_set() and slow[0] > 0:
        slow[0] -= 1
        time.sleep(0.3)
    return handle(self, data)

def recover(self, *args, **kwargs):
    code = set_state(self, *args, **kwargs)
    if held.is_set():
        released.set()
    return code

def clean_error_later(self):
    held.wait(5)
    return clean_error(self)

Base._handle_report_data = late_handle
XArmAPI.set_state = recover
XArmAPI.clean_error = clean_error_later
sys.argv = sys.argv[1:]
runpy.run_path(sys.argv[0], run_name="__main__")
"""


def test_collision_example_recovers_when_the_sdk_reads_its_reports_late() -> None:
    """Frames sent before ``clean_error`` was answered may reach the SDK's error code after the
    recovery (on a real box too: the SDK reads reports on its own thread); the program waits for a
    report that shows the box ready before it moves again, so the move finishes."""
    name = "03_fault_injection_and_recovery.py"
    code, out = run("-c", STARVED_REPORT_THREAD, str(EXAMPLES / name))
    assert code == 0, out
    for line in PRINTED[name]:
        assert line in out, f"{line!r} missing from the output of {name}:\n{out}"
    assert "FAIL" not in out
