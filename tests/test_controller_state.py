"""The controller's mutable state is one ControllerState: the controller's names read and write it,
a copy of it (with the settings and components) is the whole box, and the report snapshot is a
function of the model, that state, the settings and the components (manual section 2.1.6)."""

from __future__ import annotations

import struct

import numpy as np

from xarm_emu.controller.core.controller_state import ControllerState
from xarm_emu.controller.emulator import Emulator, report_snapshot


def _moving() -> Emulator:
    emu = Emulator(6)
    for code, params in ((11, bytes([8, 1])), (19, bytes([0])), (12, bytes([0]))):
        emu.handle(code, params)
    emu.handle(23, struct.pack("<10f", 0.8, 0.3, -0.5, 0, 0.4, 0, 0, 1.0, 10.0, 0))
    emu.handle(23, struct.pack("<10f", -0.8, 0.0, -0.2, 0, 0.2, 0, 0, 1.0, 10.0, 0))
    emu.advance(0.3)
    assert emu.controller.state == 1
    return emu


def test_the_controller_names_are_the_state_values() -> None:
    emu = _moving()
    ctl = emu.controller
    assert isinstance(ctl.data, ControllerState)
    assert ctl.q is ctl.data.q and ctl.faults is ctl.data.faults
    assert ctl.executor.buffer is ctl.data.motion.buffer
    ctl.mode = 2
    assert ctl.data.mode == 2
    assert ctl.executor.cmdnum == ctl.data.motion.cmdnum == 2


def test_report_snapshot_is_a_function_of_model_state_settings_and_components() -> None:
    emu = _moving()
    ctl = emu.controller
    copied = emu.checkpoint().state  # a deep copy (planned trajectories are shared)
    data, settings = copied.controller, copied.settings
    assert data is not ctl.data and settings is not ctl.settings
    expected = emu.snapshot()
    emu.advance(0.5)  # the live box moves on; the copied state still gives the old report
    assert emu.snapshot() != expected
    got = report_snapshot(ctl.model, data, settings, emu.io, emu.thermal, version=ctl.version_string(),
                          tool_error=0)
    assert got == expected


def test_a_restored_state_answers_with_its_own_pose_and_torques() -> None:
    emu = _moving()
    cp = emu.checkpoint()
    before = (emu.handle(41, b""), emu.handle(55, b""), emu.snapshot())
    emu.advance(0.5)
    assert emu.handle(41, b"") != before[0]
    emu.restore(cp)
    assert (emu.handle(41, b""), emu.handle(55, b""), emu.snapshot()) == before
    assert np.array_equal(emu.joints, cp.state.controller.q)
