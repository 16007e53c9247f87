"""`xarm-emu compare` of a recording without the real-time report (port 30000): only what the unchanged SDK
opens went through the proxy (the command port and its own report). The program's reads of the TCP pose
and the joints are the path's samples; the comparison says what it cannot compare."""

from __future__ import annotations

import json
import time
from pathlib import Path

import pytest
from helpers import run_cli
from proxy_session import sdk_through_proxy

from xarm_emu.controller.core.interface import PERIOD
from xarm_emu.fidelity.compare import COMMAND_PORT_ONLY, compare


def record(path: Path, stop_midway: bool) -> None:
    """A move polled by get_position and get_servo_angle while it runs; with ``stop_midway`` the
    "real arm" raises an error (C31) a moment into the move, which the recorded commands do not cause."""
    with sdk_through_proxy(path, reports=()) as (st, arm):
        assert arm.set_servo_angle(angle=[30, -10, -5, 0, 15, 0], speed=40, wait=False) == 0
        for n in range(40):
            if stop_midway and n == 10:
                st.call(lambda: st.emulator.inject_error(31))
            arm.get_position()
            arm.get_servo_angle()
            time.sleep(0.02)
        arm.get_err_warn_code()
        if not stop_midway:  # the last request a read right after a move ends: its periods come after
            assert arm.set_servo_angle(angle=[0, 0, 0, 0, 0, 0], speed=60, wait=True) == 0
            arm.get_state()
            arm.get_position()


@pytest.fixture(scope="module")
def recordings(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("cmdport")
    out = {"same": d / "same.xrec", "stopped": d / "stopped.xrec"}
    record(out["same"], False)
    record(out["stopped"], True)
    return out


def test_reads_on_the_same_path_compare_equal(recordings: dict[str, Path]) -> None:
    r = compare(recordings["same"])
    reads = [c for c in r.commands if c.register in (41, 42)]
    assert len(reads) == 81 and r.totals["samples"] == 0
    assert r.totals["reply_differences"] == 0 and r.totals["code_differences"] == 0
    assert r.totals["path_mm"] < 0.01 and r.totals["path_deg"] < 0.01
    assert r.notes == list(COMMAND_PORT_ONLY) and r.failures == []
    # every command placed by the proxy's clock, undecided where its round trip spans more than a period
    others = [c for c in r.commands if c.placed_by != "read"]
    assert others and all(c.placed_by == "clock" for c in others)
    assert all(c.undecided == (c.window[1] - c.window[0] > PERIOD + 1e-9) for c in others)
    assert r.totals["undecided"] == sum(c.undecided for c in others)
    code, out = run_cli("compare", str(recordings["same"]))
    assert code == 0 and "note: no real-time report (port 30000)" in out
    assert "not compared: move durations, joint torques and currents" in out


def test_an_arm_that_stopped_is_seen_in_the_reads_and_the_codes(recordings: dict[str, Path]) -> None:
    r = compare(recordings["stopped"])
    assert r.totals["path_mm"] > 1.0 and r.totals["path_deg"] > 0.1
    stopped = [c for c in r.commands if c.register in (41, 42) and c.reply_differs]
    assert len(stopped) > 20  # every read after the stop, the replayed arm moving on
    seen = {row["code"]: row for row in r.codes["first_seen"]}
    assert seen["E31"]["emulator"] is None and seen["E31"]["recorded"] is not None
    assert r.codes["replies"][-1]["recorded"] == [31, 0]
    flagged = {f.split()[0] for f in r.failures}
    assert {"reply_differences", "path_mm", "path_deg", "code_differences"} <= flagged
    code, out = run_cli("compare", str(recordings["stopped"]), "--json")
    assert code == 1 and json.loads(out)["notes"] == list(COMMAND_PORT_ONLY)
