"""The official SDK's gripper and IO calls against the emulator.

Gripper over register 124 (Modbus-RTU to host 9, slave 8), tool IO (127/128), control box GPIO
(131-139), delayed and position-triggered outputs (142-147), stop clearing (146); inputs played from
the in-process API and seen through the SDK and the rich report (manual 2.1.4, 2.1.6 bytes 384-433).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from helpers import sdk_ready as ready
from helpers import wait_for

from xarm_emu.controller.core.interface import PERIOD
from xarm_emu.server.app import ServerThread


def connect(make_server, sdk_arm, speed: float = 1.0, report_type: str = "rich") -> tuple[Any, ServerThread]:
    st = make_server(speed=speed)
    arm = sdk_arm(st, report_type=report_type)
    ready(arm)
    return arm, st


class StepLog:
    """Records, after every control period, (controller time, TCP xyz, probe()) in the server thread."""

    def __init__(self, st: ServerThread, probe: Callable[[], Any]) -> None:
        self.st, self.rows = st, []
        emu = st.emulator
        orig = emu.step

        def step(n: int = 1) -> None:
            for _ in range(n):
                orig(1)
                self.rows.append((emu.time, emu.controller.tcp_position, probe()))

        st.call(lambda: setattr(emu, "step", step))

    def close(self) -> list[tuple[float, tuple[float, float, float], Any]]:
        self.st.call(lambda: self.st.emulator.__dict__.pop("step", None))
        return list(self.rows)


# -- gripper ------------------------------------------------------------------------------------

def test_gripper_moves_and_wait_returns_on_arrival(make_server, sdk_arm) -> None:
    arm, st = connect(make_server, sdk_arm, speed=1.0)
    g = st.emulator.gripper.gripper
    assert arm.set_gripper_enable(True) == 0
    assert arm.set_gripper_mode(0) == 0
    assert arm.set_gripper_speed(5000) == 0
    assert st.call(lambda: (g.enabled, g.mode, g.speed)) == (True, 0, 5000)
    t0 = time.monotonic()
    assert arm.set_gripper_position(400, wait=True) == 0
    elapsed = time.monotonic() - t0
    # 400 pulses at 5000 r/min (0.17 pulse/s per r/min, gripper.py) take 0.47 s: wait covered the travel
    assert st.call(lambda: g.position) == 400.0
    assert elapsed > 0.9 * 400 / 850
    code, pos = arm.get_gripper_position()
    assert code == 0 and pos == 400
    # and back, without waiting: the call returns while the fingers still move
    assert arm.set_gripper_position(100, wait=False) == 0
    assert st.call(lambda: g.position) > 100.0
    assert wait_for(lambda: arm.get_gripper_position() == (0, 100))


def test_gripper_error_is_reported_and_cleared(make_server, sdk_arm) -> None:
    arm, st = connect(make_server, sdk_arm, speed=5.0)
    assert arm.set_gripper_enable(True) == 0
    assert arm.get_gripper_err_code() == (0, 0)
    st.call(lambda: st.emulator.inject_gripper_error(11))
    assert arm.get_gripper_err_code() == (0, 11)
    assert st.call(lambda: st.emulator.snapshot().tgpio_code) == (1, 11)
    assert arm.clean_gripper_error() == 0
    assert arm.get_gripper_err_code() == (0, 0)
    # a provoked error: a target beyond 850 gives G25 (command over software limit, manual 3.3)
    arm.set_gripper_enable(True)
    arm.set_gripper_position(900, wait=False)
    assert arm.get_gripper_err_code() == (0, 25)
    assert arm.clean_gripper_error() == 0
    assert arm.get_gripper_err_code() == (0, 0)


# -- tool IO ------------------------------------------------------------------------------------

def test_tool_digital_and_analog_io(make_server, sdk_arm) -> None:
    arm, st = connect(make_server, sdk_arm, speed=5.0)
    tool = st.emulator.io.tool
    assert arm.get_tgpio_digital() == (0, [0, 0, 0, 0])
    st.call(lambda: st.emulator.set_input("tgpio", 1, 1))
    assert arm.get_tgpio_digital() == (0, [0, 1, 0, 0])
    assert arm.get_tgpio_digital(1) == (0, 1)
    st.call(lambda: st.emulator.set_input("tool-analog", 0, 1.65))
    st.call(lambda: st.emulator.set_input("tool-analog", 1, 3.3))
    code, a0 = arm.get_tgpio_analog(0)
    assert code == 0 and a0 == pytest.approx(1.65, abs=3.3 / 4095 + 1e-9)
    code, a1 = arm.get_tgpio_analog(1)
    assert code == 0 and a1 == pytest.approx(3.3, abs=1e-3)
    # outputs (0x0A15 mask words), read back at 0x0A18
    assert arm.set_tgpio_digital(0, 1) == 0
    assert st.call(lambda: (tool.output(0), tool.output(1))) == (1, 0)
    assert arm.set_tgpio_digital(1, 1) == 0
    assert arm.get_tgpio_output_digital() == (0, [1, 1, 0, 0, 0])
    assert arm.set_tgpio_digital(0, 0) == 0
    assert arm.get_tgpio_output_digital(0) == (0, 0)
    assert arm.get_tgpio_output_digital(1) == (0, 1)


# -- control box GPIO ---------------------------------------------------------------------------

def test_control_box_digital_and_analog_io(make_server, sdk_arm) -> None:
    arm, st = connect(make_server, sdk_arm, speed=5.0)
    cg = st.emulator.io.cgpio
    code, di = arm.get_cgpio_digital()
    assert code == 0 and di == [1] * 16  # inputs idle high, 16 IO on a 1300 box
    st.call(lambda: st.emulator.set_input("cgpio", 3, 0))
    st.call(lambda: st.emulator.set_input("cgpio", 12, 0))
    code, di = arm.get_cgpio_digital()
    assert di == [1, 1, 1, 0] + [1] * 8 + [0, 1, 1, 1]
    assert arm.get_cgpio_digital(3) == (0, 0)
    st.call(lambda: st.emulator.set_input("analog", 1, 5.0))
    code, ai = arm.get_cgpio_analog()
    assert code == 0 and ai[0] == pytest.approx(0.0, abs=1e-9)
    assert ai[1] == pytest.approx(5.0, abs=10 / 4095 + 1e-9)
    # outputs: digital 2 and 10 (the two-word form for IO >= 8), analog outputs
    assert arm.set_cgpio_digital(2, 1) == 0
    assert arm.set_cgpio_digital(10, 1) == 0
    assert st.call(lambda: [cg.output(i) for i in range(16)]) == [0, 0, 1] + [0] * 7 + [1] + [0] * 5
    assert arm.set_cgpio_analog(0, 2.5) == 0
    assert arm.set_cgpio_analog(1, 7.5) == 0
    assert st.call(lambda: list(cg.analog_outputs)) == [int(2.5 / 10 * 4095), int(7.5 / 10 * 4095)]
    # register 139 through the SDK: [state, err, di fun, di, do fun, do, ai1, ai2, ao1, ao2, fun lists]
    code, state = arm.get_cgpio_state()
    assert code == 0
    assert state[0:2] == [0, 0]
    assert state[3] == 0xFFFF & ~(1 << 3) & ~(1 << 12)
    assert state[5] == (1 << 2) | (1 << 10)
    assert state[7] == pytest.approx(5.0, abs=10 / 4095 + 1e-9)
    assert state[8] == pytest.approx(2.5, abs=10 / 4095 + 1e-9)
    assert state[9] == pytest.approx(7.5, abs=10 / 4095 + 1e-9)
    assert len(state[10]) == 16 and len(state[11]) == 16
    # the rich report shows the same live IO (bytes 384-433), parsed by the SDK
    # (a frame prepared between two of the calls above shows the outputs set so far: wait for one
    # prepared after the last)
    assert wait_for(lambda: arm.cgpio_states[3] == state[3] and arm.cgpio_states[5] == state[5]
                    and abs(arm.cgpio_states[9] - 7.5) <= 10 / 4095 + 1e-9)
    assert arm.cgpio_states[7] == pytest.approx(5.0, abs=10 / 4095 + 1e-9)
    assert arm.cgpio_states[8:10] == pytest.approx([2.5, 7.5], abs=10 / 4095 + 1e-9)
    snap = st.call(lambda: st.emulator.snapshot())
    assert snap.cgpio_input_config == state[3] and snap.cgpio_output_config == state[5]


# -- delayed and position-triggered outputs -----------------------------------------------------

def test_delayed_outputs_fire_on_time(make_server, sdk_arm) -> None:
    """Registers 142/143: the output changes within one control period of its time."""
    arm, st = connect(make_server, sdk_arm, speed=5.0)
    io = st.emulator.io
    log = StepLog(st, lambda: (io.cgpio.output(4), io.tool.output(1)))
    t_sent = st.call(lambda: st.emulator.time)
    assert arm.set_cgpio_digital(4, 1, delay_sec=0.5) == 0
    assert arm.set_tgpio_digital(1, 1, delay_sec=0.3) == 0
    t_acked = st.call(lambda: st.emulator.time)
    assert st.call(lambda: (io.cgpio.output(4), io.tool.output(1))) == (0, 0)
    assert wait_for(lambda: st.call(lambda: (io.cgpio.output(4), io.tool.output(1))) == (1, 1))
    rows = log.close()
    t_cg = next(t for t, _, (c, _t) in rows if c == 1)
    t_tool = next(t for t, _, (_c, tl) in rows if tl == 1)
    assert t_sent + 0.5 - 1e-9 <= t_cg <= t_acked + 0.5 + PERIOD + 1e-9
    assert t_sent + 0.3 - 1e-9 <= t_tool <= t_acked + 0.3 + PERIOD + 1e-9
    code, di = arm.get_tgpio_output_digital()
    assert di[1] == 1 and arm.get_cgpio_state()[1][5] == 1 << 4


def _first_entry(rows: list, centre: np.ndarray, radius: float) -> float:
    """Controller time of the first period whose path segment enters the sphere."""
    prev = None
    for t, p, _ in rows:
        p = np.array(p)
        if prev is not None:
            d = p - prev
            s = float(np.clip((centre - prev) @ d / max(d @ d, 1e-12), 0.0, 1.0))
            if np.linalg.norm(prev + s * d - centre) <= radius:
                return t
        prev = p
    raise AssertionError("the TCP never entered the sphere")


def test_position_triggered_outputs_fire_once_when_passing(make_server, sdk_arm) -> None:
    """Registers 144, 145, 147: fire once, within one control period of the TCP entering the sphere."""
    arm, st = connect(make_server, sdk_arm, speed=5.0, report_type="real")
    io = st.emulator.io
    log = StepLog(st, lambda: (io.cgpio.output(5), io.tool.output(0), io.cgpio.analog_outputs[1]))
    c_pt, t_pt, a_pt = np.array([257.0, 0, 112]), np.array([280.0, 0, 112]), np.array([300.0, 0, 112])
    assert arm.set_cgpio_digital_with_xyz(5, 1, list(c_pt), 2.0) == 0
    assert arm.set_tgpio_digital_with_xyz(0, 1, list(t_pt), 0.5) == 0
    assert arm.set_cgpio_analog_with_xyz(1, 6.0, list(a_pt), 1.0) == 0
    assert st.call(lambda: (io.cgpio.output(5), io.tool.output(0), io.cgpio.analog_outputs[1])) == (0, 0, 0)
    assert arm.set_position(320, 0, 112, 180, 0, 0, speed=100, mvacc=1000, wait=True) == 0
    assert st.call(lambda: (io.cgpio.output(5), io.tool.output(0))) == (1, 1)
    assert st.call(lambda: io.cgpio.analog_outputs[1]) == int(6.0 / 10 * 4095)
    # switched off by hand, they stay off on the way back through the same points: fired once
    assert arm.set_cgpio_digital(5, 0) == 0 and arm.set_tgpio_digital(0, 0) == 0
    assert arm.set_cgpio_analog(1, 0.0) == 0
    assert arm.set_position(207, 0, 112, 180, 0, 0, speed=100, mvacc=1000, wait=True) == 0
    rows = log.close()
    assert st.call(lambda: (io.cgpio.output(5), io.tool.output(0), io.cgpio.analog_outputs[1])) == (0, 0, 0)
    for k, (centre, radius) in enumerate(((c_pt, 2.0), (t_pt, 0.5), (a_pt, 1.0))):
        t_enter = _first_entry(rows, centre, radius)
        t_fire = next(t for t, _, v in rows if v[k])
        assert t_enter <= t_fire <= t_enter + PERIOD + 1e-9, (k, t_enter, t_fire)
        rises = sum(1 for a, b in zip(rows, rows[1:], strict=False) if not a[2][k] and b[2][k])
        assert rises == 1


def test_reset_outputs_when_stop(make_server, sdk_arm) -> None:
    """Register 146: with the switch on, STOP (state 4) clears the general digital outputs; off, they stay.
    The rich report's byte 313 shows the switch (SDK: gpio_reset_config)."""
    arm, st = connect(make_server, sdk_arm, speed=5.0)
    cg = st.emulator.io.cgpio
    assert arm.set_cgpio_digital(1, 1) == 0
    assert arm.set_state(4) == 0
    assert st.call(lambda: cg.output(1)) == 1
    ready(arm)
    assert arm.config_cgpio_reset_when_stop(True) == 0
    assert wait_for(lambda: arm.gpio_reset_config[0] == 1)
    assert st.call(lambda: st.emulator.snapshot().cgpio_reset_on_stop) is True
    assert arm.set_cgpio_digital(1, 1) == 0
    assert st.call(lambda: cg.output(1)) == 1
    assert arm.set_state(4) == 0
    assert wait_for(lambda: st.call(lambda: cg.output(1)) == 0)
    assert arm.get_cgpio_state()[1][5] == 0
    ready(arm)
    assert arm.config_cgpio_reset_when_stop(False) == 0
    assert wait_for(lambda: arm.gpio_reset_config[0] == 0)


