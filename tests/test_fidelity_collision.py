"""Collision thresholds in a calibration: fitted between the bounds a recorded detection (C31) sets, and
applied by ``serve --calibration`` to the collision detection of register 37's sensitivity."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from helpers import run_cli

from xarm_emu.controller.core.interface import PERIOD
from xarm_emu.controller.core.safety import COLLISION_THRESHOLDS
from xarm_emu.fidelity.collision_fit import fit_thresholds
from xarm_emu.model.calibration import Calibration, CalibrationError, load, save
from xarm_emu.model.robots import get_model, with_calibration
from xarm_emu.protocol.firmware import SERVE_VERSION
from xarm_emu.testing import running_emulator, sdk_pointed_at

MOVED = Calibration(model="6", collision_thresholds=(60.0, 45.0, 22.0, 20.0, 10.0))


def _pushed(threshold: float, ramp: float) -> tuple[np.ndarray, ...]:
    """An external torque rising at ``ramp`` N m/s from 1 s, detected at sensitivity 3 when it reaches
    ``threshold``: real-time frames every period (residual, motion state 1 then 4 the period after),
    status frames at 5 Hz (error 31 from the first after the detection)."""
    t = np.arange(1, 1000) * PERIOD
    residual = 0.1 + ramp * np.clip(t - 1.0, 0.0, None)
    hit = t[np.argmax(residual >= threshold)]
    state = np.where(t > hit, 4, 1)
    st = np.arange(0.1, 4.0, 0.2)
    err = np.where(st >= hit + PERIOD, 31, 0)
    return t, residual, st, err, np.full(len(st), 3), state


def test_thresholds_lie_between_the_bounds_a_detection_sets() -> None:
    t, residual, st, err, level, state = _pushed(22.0, 8.0)
    fit = fit_thresholds(t, residual, st, err, level, state)
    assert fit.detections == 1 and set(fit.values) == {3}
    lo, hi = fit.bounds[3]
    assert lo <= 22.0 <= hi and hi - lo < 0.5  # the stop shows the detection within a period or so
    assert abs(fit.values[3] - 22.0) <= (hi - lo) / 2
    assert fit.sd[3] == pytest.approx((hi - lo) / math.sqrt(12))
    # without the real-time states the status frames' 0.2 s bound it
    fit = fit_thresholds(t, residual, st, err, level)
    lo, hi = fit.bounds[3]
    assert lo <= 22.0 <= hi and hi - lo <= 8.0 * 0.2 + 1e-9
    # an error raised without an external torque bounds nothing
    fit = fit_thresholds(t, np.full(len(t), 0.05), st, err, level, state)
    assert fit.values == {} and "shows no external torque" in fit.notes[0]


def test_serve_calibration_applies_the_thresholds(tmp_path: Path) -> None:
    from xarm.wrapper import XArmAPI

    path = tmp_path / "cal.toml"
    save(MOVED, path)
    assert load(path) == MOVED
    for cal, detected in ((None, False), (path, True)):  # 25 N m: under the emulator's 30, over 22
        with running_emulator(firmware=SERVE_VERSION, calibration=cal) as st, sdk_pointed_at(st):
            arm = XArmAPI("127.0.0.1", is_radian=False)
            try:
                arm.motion_enable(True)
                arm.set_mode(0)
                arm.set_state(0)
                assert st.call(lambda: st.emulator.inject_collision(2, 25.0)) is detected
                assert arm.get_err_warn_code()[1] == [31 if detected else 0, 0]
            finally:
                arm.disconnect()
    assert COLLISION_THRESHOLDS[3] == 30.0
    with pytest.raises(CalibrationError, match="one per collision sensitivity level 1..5"):
        with_calibration(get_model(6), Calibration(collision_thresholds=(1.0,) * 6))
    bad = tmp_path / "bad.toml"
    bad.write_text("collision_thresholds = [60, 45, 0, 20, 10]\n")
    code, out = run_cli("serve", "--calibration", str(bad), "--port", "0")
    assert code == 2 and out.strip() == "--calibration: collision_thresholds: 0.0 is not a usable value"
