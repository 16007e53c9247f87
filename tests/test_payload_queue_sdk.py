"""Register 36 (the payload) in the command buffer at firmware 2.x, through the unchanged official SDK
on the stepped clock: ``set_tcp_load`` sent while a joint move runs takes effect when the buffer
reaches it (the move's end), and ``wait=True`` returns on its TRIGGER feedback then; the manual's
box (1.6.0) applies it when it arrives. The reported joint torques (register 55) are compared with
the model's torques of the same state with and without the payload."""

from __future__ import annotations

import copy
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from xarm_emu.controller.controller import joint_torques
from xarm_emu.controller.emulator import Emulator
from xarm_emu.server.thread import ServerThread

LOAD = (1.0, [0.0, 0.0, 50.0])
#: J2 and J3 by 40 degrees at 20 deg/s: about 2 s of motion.
TARGET = [0, 40, -40, 0, 0, 0]


def _server(make_server: Any, tmp_path: Path, firmware: str) -> ServerThread:
    emu = Emulator(6, config_dir=tmp_path / firmware, firmware=firmware)
    return make_server(emulator=emu, stepped=True, admin=True)


def _ready(st: ServerThread, arm: Any) -> None:
    assert arm.motion_enable(True) == 0
    assert arm.set_mode(0) == 0
    assert arm.set_state(0) == 0
    st.call(lambda: st.server.advance(0.1))


def _torques(st: ServerThread) -> tuple[np.ndarray, np.ndarray, bool]:
    """The model's torques of the box's present state without and with :data:`LOAD`, and whether
    the arm is moving."""
    def look() -> tuple[np.ndarray, np.ndarray, bool]:
        ctl = st.emulator.controller
        bare, loaded = copy.copy(ctl.settings), copy.copy(ctl.settings)
        bare.tcp_load = [0.0, 0.0, 0.0, 0.0]
        loaded.tcp_load = [LOAD[0], *LOAD[1]]
        return (joint_torques(ctl.model, ctl.data, bare), joint_torques(ctl.model, ctl.data, loaded),
                ctl.is_moving)
    return st.call(look)  # type: ignore[no-any-return]


def _reported(arm: Any) -> np.ndarray:
    code, tau = arm.get_joints_torque()
    assert code == 0
    return np.array(tau[:6])


def _start_move(arm: Any) -> None:
    assert arm.set_servo_angle(angle=TARGET, speed=20, mvacc=500, wait=False) == 0


@pytest.mark.parametrize("wait", [True, False])
def test_fw2_payload_applies_when_the_queue_reaches_it(make_server: Any, sdk_arm: Any, tmp_path: Path,
                                                        wait: bool) -> None:
    st = _server(make_server, tmp_path, "2.7.103")
    arm = sdk_arm(st)
    _ready(st, arm)
    _start_move(arm)
    st.call(lambda: st.server.advance(0.2))
    result: list[int] = []
    sender = threading.Thread(target=lambda: result.append(arm.set_tcp_load(*LOAD, wait=wait)))
    sender.start()
    if not wait:
        sender.join(5.0)
        assert result == [0]  # at once, the move still running
    else:
        deadline = time.monotonic() + 5.0  # the request reaches the box (it is queued behind the move)
        while st.call(lambda: len(st.emulator.controller.executor.buffer)) == 0:
            assert time.monotonic() < deadline
            time.sleep(0.01)
    t_move = 0.2
    while True:
        bare, loaded, moving = _torques(st)
        if not moving:
            break
        assert _reported(arm) == pytest.approx(bare, abs=1e-3)  # the payload not yet applied
        assert not np.allclose(bare, loaded, atol=1e-2)
        if wait:
            time.sleep(0.06)  # more than one of the SDK's 50 ms polls: it is still waiting
            assert sender.is_alive() and not result
        st.call(lambda: st.server.advance(0.1))
        t_move += 0.1
    assert 1.9 < t_move < 3.0  # the move took about 2 s
    # the move ended within the last 0.1 s: the queue reached the payload, the torques carry it
    assert _reported(arm) == pytest.approx(loaded, abs=1e-3)
    sender.join(5.0)
    assert not sender.is_alive() and result == [0]
    assert st.call(lambda: list(st.emulator.controller.settings.tcp_load)) == pytest.approx([1.0, 0, 0, 50])


def test_fw1_payload_applies_at_once(make_server: Any, sdk_arm: Any, tmp_path: Path) -> None:
    st = _server(make_server, tmp_path, "1.6.0")
    arm = sdk_arm(st)
    _ready(st, arm)
    _start_move(arm)
    st.call(lambda: st.server.advance(0.2))
    assert arm.set_tcp_load(*LOAD, wait=False) == 0
    bare, loaded, moving = _torques(st)
    assert moving
    assert _reported(arm) == pytest.approx(loaded, abs=1e-3)
    assert not np.allclose(bare, loaded, atol=1e-2)
