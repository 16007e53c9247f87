"""The emulator's state as bytes (controller/core/state_bytes.py): a checkpoint written mid-motion and
loaded into a fresh emulator, in this process or another, continues the same motion to the bit;
commands waiting in the buffer (IO sent with the sync byte, the counter) run in their turn after
the load; bytes of another box or no state at all are refused with a clear error (an emulator
feature: no real control box has checkpoints)."""

from __future__ import annotations

import json
import math
import subprocess
import sys
import textwrap
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from helpers import ready, report_frames
from test_clock_exact import gripper_to

from xarm_emu.controller.core.state_bytes import StateBytesError
from xarm_emu.controller.emulator import Emulator

PI = math.pi


def send(emu: Emulator, code: int, **values: Any) -> tuple[int, bytes]:
    return emu.handle(code, emu.controller.registers[code].request.encode(values))


def _program(emu: Emulator) -> None:
    """Queue a mixed motion: a joint move, a line chain blended at its corners (with a line that
    arrives while the chain runs, blended in late), an arc, IO and the counter behind the moves."""
    ready(emu)
    send(emu, 23, joints=(0.2, -0.3, -0.4, 0.0, 0.7, 0.0, 0.0), speed=1.0, acc=8.0, mvtime=0.0)
    send(emu, 22, pose=(300.0, 80.0, 250.0, PI, 0.0, 0.0), speed=120.0, acc=1500.0, mvtime=0.0, radius=20.0)
    send(emu, 22, pose=(300.0, -20.0, 250.0, PI, 0.0, 0.0), speed=120.0, acc=1500.0, mvtime=0.0, radius=20.0)
    send(emu, 134, digital=0x0101, sync=1)  # output 0 on behind the moves
    send(emu, 135, analog=2000, sync=1)  # an analog output behind them
    send(emu, 144, ionum=3, on=1, xyz=(260.0, 30.0, 250.0), tol_r=10.0)  # a trigger on the arc, armed in turn
    emu.handle(75, b"")  # the counter, behind the moves (firmware 2.x)
    emu.advance(1.7)  # on the chain's last straight piece: the next line is blended in from there
    send(emu, 22, pose=(220.0, -20.0, 250.0, PI, 0.0, 0.0), speed=120.0, acc=1500.0, mvtime=0.0, radius=0.0)
    send(emu, 27, pose1=(260.0, 30.0, 250.0, PI, 0.0, 0.0), pose2=(300.0, 0.0, 250.0, PI, 0.0, 0.0),
         speed=80.0, acc=1000.0, mvtime=0.0, percent=50.0)


def _continue_both(a: Emulator, b: Emulator, seconds: float) -> float:
    """Step both period by period for ``seconds``; the largest joint difference seen."""
    worst = 0.0
    for _ in range(round(seconds / a.controller.period)):
        a.step()
        b.step()
        worst = max(worst, float(np.max(np.abs(a.controller.q - b.controller.q))))
    return worst


@pytest.mark.parametrize("kw", [{}, {"firmware": "2.7.103", "linear_track": 700},
                                {"firmware": "2.7.103", "gripper": "robotiq-2f85"}],
                         ids=["1.6.0", "2.7.103-track", "2.7.103-robotiq"])
@pytest.mark.parametrize("at", [0.05, 0.8, 1.6])  # in the late blend, in the arc
def test_a_checkpoint_loaded_in_a_fresh_emulator_continues_the_motion(kw: dict[str, Any], at: float) -> None:
    live = Emulator(6, **kw)
    _program(live)
    live.advance(at)
    assert live.controller.executor.running  # mid-motion
    data = live.checkpoint_bytes()
    loaded = Emulator(6, **kw)
    loaded.restore_bytes(data)
    assert report_frames(loaded) == report_frames(live)
    assert _continue_both(live, loaded, 9.0) <= 1e-9
    assert not live.controller.executor.active and live.controller.motion_state != 1  # the motion ended
    assert report_frames(loaded) == report_frames(live)  # the IO, the counter, the clock and the rest
    assert live.controller.user_counter == loaded.controller.user_counter == (0 if kw == {} else 1)
    assert loaded.io.cgpio.general_outputs & 0b1001 == 0b1001  # the synced output and the trigger's
    assert loaded.io.cgpio.analog_outputs[0] == live.io.cgpio.analog_outputs[0] > 0


def test_the_bytes_read_back_to_the_same_tree() -> None:
    emu = Emulator(7, vacuum=True)
    _program(emu)
    emu.advance(0.5)
    data = emu.checkpoint_bytes()
    other = Emulator(7, vacuum=True)
    other.restore_bytes(data)
    assert other.checkpoint_bytes() == data


