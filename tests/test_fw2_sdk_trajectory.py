"""The official SDK's trajectory calls (registers 61-65) against boxes claiming firmware 1.11.100
(the SDK polls register 65 and the report's state and mode 11) and 2.7.103 (it waits for the
OTHER_FINISH feedback frames): a hand-guided motion in joint teaching mode is recorded, saved, loaded
by a restarted box and played back, each call with ``wait=True``."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from helpers import sdk_ready, wait_for

from xarm_emu.testing import running_emulator

SDKArm = Callable[..., Any]


def _guide(ctl: Any, seconds: float) -> np.ndarray:
    """Move the joints by hand (mode 2) for ``seconds`` of wall time; returns the last position."""
    t0 = time.monotonic()
    q = ctl.q.copy()
    while (t := time.monotonic() - t0) < seconds:
        q = np.array([0.3 * math.sin(2 * t), -0.2 * math.sin(t), 0.0, 0.2 * t, 0.0, 0.0])
        ctl.teach_move(q)
        time.sleep(0.01)
    return q


@pytest.mark.parametrize("firmware", ["1.11.100", "2.7.103"])
def test_record_save_restart_load_and_play_back(firmware: str, sdk_arm: SDKArm, tmp_path: Path) -> None:
    with running_emulator(firmware=firmware, config_dir=tmp_path) as st:
        arm = sdk_arm(st)
        sdk_ready(arm)
        ctl = st.emulator.controller
        assert arm.set_mode(2) == 0 and arm.set_state(0) == 0
        assert wait_for(lambda: ctl.mode == 2 and ctl.state == 2)
        assert arm.start_record_trajectory() == 0
        last = _guide(ctl, 1.0)
        assert arm.stop_record_trajectory() == 0
        assert arm.save_record_trajectory("wave", wait=True) == 0
        assert arm.get_trajectory_rw_status() == (0, 5)
    assert (tmp_path / "trajectories" / "wave.traj").is_file()

    with running_emulator(firmware=firmware, config_dir=tmp_path) as st:
        arm = sdk_arm(st)
        sdk_ready(arm)
        ctl = st.emulator.controller
        assert arm.load_trajectory("wave", wait=True) == 0
        assert arm.get_trajectory_rw_status() == (0, 2)
        assert arm.playback_trajectory(times=1, double_speed=2, wait=True) == 0
        assert ctl.state == 2
        assert ctl.q == pytest.approx(last, abs=1e-12)
        assert wait_for(lambda: arm.mode == 0)


def test_loading_a_missing_trajectory_fails(sdk_arm: SDKArm) -> None:
    with running_emulator(firmware="1.11.100") as st:
        arm = sdk_arm(st)
        sdk_ready(arm)
        assert arm.load_trajectory("nothing", wait=True, timeout=3) != 0
        assert arm.get_trajectory_rw_status() == (0, 3)


def test_playback_without_wait_shows_mode_11_then_returns_to_0(sdk_arm: SDKArm, tmp_path: Path) -> None:
    with running_emulator(firmware="2.7.103", config_dir=tmp_path) as st:
        arm = sdk_arm(st)
        sdk_ready(arm)
        ctl = st.emulator.controller
        assert arm.set_mode(2) == 0 and arm.set_state(0) == 0
        assert wait_for(lambda: ctl.mode == 2 and ctl.state == 2)
        assert arm.start_record_trajectory() == 0
        last = _guide(ctl, 0.6)
        assert arm.stop_record_trajectory("short") == 0  # stop and save in one call
        assert arm.set_mode(0) == 0 and arm.set_state(0) == 0
        assert arm.load_trajectory("short") == 0
        modes: list[int] = []
        assert arm.playback_trajectory(times=1, wait=False) == 0
        assert wait_for(lambda: (modes.append(ctl.mode), ctl.mode == 0 and ctl.state == 2)[1], 10)
        assert 11 in modes
        assert ctl.q == pytest.approx(last, abs=1e-12)
