"""`xarm-emu calibrate` fits the joints' thermal constants: the "real arm" is an emulator whose thermal
constants a calibration moved (fast, so that seconds of recording show them), the recording proxy sits in
front of it and the unchanged SDK moves the arm between poses of different gravity load while the rich
report (joint temperatures) and the real-time report (currents) are read through the proxy."""

from __future__ import annotations

import time
from pathlib import Path

import pytest
from helpers import run_cli
from proxy_session import sdk_through_proxy

from xarm_emu.controller.core.thermal import thermal_params
from xarm_emu.model.calibration import Calibration, load
from xarm_emu.model.robots import get_model, with_calibration

#: Time constants of seconds (the emulator's are minutes) and idle rises of tens of degrees.
TAU = (4.0, 5.0, 3.0, 6.0, 4.0, 5.0)
IDLE = (20.0, 15.0, 25.0, 12.0, 18.0, 10.0)
RISE = (1.0, 1.5, 2.0, 6.0, 6.0, 6.0)
MOVED = Calibration(model="6", thermal_time_constants=TAU, thermal_idle_rise=IDLE, thermal_rise_per_amp2=RISE)


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("thermal") / "thermal.xrec"
    with sdk_through_proxy(path, MOVED, ("realtime", "rich")) as (_, arm):
        for angles in ([0, -60, -20, 0, 60, 0], [0, 30, -100, 0, 30, 0], [40, -10, -5, 0, 15, 0]):
            assert arm.set_servo_angle(angle=angles, speed=100, wait=True) == 0
            time.sleep(2.5)  # the temperatures settle towards the pose's currents
    return path


def test_calibrate_recovers_thermal_constants(recording: Path, tmp_path: Path) -> None:
    out = tmp_path / "cal.toml"
    code, text = run_cli("calibrate", str(recording), "-o", str(out))
    assert code == 0, text
    cal = load(out)
    unc = dict(cal.uncertainties)
    tau, idle, rise = cal.thermal_time_constants, cal.thermal_idle_rise, cal.thermal_rise_per_amp2
    assert tau is not None and idle is not None and rise is not None
    # every joint warmed by several degrees: its time constant and idle rise are fitted, each within
    # three of its standard deviations of the true value
    for j in range(6):
        assert abs(tau[j] - TAU[j]) <= 3 * unc["thermal_time_constants"][j] + 0.05 * TAU[j], j
        assert unc["thermal_time_constants"][j] < 0.25 * TAU[j], j
    # the shoulder and elbow carry currents that change by amperes from pose to pose: their rise per
    # A^2 is fitted too; whole degrees on one-second steps over twelve seconds know each of the three to
    # a few percent (one standard deviation under 10 %), and the fit is within three of them
    for j in (1, 2):
        for name, got, want in (("thermal_time_constants", tau[j], TAU[j]),
                                ("thermal_idle_rise", idle[j], IDLE[j]),
                                ("thermal_rise_per_amp2", rise[j], RISE[j])):
            sd = unc[name][j]
            assert sd < 0.1 * want and abs(got - want) <= 3 * sd, (name, j, got, sd)
    # a joint whose current hardly varied keeps the emulator's rise per A^2, said so, with no uncertainty
    default = thermal_params(get_model(6))
    kept = [j for j in range(6) if unc["thermal_rise_per_amp2"][j] == float("inf")]
    assert 5 in kept and all(rise[j] == default[j].rise_per_amp2 for j in kept)
    assert "joint 6: thermal rise per A^2 not fitted" in text
    # serve --calibration takes them: the thermal model of the calibrated arm has the fitted values
    params = thermal_params(with_calibration(get_model(6), cal))
    assert [p.time_constant for p in params] == list(tau)


def test_thermal_fit_needs_a_change_and_reads_whole_degrees() -> None:
    import numpy as np

    from xarm_emu.fidelity.thermal_fit import fit_joint

    idx = np.arange(20)
    assert fit_joint(idx, np.full(20, 31.0), np.ones(20), 25.0, 1.0, 2.5) is None
    # a joint that warms on a known curve is fitted from whole degrees alone
    i2 = np.r_[np.full(10, 4.0), np.full(10, 0.25)]
    temps, x = [], 25.0
    a = np.exp(-1 / 3.0)
    for k in range(20):
        temps.append(round(x))
        target = 25.0 + 10.0 + 5.0 * i2[k]
        x = target + (x - target) * a
    f = fit_joint(idx, np.array(temps, dtype=float), i2, 25.0, 1.0, 2.5)
    assert f is not None and f.fitted_rise
    assert abs(f.time_constant - 3.0) < 0.3 and abs(f.rise_per_amp2 - 5.0) < 0.5
    assert abs(f.idle_rise - 10) < 1.5