def test_a_new_process_loads_a_checkpoint_file(tmp_path: Path) -> None:
    live = Emulator(6)  # in a joint move and a blended chain planned from rest
    ready(live)
    send(live, 23, joints=(0.2, -0.3, -0.4, 0.0, 0.7, 0.0, 0.0), speed=1.0, acc=8.0, mvtime=0.0)
    send(live, 22, pose=(300.0, 80.0, 250.0, PI, 0.0, 0.0), speed=120.0, acc=1500.0, mvtime=0.0, radius=20.0)
    send(live, 22, pose=(300.0, -20.0, 250.0, PI, 0.0, 0.0), speed=120.0, acc=1500.0, mvtime=0.0, radius=0.0)
    live.advance(0.5)
    path = tmp_path / "mid-motion.ckpt"
    path.write_bytes(live.checkpoint_bytes())
    live.advance(3.0)
    script = textwrap.dedent(f"""
        import json
        from pathlib import Path
        from xarm_emu.controller.emulator import Emulator
        emu = Emulator(6)
        emu.restore_bytes(Path({str(path)!r}).read_bytes())
        emu.advance(3.0)
        print(json.dumps([emu.controller.q.tolist(), emu.time]))
    """)
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=60,
                         check=True)
    q, t = json.loads(run.stdout)
    assert np.max(np.abs(np.array(q) - live.controller.q)) <= 1e-9
    assert t == live.time


def test_bytes_of_another_box_or_no_state_are_refused() -> None:
    emu = Emulator(6)
    _program(emu)
    data = emu.checkpoint_bytes()
    before = report_frames(emu)
    with pytest.raises(StateBytesError, match="another box: model"):
        Emulator(7).restore_bytes(data)
    with pytest.raises(StateBytesError, match="another box: .*gripper"):
        Emulator(6, gripper="bio").restore_bytes(data)
    for junk in (b"", b"not a checkpoint", data[: len(data) // 2]):
        with pytest.raises(StateBytesError):
            emu.restore_bytes(junk)
    assert report_frames(emu) == before  # a refused load changes nothing


def test_a_lambda_among_the_scheduled_actions_is_named_not_written() -> None:
    emu = Emulator(6)
    emu.at(5.0, lambda: emu.inject_error(22))
    with pytest.raises(StateBytesError, match=r"state\.schedule\.heap\[0\]\[2\]: .*lambda"):
        emu.checkpoint_bytes()


@pytest.mark.parametrize("kw", [{}, {"firmware": "2.7.103", "gripper": "robotiq-2f85", "linear_track": 700},
                                {"vacuum": True}, {"firmware": "2.7.103", "gripper": "bio"}],
                         ids=["1.6.0", "robotiq-track", "vacuum", "bio"])
def test_periods_run_only_on_the_clock_leave_the_tree_of_every_period_stepped(kw: dict[str, Any]) -> None:
    """At rest a ``step()`` call before ``next_event()`` runs only the clock: the whole state, as
    bytes, is the same as that of a box that stepped every period (a move, a delayed output, the
    devices and the thermal steps in between)."""
    fast, exact = Emulator(6, **kw), Emulator(6, exact_steps=True, **kw)
    for emu in (fast, exact):
        ready(emu)
        send(emu, 142, ionum=2, on=1, delay=1.3)
        send(emu, 23, joints=(0.1, 0.0, -0.1, 0.0, 0.1, 0.0, 0.0), speed=1.0, acc=8.0, mvtime=0.0)
        if kw.get("gripper", "xarm") == "xarm":
            gripper_to(emu, 500, speed=1500)  # the gripper moves on its own for a while
    compared = 0
    for k in range(900):  # 7.2 s in strides of 1 to 3 periods, as report frames catch up
        for emu in (fast, exact):
            emu.step(1 + k % 3)
        if k % 9 == 0:
            assert fast.checkpoint_bytes() == exact.checkpoint_bytes(), k
            compared += 1
    assert fast.periods_jumped > 1000 and exact.periods_jumped == 0  # most of it ran on the clock
    assert compared == 100


@pytest.mark.parametrize(("mode", "code", "values"), [
    (1, 29, {"joints": (0.3, 0.1, -0.2, 0.0, 0.2, 0.0, 0.0), "speed": 0.0, "acc": 0.0, "mvtime": 0.0}),
    (6, 23, {"joints": (0.3, 0.1, -0.2, 0.0, 0.2, 0.0, 0.0), "speed": 1.0, "acc": 8.0, "mvtime": 0.0}),
    (7, 21, {"pose": (250.0, 50.0, 250.0, PI, 0.0, 0.0), "speed": 100.0, "acc": 1000.0, "mvtime": 0.0}),
], ids=["servo", "online-joint", "online-cartesian"])
def test_servo_and_online_motions_continue_after_a_load(mode: int, code: int, values: dict[str, Any]) -> None:
    """Servo mode's tracker and the online planner's trajectory (modes 1, 6, 7 of register 19)
    continue from a saved state as in the live box."""
    live = Emulator(6, firmware="2.7.103")
    ready(live)
    send(live, 19, mode=mode)
    send(live, 12, state=0)
    live.step(2)
    send(live, code, **values)
    live.advance(0.2)
    q0 = live.controller.q.copy()
    loaded = Emulator(6, firmware="2.7.103")
    loaded.restore_bytes(live.checkpoint_bytes())
    assert _continue_both(live, loaded, 3.0) <= 1e-9
    assert float(np.max(np.abs(live.controller.q - q0))) > 0.01  # it moved after the save
    assert report_frames(loaded) == report_frames(live)