# -- vacuum gripper -----------------------------------------------------------------------------

def test_vacuum_gripper_through_the_sdk(make_server, sdk_arm) -> None:
    """`set_vacuum_gripper(True, wait=True)` returns once the pressure switch (TI0) reports normal."""
    from xarm_emu.controller.devices.vacuum import PRESSURE_BUILD
    from xarm_emu.controller.emulator import Emulator

    st = make_server(emulator=Emulator(6, vacuum=True), speed=1.0)
    arm = sdk_arm(st)
    ready(arm)
    assert arm.get_vacuum_gripper() == (0, -1)  # the SDK answers -1 while the pump outputs are off
    t0 = time.monotonic()
    assert arm.set_vacuum_gripper(True, wait=True) == 0
    assert time.monotonic() - t0 >= 0.9 * PRESSURE_BUILD  # waited for the pressure, not the reply
    assert arm.get_vacuum_gripper() == (0, 1)
    assert arm.get_tgpio_output_digital()[1][:2] == [1, 0]  # pump on, release off
    assert arm.set_vacuum_gripper(False, wait=True) == 0
    assert arm.get_vacuum_gripper() == (0, -1)
    assert arm.get_tgpio_digital(0) == (0, 0)
    # a missed pick: no object at the cup, the pressure never becomes normal (SDK code 41)
    st.call(lambda: st.emulator.set_input("vacuum-object", 0, 0))
    assert arm.set_vacuum_gripper(True, wait=True, timeout=0.6) == 41
    # the part arrives, then drops while held
    st.call(lambda: st.emulator.set_input("vacuum-object", 0, 1))
    assert wait_for(lambda: arm.get_vacuum_gripper() == (0, 1))
    st.call(lambda: st.emulator.set_input("vacuum-object", 0, 0))
    assert wait_for(lambda: arm.get_vacuum_gripper() == (0, 0), timeout=0.5)


def test_without_a_vacuum_gripper_the_pressure_never_rises(make_server, sdk_arm) -> None:
    arm, st = connect(make_server, sdk_arm, speed=5.0)
    assert arm.set_vacuum_gripper(True, wait=True, timeout=0.5) == 41
    with pytest.raises(ValueError, match="no vacuum gripper"):
        st.call(lambda: st.emulator.set_input("vacuum-object", 0, 1))


def test_sdk_example_5004_runs_unchanged_with_speed_8000(tmp_path) -> None:  # type: ignore[no-untyped-def]
    from test_robotiq_sdk import run_sdk_example

    from xarm_emu.testing import running_emulator

    with running_emulator(6, speed=5.0) as st:
        env, out = run_sdk_example("wrapper/common/5004-set_gripper.py", st, tmp_path, 60.0, lambda: None)
        try:
            assert "set gripper speed, code=0" in out
            assert "[wait]set gripper pos, code=0" in out
            assert "[no wait]set gripper pos, code=0" in out  # speed 8000: no G12
            g = st.emulator.gripper.gripper
            assert st.call(lambda: (g.error, g.speed, g.position)) == (0, 8000, 300.0)
        finally:
            env["arm"].disconnect()
