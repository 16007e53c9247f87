"""The official SDK's linear track ("linear motor") functions against a box with a track on its
control box RS-485, a box without one, and the SDK's example program 9000 run unchanged."""

from __future__ import annotations

import builtins
import runpy
from pathlib import Path
from typing import Any

import pytest
from helpers import SDK_EXAMPLES_MISSING, sdk_example, wait_for
from helpers import sdk_ready as ready

from xarm_emu.controller.devices.linear_track import HOME_LATCH
from xarm_emu.controller.emulator import Emulator
from xarm_emu.protocol.firmware import SERVE_VERSION
from xarm_emu.server.app import ServerThread

#: The SDK's own codes (x3/code.py): the track has a fault, is not on zero; a short RS-485 reply.
HAS_FAULT, NOT_INIT, MODBUS_ERR_LENG = 80, 82, 23


def connect(make_server, sdk_arm, tmp_path: Path, *, track: int | None = 700, start: float = 0.0,
            speed: float = 4.0) -> tuple[Any, ServerThread]:
    emu = Emulator(6, config_dir=tmp_path / "cfg", firmware=SERVE_VERSION, linear_track=track)
    if emu.linear_track is not None:
        emu.linear_track.position = emu.linear_track.target = start
    st = make_server(emulator=emu, speed=speed)
    arm = sdk_arm(st)
    ready(arm)
    return arm, st


def track_of(st: ServerThread, *names: str) -> tuple[Any, ...]:
    return st.call(lambda: tuple(getattr(st.emulator.linear_track, n) for n in names))  # type: ignore[no-any-return]


def test_back_origin_homes_then_enables(make_server, sdk_arm, tmp_path: Path) -> None:
    arm, st = connect(make_server, sdk_arm, tmp_path, start=230.0)
    assert arm.get_linear_motor_on_zero() == (0, 0)
    assert arm.get_linear_motor_is_enabled() == (0, 0)
    assert arm.get_linear_motor_pos() == (0, 230)
    assert arm.set_linear_motor_pos(100) == NOT_INIT  # refused by the SDK before homing
    t0 = st.call(lambda: st.emulator.time)
    assert arm.set_linear_motor_back_origin(wait=True) == 0
    took = st.call(lambda: st.emulator.time) - t0
    assert took >= 230.0 / (1533 / 6.667) + HOME_LATCH  # travel at the homing speed, then the latch
    assert arm.get_linear_motor_on_zero() == (0, 1)
    assert arm.get_linear_motor_is_enabled() == (0, 1)
    assert arm.get_linear_motor_pos() == (0, 0)


def test_speed_and_position_with_wait(make_server, sdk_arm, tmp_path: Path) -> None:
    arm, st = connect(make_server, sdk_arm, tmp_path)
    assert arm.set_linear_motor_back_origin(wait=True) == 0
    assert arm.set_linear_motor_speed(500) == 0
    assert track_of(st, "speed_value") == (3333,)
    t0 = st.call(lambda: st.emulator.time)
    assert arm.set_linear_motor_pos(300, wait=True) == 0
    took = st.call(lambda: st.emulator.time) - t0
    # the trapezoid takes 300 / 500 + 500 / 3333 = 0.75 s of controller time; the SDK polls every
    # 0.1 s of wall time (0.4 s of controller time at speed 4)
    assert 0.75 - 0.01 <= took <= 0.75 + 0.6
    assert track_of(st, "position", "velocity") == (300.0, 0.0)
    assert arm.get_linear_motor_pos() == (0, 300)
    assert arm.get_linear_motor_status() == (0, 0)
    # without waiting the call returns while the carriage moves; speed given with the move
    assert arm.set_linear_motor_pos(600, speed=1000, wait=False) == 0
    assert track_of(st, "speed_value") == (6667,)
    code, status = arm.get_linear_motor_status()
    assert code == 0 and status & 1 == 1
    # the position reads whole millimetres, so it shows 600 a moment before the carriage rests
    assert wait_for(lambda: arm.get_linear_motor_status() == (0, 0))
    assert arm.get_linear_motor_pos() == (0, 600)


def test_stop_enable_and_register_reads(make_server, sdk_arm, tmp_path: Path) -> None:
    arm, st = connect(make_server, sdk_arm, tmp_path, speed=1.0)
    assert arm.set_linear_motor_back_origin(wait=True) == 0
    assert arm.set_linear_motor_pos(700, speed=200, wait=False) == 0
    assert wait_for(lambda: arm.get_linear_motor_pos()[1] >= 50)
    assert arm.set_linear_motor_stop() == 0
    assert wait_for(lambda: arm.get_linear_motor_status() == (0, 2))  # at rest, stopped
    code, pos = arm.get_linear_motor_pos()
    assert code == 0 and 50 <= pos < 700
    code, regs = arm.get_linear_motor_registers()
    assert code == 0 and regs["pos"] == pos and regs["is_enabled"] == 1 and regs["on_zero"] == 1
    assert arm.get_linear_motor_sci() == (0, 1)
    assert arm.get_linear_motor_sco() == (0, [0, 0])
    assert arm.get_linear_motor_error() == (0, 0)
    assert arm.set_linear_motor_enable(False) == 0
    assert arm.get_linear_motor_is_enabled() == (0, 0)
    assert arm.set_linear_motor_enable(True) == 0
    assert arm.get_linear_motor_is_enabled() == (0, 1)
    # the arm's own pose stays the arm's (the SDK adds nothing for the track)
    assert arm.get_position()[1][:3] == pytest.approx([207.0, 0.0, 112.0], abs=1e-3)
    assert arm._arm.get_linear_motor_version() == (0, "1.0.0")
    code, sn = arm._arm.get_linear_motor_sn()
    assert code == 0 and sn.startswith("AL1300")


