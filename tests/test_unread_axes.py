"""Fields beyond the arm's axes are not read, so they are never a reason to refuse (the C++ SDK's
relative move leaves stack garbage in register 83's seventh value on a six-axis arm); a queued
command that is refused ends the SDK's wait with a feedback frame of its own."""

from __future__ import annotations

import struct
from collections.abc import Callable, Iterator
from typing import Any

import pytest

from xarm_emu.controller.emulator import Emulator
from xarm_emu.protocol.feedback import FeedbackCode, FeedbackType, decode_feedback
from xarm_emu.protocol.frame import STATE_WARNING
from xarm_emu.server.thread import ServerThread
from xarm_emu.testing import running_emulator

FW2 = "2.7.103"
GARBAGE = -6.6e35


@pytest.fixture(scope="module")
def fw2() -> Iterator[ServerThread]:
    with running_emulator(firmware=FW2) as st:
        yield st


@pytest.fixture
def arm(fw2: ServerThread, sdk_arm: Callable[..., Any]) -> Any:
    a = sdk_arm(fw2)
    a.clean_warn()
    a.motion_enable(True)
    a.set_mode(0)
    a.set_state(0)
    assert a.state == 2
    return a


def _ready(emu: Emulator) -> None:
    emu.handle(11, bytes([8, 1]))
    emu.handle(12, bytes([0]))


def test_register_83_ignores_the_seventh_delta_of_a_six_axis_arm(tmp_path: Any) -> None:
    emu = Emulator(6, config_dir=tmp_path, firmware=FW2)
    _ready(emu)
    x0 = emu.snapshot().pose[0]
    params = struct.pack("<7f4f2B", 10.0, 0, 0, 0, 0, 0, GARBAGE, 50.0, 500.0, 0.0, -1.0, 0, 0)
    state, _ = emu.handle(83, params)
    assert not state & STATE_WARNING and emu.controller.warning_code == 0
    emu.advance(2.0)
    assert emu.snapshot().pose[0] == pytest.approx(x0 + 10.0, abs=0.01)


def test_joint_fields_beyond_the_axes_are_not_read(tmp_path: Any) -> None:
    emu = Emulator(6, config_dir=tmp_path, firmware=FW2)
    _ready(emu)
    state, _ = emu.handle(23, struct.pack("<7f3f", 0.2, 0, 0, 0, 0, 0, GARBAGE, 1.0, 10.0, 0.0))
    assert not state & STATE_WARNING
    emu.advance(2.0)
    assert emu.controller.data.q[0] == pytest.approx(0.2, abs=1e-6)
    # a value the arm does read is still checked: J6 huge is refused with warning 12
    state, _ = emu.handle(23, struct.pack("<7f3f", 0.2, 0, 0, 0, 0, GARBAGE, 0, 1.0, 10.0, 0.0))
    assert state & STATE_WARNING and emu.controller.warning_code == 12


def test_the_sdk_relative_move_with_garbage_returns_0(arm: Any, fw2: ServerThread,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    cmd = arm._arm.arm_cmd
    original = cmd.move_relative

    def with_garbage(pose: list[float], *args: Any, **kwargs: Any) -> Any:
        return original(list(pose[:6]) + [GARBAGE], *args, **kwargs)

    monkeypatch.setattr(cmd, "move_relative", with_garbage)
    x0 = arm.get_position()[1][0]
    assert arm.set_position(x=10, relative=True, speed=100, wait=True) == 0
    assert arm.get_position()[1][0] == pytest.approx(x0 + 10, abs=0.05)
    assert arm.warn_code == 0


def test_a_refused_queued_move_ends_the_sdk_wait(arm: Any) -> None:
    got: list[bytes] = []
    assert arm.set_feedback_type(FeedbackType.MOTION_FINISH | FeedbackType.TRIGGER) == 0
    arm.register_feedback_callback(lambda data: got.append(bytes(data)))
    # a position beyond any float the box takes: it refuses the move (warning 12), nothing is queued
    code = arm.set_position(x=1e12, y=0, z=300, roll=180, pitch=0, yaw=0, speed=100, wait=True)
    # the frame for the refused move's transaction: what a client waiting only on feedback needs
    frames = [decode_feedback(f) for f in got]
    assert [(f.kind, f.code) for f in frames] == [(FeedbackType.MOTION_FINISH, FeedbackCode.DISCARDED)], code
    assert frames[0].state & STATE_WARNING and code == 0  # the SDK returns 0 from a warned move
    arm.clean_warn()
