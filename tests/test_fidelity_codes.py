"""`xarm-emu compare` compares error and warning codes directly: the codes of every normal and rich report
frame and of every get_err_warn_code reply against the emulator's at the same controller time. The "real
arm" is an emulator on which a warning and an error are raised from outside the protocol (as a real arm
raises them on its own), so the replay, which sees only the recorded commands, shows neither."""

from __future__ import annotations

import json
import time
from pathlib import Path

import pytest
from helpers import run_cli
from proxy_session import sdk_through_proxy

from xarm_emu.fidelity.compare import compare

WARNING = 24  # an arbitrary warning code the program did not cause


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("codes") / "codes.xrec"
    with sdk_through_proxy(path, reports=("realtime", "rich")) as (st, arm):
        assert arm.set_servo_angle(angle=[20, -10, -5, 0, 15, 0], speed=80, wait=True) == 0
        assert arm.get_err_warn_code()[1] == [0, 0]
        st.call(lambda: st.emulator.inject_warning(WARNING))
        time.sleep(0.5)
        assert arm.get_err_warn_code()[1] == [0, WARNING]
        st.call(lambda: st.emulator.inject_error(31))
        time.sleep(0.5)
        assert arm.get_err_warn_code()[1] == [31, WARNING]
    return path


def test_codes_the_box_showed_and_the_emulator_did_not(recording: Path, tmp_path: Path) -> None:
    r = compare(recording)
    seen = {row["code"]: row for row in r.codes["first_seen"]}
    assert set(seen) == {"E31", f"W{WARNING}"}
    assert all(row["emulator"] is None and row["recorded"] is not None for row in seen.values())
    assert seen[f"W{WARNING}"]["recorded"] < seen["E31"]["recorded"]
    # both get_err_warn_code replies after the injections differ, with the codes of each side
    assert [(row["recorded"], row["emulator"]) for row in r.codes["replies"]] == \
        [([0, WARNING], [0, 0]), ([31, WARNING], [0, 0])]
    # the report frames: a run with the warning only, then one with the error too, on each port read
    runs = r.codes["reports"]
    assert {tuple(x["recorded"]) for x in runs} == {(0, WARNING), (31, WARNING)}
    assert all(x["emulator"] == [0, 0] and x["frames"] >= 1 for x in runs)
    assert r.totals["code_differences"] >= 4
    assert any(f.startswith("code_differences") for f in r.failures)
    # the path before the injections is the same
    assert r.totals["path_mm"] < 0.01
    code, out = run_cli("compare", str(recording), "--json")
    assert code == 1 and json.loads(out)["codes"]["replies"] == r.codes["replies"]
    code, out = run_cli("compare", str(recording), "-o", str(tmp_path / "r.html"))
    assert code == 1 and "code E31: first seen recorded" in out and "emulator never" in out
    assert "Error and warning codes" in (tmp_path / "r.html").read_text()


def test_an_error_without_torque_fits_no_collision_threshold(recording: Path, tmp_path: Path) -> None:
    """The injected C31 came with no external torque in the recorded torques: calibrate says so and
    leaves the thresholds, and fits the torques only where the box was on the replayed path."""
    code, out = run_cli("calibrate", str(recording), "-o", str(tmp_path / "cal.toml"))
    assert code == 0, out
    assert "shows no external torque in the recorded torques" in out
    assert "collision_thresholds" not in (tmp_path / "cal.toml").read_text()