def test_bad_input_gets_the_drive_errors(make_server, sdk_arm, tmp_path: Path) -> None:
    arm, st = connect(make_server, sdk_arm, tmp_path)
    assert arm.set_linear_motor_back_origin(wait=True) == 0
    assert arm.set_linear_motor_pos(800, wait=True) == HAS_FAULT  # beyond the 700 mm stroke
    assert arm.get_linear_motor_error() == (0, 25)
    assert arm.get_linear_motor_is_enabled() == (0, 0)
    assert arm.get_linear_motor_pos() == (0, 0)
    assert arm.clean_linear_motor_error() == 0
    assert arm.get_linear_motor_error() == (0, 0)
    assert arm.set_linear_motor_speed(1500) == 0  # the SDK does not read back: the drive's error
    assert arm.get_linear_motor_error() == (0, 12)
    assert arm.set_linear_motor_enable(True) == HAS_FAULT
    assert arm.clean_linear_motor_error() == 0
    assert arm.set_linear_motor_enable(True) == 0
    st.call(lambda: st.emulator.inject_track_error(33))
    assert arm.get_linear_motor_error() == (0, 33)
    assert arm.set_linear_motor_pos(100, wait=True) == HAS_FAULT


def test_a_box_without_a_track(make_server, sdk_arm, tmp_path: Path) -> None:
    arm, _ = connect(make_server, sdk_arm, tmp_path, track=None)
    # nothing answers on the control box RS-485: the box relays the gateway exception, a reply
    # shorter than the SDK expects
    assert arm.get_linear_motor_pos()[0] == MODBUS_ERR_LENG
    assert arm.set_linear_motor_enable(True) == MODBUS_ERR_LENG
    assert arm.set_linear_motor_back_origin(wait=True) == MODBUS_ERR_LENG
    assert arm.get_state() == (0, 2)  # the arm itself is untouched
    assert arm.error_code == 0


def test_sdk_example_9000_runs_unchanged(make_server, sdk_arm, tmp_path: Path, monkeypatch,
                                         capsys) -> None:
    example = sdk_example("wrapper/common/9000-set_linear_motor.py")
    if example is None:
        pytest.skip(SDK_EXAMPLES_MISSING)
    import xarm.wrapper

    emu = Emulator(6, config_dir=tmp_path / "cfg", firmware=SERVE_VERSION, linear_track=700)
    st = make_server(emulator=emu, speed=4.0)
    made: list[Any] = []

    def to_the_emulator(ip: str, **kwargs: Any) -> Any:  # the example's fixed address -> the emulator
        made.append(sdk_arm(st, **kwargs))
        return made[-1]

    monkeypatch.setattr(xarm.wrapper, "XArmAPI", to_the_emulator)
    monkeypatch.setattr(builtins, "input", lambda *a: pytest.fail("the example asked for input"))
    (tmp_path / "robot.conf").write_text("[xArm]\nip = 127.0.0.1\n")
    (tmp_path / "common").mkdir()
    monkeypatch.chdir(tmp_path / "common")
    runpy.run_path(str(example), run_name="__main__")
    out = capsys.readouterr().out
    for line in ("set linear motor back origin, code=0", "get linear motor on zero point, code=0, status=1",
                 "set linear motor enable, code=0", "set linear motor speed, code=0",
                 "[wait]set linear motor pos, code=0", "[no wait]set linear motor pos, code=0"):
        assert line in out
    assert len(made) == 1
    # the last move went on without waiting: it arrives at 700 mm
    assert wait_for(lambda: made[0].get_linear_motor_pos() == (0, 700))


def test_status_and_inject_through_the_cli(make_server, tmp_path: Path) -> None:
    import json

    from helpers import run_cli as run

    emu = Emulator(6, config_dir=tmp_path / "cfg", firmware=SERVE_VERSION, linear_track=1000)
    st = make_server(emulator=emu, admin=True)
    port = ["--port", str(st.ports["command"])]
    code, out = run("status", "--json", "--linear-track", *port, "--report-port", str(st.ports["develop"]))
    assert code == 0, out
    assert json.loads(out)["linear_track"] == {"position": 0.0, "moving": False, "error": 0,
                                               "enabled": False, "on_zero": False}
    code, out = run("inject", "track-error", "34", *port, "--admin-port", str(st.ports["admin"]))
    assert code == 0 and "34" in out, out
    assert st.call(lambda: emu.linear_track.error) == 34  # type: ignore[union-attr]
    code, out = run("status", "--linear-track", *port, "--report-port", str(st.ports["develop"]))
    assert code == 0 and "linear track" in out and "error 34" in out and "disabled" in out, out
    code, out = run("inject", "track-error", "99", *port, "--admin-port", str(st.ports["admin"]))
    assert code != 0 and "one of" in out
    bare = make_server(emulator=Emulator(6, config_dir=tmp_path / "bare"))
    code, out = run("status", "--linear-track", "--port", str(bare.ports["command"]), "--report-port",
                    str(bare.ports["develop"]))
    assert code == 0 and "no answer on the control box RS-485" in out
