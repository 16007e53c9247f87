"""`xarm-emu compare` and `xarm-emu calibrate` without an arm: the "real arm" is an emulator whose estimated
constants a calibration moved, the recording proxy sits in front of it and the unchanged SDK runs a
program through the proxy."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from helpers import run_cli
from proxy_session import sdk_through_proxy

from xarm_emu.controller.core.interface import PERIOD
from xarm_emu.fidelity.compare import Comparison, compare
from xarm_emu.model.calibration import Calibration, CalibrationError, load, save
from xarm_emu.model.inertials import torque_constants
from xarm_emu.model.robots import get_model, with_calibration

KT = tuple(float(x) for x in torque_constants(get_model(6)))
#: The "real arm": torque constants 10 % above the emulator's, torque offsets and friction on J1.
MOVED = Calibration(model="6", torque_constants=tuple(k * 1.1 for k in KT),
                    torque_offsets=(0.0, 0.3, -0.2, 0.0, 0.1, 0.0),
                    viscous_friction=(0.4, 0.0, 0.0, 0.0, 0.0, 0.0),
                    coulomb_friction=(0.25, 0.0, 0.0, 0.0, 0.0, 0.0))


def record(path: Path, calibration: Calibration | None) -> int:
    """An SDK program through the proxy, with the real-time report read through it too; the report
    frames the emulator missed (a process starved of the processor sends fewer)."""
    with sdk_through_proxy(path, calibration) as (st, arm):
        assert arm.set_servo_angle(angle=[40, -10, -5, 0, 15, 0], speed=80, wait=True) == 0
        assert arm.set_position(x=300, y=50, z=200, roll=180, pitch=0, yaw=0, speed=200, wait=True) == 0
        assert arm.set_servo_angle(angle=[-40, 10, -20, 10, 30, 20], speed=80, wait=True) == 0
        arm.set_cgpio_digital(1, 1)
        return sum(st.server.reports.frames_missed.values())


@pytest.fixture(scope="module")
def recordings(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("fidelity")
    out = {"default": d / "default.xrec", "moved": d / "moved.xrec"}
    MISSED["default"] = record(out["default"], None)
    MISSED["moved"] = record(out["moved"], MOVED)
    return out


#: Report frames the emulator behind the proxy missed, per recording (its rate shows them).
MISSED: dict[str, int] = {}


def flagged_of(r: Comparison, name: str) -> set[str]:
    """The measures a comparison flags, less the report rate of a recording whose box was starved."""
    return {f.split()[0] for f in r.failures} - ({"report_rate_rel"} if MISSED.get(name) else set())


def test_default_emulator_compares_identical(recordings: dict[str, Path]) -> None:
    r = compare(recordings["default"])
    t = r.totals
    assert t["requests"] > 20 and t["samples"] > 200
    assert t["reply_differences"] == 0 and t["code_differences"] == 0
    moves = [c for c in r.commands if c.duration is not None]
    assert len(moves) == 3
    assert all(abs(c.duration[0] - c.duration[1]) <= PERIOD for c in moves)  # type: ignore[index]
    assert t["path_mm"] < 0.01 and t["path_deg"] < 0.01
    assert flagged_of(r, "default") == set()
    if not MISSED["default"]:
        code, out = run_cli("compare", str(recordings["default"]))
        assert code == 0 and out.strip().endswith("within every tolerance")


def test_moved_constants_flag_torques_and_currents_only(recordings: dict[str, Path], tmp_path: Path) -> None:
    r = compare(recordings["moved"])
    flagged = flagged_of(r, "moved")
    differing = [(c.index, c.register, c.name, c.time, c.recorded_reply, c.replayed_reply)
                 for c in r.commands if c.reply_differs]  # what a failure shows of a reply difference
    assert flagged and flagged <= {"torque_rms", "torque_max", "current_rms", "current_max"}, differing
    assert "current_max" in flagged and "torque_max" in flagged
    assert r.totals["reply_differences"] == 0 and r.totals["path_mm"] < 0.01
    code, out = run_cli("compare", str(recordings["moved"]), "--json")
    assert code == 1 and json.loads(out)["failures"] == r.failures
    # and a calibration is given to serve as it is here (running_emulator(calibration=...))


def test_calibrate_recovers_the_moved_constants(recordings: dict[str, Path], tmp_path: Path) -> None:
    cal_file = tmp_path / "cal.toml"
    code, out = run_cli("calibrate", str(recordings["moved"]), "-o", str(cal_file))
    assert code == 0
    cal = load(cal_file)
    assert cal.model == "6" and cal.torque_constants is not None and cal.torque_offsets is not None
    # the wrist's last joint carries under 0.01 N.m in this program: too little to fit, so it is kept
    # at the emulator's constant and said so; every other within 1 % of the moved one
    kt_sd = dict(cal.uncertainties)["torque_constants"]
    assert kt_sd[5] == float("inf") and cal.torque_constants[5] == KT[5] and "torque_constants[6]" in out
    moved = MOVED.torque_constants or ()
    for got, want, sd in list(zip(cal.torque_constants, moved, kt_sd, strict=True))[:5]:
        assert abs(got / want - 1.0) < 0.01 and abs(got - want) <= 3 * sd
    for got, want in zip(cal.torque_offsets, MOVED.torque_offsets or (), strict=True):
        assert abs(got - want) < 0.01
    assert cal.viscous_friction is not None and abs(cal.viscous_friction[0] - 0.4) < 0.01 * 0.4 + 1e-3
    assert cal.coulomb_friction is not None and abs(cal.coulomb_friction[0] - 0.25) < 0.01 * 0.25 + 1e-3
    assert dict(cal.uncertainties)["torque_constants"][0] < 0.01
    code, out = run_cli("compare", str(recordings["moved"]), "--calibration", str(cal_file),
                        "-o", str(tmp_path / "report.html"))
    assert code == 0 or MISSED["moved"] and "report_rate_rel" in out and "torque" not in out, out
    assert "<svg" in (tmp_path / "report.html").read_text()  # its charts (tests/test_fidelity_html.py)


def test_calibration_never_changes_what_the_manual_fixes(tmp_path: Path) -> None:
    m = with_calibration(get_model(6), MOVED)
    base = get_model(6)
    assert (m.joints, m.lower.tolist(), m.upper.tolist(), m.max_joint_speed) == \
        (base.joints, base.lower.tolist(), base.upper.tolist(), base.max_joint_speed)
    assert torque_constants(m).tolist() == list(MOVED.torque_constants or ())
    path = tmp_path / "cal.toml"
    save(MOVED, path)
    assert load(path) == MOVED
    with pytest.raises(CalibrationError, match="measured on model 6, not 7"):
        with_calibration(get_model(7), MOVED)
    with pytest.raises(CalibrationError, match="the arm has 7 joints"):
        with_calibration(get_model(7), Calibration(torque_offsets=(0.0,) * 6))
    bad = tmp_path / "bad.toml"
    bad.write_text("torque_constants = [1, -2, 3, 4, 5, 6]\n")
    code, out = run_cli("serve", "--calibration", str(bad), "--port", "0")
    assert code == 2 and out.strip() == "--calibration: torque_constants: -2.0 is not a usable value"


def test_fleet_arm_takes_a_calibration_file(tmp_path: Path) -> None:
    from xarm_emu.server.fleet import FleetError, parse_fleet

    save(MOVED, tmp_path / "cal.toml")
    fleet = parse_fleet({"arm": [{"model": 6, "calibration": "cal.toml"}, {"model": 6, "host": "127.0.0.2"}]},
                        base=tmp_path)
    calibrated, plain = (a.emulator(None) for a in fleet.arms)
    assert calibrated.model.calibration == MOVED and plain.model.calibration is None
    assert calibrated.controller.joint_currents().tolist() != plain.controller.joint_currents().tolist()
    with pytest.raises(FleetError, match="arm 1: the calibration was measured on model 6, not 7"):
        parse_fleet({"arm": [{"model": 7, "calibration": "cal.toml"}]}, base=tmp_path)


def test_calibrate_fits_what_a_program_without_joint_1_shows(tmp_path: Path) -> None:
    """Only the wrist turns: joint 1 carries no load (no gravity, next to no reaction) and its torque
    constant is kept at the emulator's (named in the file and on stdout, uncertainty inf), the others
    are fitted within three standard deviations of the moved ones, and ``compare --calibration`` of
    the partial file flags no torque or current."""
    path, cal_file = tmp_path / "no_j1.xrec", tmp_path / "partial.toml"
    with sdk_through_proxy(path, MOVED) as (_, arm):
        assert arm.set_servo_angle(angle=[0, 0, 0, 0, 30, 0], speed=60, wait=True) == 0  # the wrist only
        assert arm.set_servo_angle(angle=[0, 0, 0, 0, -10, 0], speed=60, wait=True) == 0
    code, out = run_cli("calibrate", str(path), "-o", str(cal_file))
    assert code == 0, out
    cal = load(cal_file)
    unc = dict(cal.uncertainties)["torque_constants"]
    assert cal.torque_constants is not None and cal.torque_constants[0] == KT[0] and unc[0] == float("inf")
    assert "torque_constants[1]" in out and "torque_constants[1]" in cal_file.read_text()
    fitted = [j for j in range(6) if unc[j] != float("inf")]
    assert {1, 2, 4} <= set(fitted) and 0 not in fitted  # the shoulder, elbow and wrist hold the arm up
    for j in fitted:
        want = (MOVED.torque_constants or ())[j]
        assert abs(cal.torque_constants[j] - want) <= 3 * unc[j], (j, cal.torque_constants[j], want, unc[j])
        assert abs(cal.torque_constants[j] / want - 1) < 0.01
    code, out = run_cli("compare", str(path), "--calibration", str(cal_file))
    assert "within every tolerance" in out or "torque" not in out and "current" not in out, out
