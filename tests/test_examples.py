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
        "ok   ready again (state 2)", "ok   move finished after recovery (J1 = 90.0 deg)"],
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
    code, out = run("-m", "pytest", "-p", "no:cacheprovider", str(EXAMPLES / "02_test_a_user_program.py"))
    assert code == 0, out
    assert "2 passed" in out and "Logging error" not in out


def test_pick_and_place_example_passes_under_pytest() -> None:
    pytest.importorskip("mujoco")
    code, out = run("-m", "pytest", "-p", "no:cacheprovider", str(EXAMPLES / "07_pick_and_place.py"))
    assert code == 0, out
    assert "2 passed" in out


def test_every_example_is_run_here_and_listed_in_the_readme() -> None:
    names = sorted(p.name for p in EXAMPLES.glob("[0-9][0-9]_*.py"))
    assert names == sorted([*PRINTED, "02_test_a_user_program.py", "07_pick_and_place.py"])
    readme = (EXAMPLES / "README.md").read_text()
    assert all(name in readme for name in names)
