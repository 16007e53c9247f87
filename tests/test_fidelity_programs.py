"""``xarm-emu compare`` exact on the emulator itself: every program of the library (fidelity_programs.py),
run by the unchanged SDK through the recording proxy with readers on every report port, compares with
no difference at all when replayed into the emulator with its own constants: replies, codes,
durations, paths, torques, currents and report rates."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from fidelity_programs import SESSIONS, record
from helpers import run_cli

from xarm_emu.fidelity.compare import compare


@pytest.mark.parametrize("name", list(SESSIONS))
def test_programs_compare_equal_with_the_emulator_itself(name: str, tmp_path: Path) -> None:
    path = tmp_path / f"{name}.xrec"
    missed = record(SESSIONS[name], path)
    r = compare(path)
    failures = r.failures
    if missed:  # a box starved of the processor sends fewer frames: that its rate shows, nothing else
        failures = [f for f in failures if not f.startswith("report_rate_rel")]
    differing = [(c.index, c.name, c.recorded_reply, c.replayed_reply) for c in r.commands if c.reply_differs]
    assert failures == [], (failures, differing)
    t = r.totals
    assert t["reply_differences"] == 0 and t["code_differences"] == 0 and t["code_timing_s"] == 0.0
    assert t["torque_max"] < 1e-3 and t["current_max"] < 1e-3 and t["duration_s"] == 0.0  # float32 frames
    assert t["path_mm"] < 1e-3 and t["path_deg"] < 1e-3
    # rates per connection: the rich and develop reports were read by two readers each
    ports = [c["port"] for c in r.rate_connections]
    assert ports.count(30003) == 2 and r.rates["30003"][1] == 100.0
    if not missed:
        assert all(abs(c["rate"] / r.rates[str(c["port"])][1] - 1) < 0.2 for c in r.rate_connections)
    if name == "xarm6_1.6.0":  # no real-time report at 1.x: the code both sides showed, at the same time
        assert t["samples"] == 0 and r.notes
        seen = {row["code"]: row for row in r.codes["first_seen"]}
        for code in ("E23", "E21"):  # a joint beyond its limit, a pose out of reach
            assert seen[code]["recorded"] is not None and seen[code]["emulator"] is not None
    else:
        assert t["samples"] > 100
    if name in ("xarm6_1.6.0", "lite6") and not missed:  # the command line says the same
        code, out = run_cli("compare", str(path), "--json")
        data = json.loads(out)
        assert code == 0 and data["failures"] == [] and data["totals"]["reply_differences"] == 0
        assert {"window", "placed_by", "undecided"} <= set(data["commands"][0])
