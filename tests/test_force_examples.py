"""The official SDK's F/T application example programs (8001 force teaching, 8002 admittance
control, 8003 force control, from its ``example/wrapper/common``) run unchanged against a box with
the F/T sensor mounted, and the arm does what each one asks.

The SDK's wheel does not ship its examples: ``make sdk-examples`` unpacks them from the SDK's source
distribution (or ``XARM_SDK_EXAMPLES`` names a checkout; the test is skipped, saying so, when
absent). Each program sleeps for 5 or 10 s; the box runs on lockstep time and the program's own
``time`` module turns each of its sleeps into that much controller time, so the pauses pass on
controller time at once.
"""

from __future__ import annotations

import contextlib
import runpy
import sys
import time
import types
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from helpers import SDK_EXAMPLES_MISSING, sdk_examples

from xarm_emu.controller.applications import force_control as fc
from xarm_emu.controller.emulator import Emulator
from xarm_emu.controller.scene.contact import Plane, Scene
from xarm_emu.server.app import ServerThread
from xarm_emu.testing import sdk_pointed_at

_ROOT = sdk_examples()
EXAMPLES = _ROOT / "wrapper" / "common" if _ROOT is not None else Path("absent")
pytestmark = pytest.mark.skipif(not (EXAMPLES / "8001-force_tech.py").is_file(), reason=SDK_EXAMPLES_MISSING)


def _lockstep_time(st: ServerThread) -> types.ModuleType:
    """A ``time`` module for the program alone: a sleep runs that much controller time."""
    fast = types.ModuleType("time")
    fast.__dict__.update({k: getattr(time, k) for k in dir(time) if not k.startswith("__")})

    def sleep(seconds: float) -> None:
        st.call(lambda: st.server.advance(seconds))

    fast.sleep = sleep  # type: ignore[attr-defined]
    return fast


@contextlib.contextmanager
def program_environment(st: ServerThread, program: Path) -> Iterator[None]:
    argv, real_time = sys.argv, sys.modules["time"]
    with sdk_pointed_at(st):
        sys.argv = [str(program), "127.0.0.1"]
        sys.modules["time"] = _lockstep_time(st)  # only the program imports time after this
        try:
            yield
        finally:
            sys.modules["time"] = real_time
            sys.argv = argv


def run_example(st: ServerThread, name: str) -> None:
    program = EXAMPLES / name
    with program_environment(st, program):
        runpy.run_path(str(program), run_name="__main__")


@pytest.fixture
def served(make_server: Any, tmp_path: Path) -> ServerThread:
    emu = Emulator(6, firmware="2.7.103", ft_sensor=True, ft_noise=False, config_dir=tmp_path / "box")
    return make_server(emulator=emu, stepped=True, admin=True)  # type: ignore[no-any-return]


def tcp(st: ServerThread) -> np.ndarray:
    return np.asarray(st.call(lambda: st.emulator.controller.tcp_pose()), dtype=float)


def app_seen(st: ServerThread) -> list[int]:
    """Record the application each control period (what register 203 answers)."""
    seen: list[int] = []
    emu = st.emulator

    def watch() -> None:
        seen.append(fc.control_of(emu.controller).app)
        emu.at(emu.controller.time + 0.1, watch)

    st.call(lambda: emu.at(0.0, watch))
    return seen


def test_8001_force_teaching_follows_a_hand(served: ServerThread) -> None:
    st, emu = served, served.emulator
    seen = app_seen(st)
    z0 = tcp(st)[2]
    st.call(lambda: emu.apply_wrench([0, 0, 1.0, 0, 0, 0], frame="base"))  # a hand lifts with 1 N
    run_example(st, "8001-force_tech.py")
    rise = tcp(st)[2] - z0
    assert rise == pytest.approx(100.0, abs=1.0)  # 10 mm/s (the box's damping) for its 10 s
    assert fc.APP_ADMITTANCE in seen
    assert st.call(lambda: (fc.control_of(emu.controller).app, emu.controller.error_code,
                            emu.controller.warning_code)) == (0, 0, 0)


def test_8002_admittance_settles_on_the_spring(served: ServerThread) -> None:
    st, emu = served, served.emulator
    z0 = tcp(st)[2]
    st.call(lambda: emu.apply_wrench([0, 0, 3.0, 0, 0, 0], frame="base"))
    run_example(st, "8002-admittance_control.py")
    assert tcp(st)[2] - z0 == pytest.approx(10.0, abs=0.1)  # 3 N on 300 N/m
    assert st.call(lambda: (emu.controller.error_code, emu.controller.warning_code)) == (0, 0)


def test_8003_force_control_presses_with_5_newtons(served: ServerThread) -> None:
    st, emu = served, served.emulator
    table_z = float(tcp(st)[2]) - 5.0
    st.call(lambda: emu.set_scene(Scene((Plane("table", (0, 0, table_z), (0, 0, 1), 10.0),))))
    run_example(st, "8003-force_control.py")
    assert table_z - tcp(st)[2] == pytest.approx(0.5, abs=0.05)  # 5 N at 10 N/mm, held after the end
    assert st.call(lambda: (emu.controller.error_code, emu.controller.warning_code)) == (0, 0)
