"""Fault schedules (`serve --faults`): admin requests at controller times, landing on the control
period, checked whole before the emulator starts."""

from __future__ import annotations

import json
import logging
import time
from pathlib import Path

import pytest
from helpers import free_ports, port_args, ready, run_cli, serve_subprocess

from xarm_emu.controller.core.interface import PERIOD
from xarm_emu.controller.emulator import Emulator
from xarm_emu.server.faults import FaultScheduleError

SCHEDULE = """
[[fault]]
at = 0.5
do = "set-input"
kind = "cgpio"
index = 3
value = 0

[[fault]]
at = 1.0
do = "error"
code = "C31"

[[fault]]
at = 1.0
do = "report-pause"
seconds = "2s"
"""


def test_emulator_at_runs_actions_after_the_period_that_reaches_their_time(caplog) -> None:
    emu = Emulator(6)
    seen: list[tuple[str, float]] = []
    emu.at(0.1, lambda: seen.append(("a", emu.time)))
    emu.at(0.0101, lambda: seen.append(("b", emu.time)))
    emu.at(0.1, lambda: seen.append(("c", emu.time)))
    emu.at(0.05, lambda: 1 / 0)  # logged, the others still run
    with caplog.at_level(logging.ERROR):
        emu.advance(0.2)
    assert [name for name, _ in seen] == ["b", "a", "c"]
    assert seen[0][1] == pytest.approx(3 * PERIOD)  # 0.0101 s falls in the third period
    assert seen[1][1] == pytest.approx(0.1) and seen[2][1] == pytest.approx(0.1)
    assert "scheduled action" in caplog.text
    with pytest.raises(ValueError):
        emu.at(float("nan"), lambda: None)


def test_schedule_lands_on_controller_time_in_lockstep(make_server, tmp_path: Path) -> None:
    path = tmp_path / "faults.toml"
    path.write_text(SCHEDULE)
    st = make_server(stepped=True, admin=True, faults=path)
    emu = st.emulator
    st.call(lambda: ready(emu))
    st.call(lambda: st.server.advance(0.496))
    assert st.call(lambda: (emu.io.cgpio.digital_inputs >> 3) & 1) == 1  # inputs idle high
    st.call(lambda: st.server.advance(PERIOD))
    assert st.call(lambda: (emu.io.cgpio.digital_inputs >> 3) & 1) == 0
    st.call(lambda: st.server.advance(0.496))
    assert st.call(lambda: emu.controller.error_code) == 0
    st.call(lambda: st.server.advance(PERIOD))
    assert st.call(lambda: (emu.controller.error_code, emu.controller.state)) == (31, 4)
    assert st.call(st.server.reports_paused) is True


@pytest.mark.parametrize("text, fragment", [
    ('[[fault]]\nat = 1\ndo = "step"\nseconds = 1\n', "fault 1: do is one of"),
    ('[[fault]]\nat = -1\ndo = "estop"\n', "fault 1: at is controller seconds >= 0"),
    ('[[fault]]\nat = 1\ndo = "estop"\n[[fault]]\nat = 2\ndo = "error"\ncode = "C99"\n',
     "fault 2 (error at 2 s): C99"),
    ('[[fault]]\nat = 1\ndo = "servo-error"\njoint = 9\ncode = "S23"\n', "joint 9 out of range"),
    ('[fault]\nat = 1\n', "list of [[fault]] tables"),
    ('[[fault]]\nat = 1\ndo = ["estop"]\n', "fault 1: do is one of"),
    ('[[fault]]\nat = 1\ndo = "set-input"\nkind = "cgpio"\nindex = 99\nvalue = 1\n', "cgpio input 99"),
    ('[[fault]]\nat = 1\ndo = "set-input"\nkind = "vacuum-object"\nindex = 0\nvalue = 0\n',
     "no vacuum gripper"),
    ('[[fault]\n', "not valid TOML"),
])
def test_bad_schedules_stop_the_start(make_server, tmp_path: Path, text: str, fragment: str) -> None:
    path = tmp_path / "faults.toml"
    path.write_text(text)
    with pytest.raises(FaultScheduleError) as info:
        make_server(faults=path)
    assert fragment in str(info.value)


def test_serve_faults_from_the_cli(tmp_path: Path) -> None:
    path = tmp_path / "faults.toml"
    path.write_text('[[fault]]\nat = 0.2\ndo = "warning"\ncode = 11\n')
    cmd, normal, rich, develop = free_ports(4)
    with serve_subprocess(tmp_path, *port_args(cmd, normal, rich, develop), "--faults", str(path),
                          "--speed", "4"):
        code, out = run_cli("status", "--json", "--wait", "30", "--port", str(cmd), "--report-port",
                            str(develop))
        assert code == 0, out
        deadline = time.monotonic() + 10
        while json.loads(out)["warning"] != 11 and time.monotonic() < deadline:
            time.sleep(0.05)
            out = run_cli("status", "--json", "--port", str(cmd), "--report-port", str(develop))[1]
        assert json.loads(out)["warning"] == 11
    bad = tmp_path / "bad.toml"
    bad.write_text('[[fault]]\nat = 1\ndo = "explode"\n')
    ports = ("--port", "0", "--normal-port", "0", "--rich-port", "0", "--develop-port", "0")
    code, out = run_cli("serve", "--faults", str(bad), *ports, "--config-dir", str(tmp_path))
    assert code == 2 and "do is one of" in " ".join(out.split())


def test_a_checkpoint_carries_the_pending_fault_schedule(make_server, tmp_path: Path) -> None:
    """The schedule's actions are written into a checkpoint like the rest of the state: after a
    restore the faults that were pending come again, and one waiting for the first motion waits again."""
    from xarm_emu.server.admin import execute

    path = tmp_path / "faults.toml"
    path.write_text(SCHEDULE + '\n[[fault]]\nafter = "motion"\nat = 0.2\ndo = "warning"\ncode = 11\n'
                    '\n[[fault]]\nat = 0.8\ndo = "drop-clients"\n')
    st = make_server(stepped=True, admin=True, faults=path)
    emu, srv = st.emulator, st.server
    st.call(lambda: ready(emu))
    st.call(lambda: srv.advance(0.3))
    assert "saved" in st.call(lambda: execute(srv, {"cmd": "checkpoint-save", "name": "early"}))
    assert st.call(emu.checkpoint_bytes)  # the schedule has a written form, for a file too
    st.call(lambda: srv.advance(1.0))
    assert st.call(lambda: emu.controller.error_code) == 31
    assert "restored" in st.call(lambda: execute(srv, {"cmd": "checkpoint-restore", "name": "early"}))
    assert st.call(lambda: (emu.controller.error_code, (emu.io.cgpio.digital_inputs >> 3) & 1)) == (0, 1)
    st.call(lambda: srv.advance(0.196))
    assert st.call(lambda: (emu.io.cgpio.digital_inputs >> 3) & 1) == 1
    st.call(lambda: srv.advance(0.6))
    assert st.call(lambda: (emu.controller.error_code, (emu.io.cgpio.digital_inputs >> 3) & 1)) == (31, 0)
    assert st.call(lambda: emu.controller.warning_code) == 0  # the motion-watch still waits


def test_a_state_that_cannot_be_written_is_refused_by_checkpoint_save(make_server) -> None:
    """A lambda scheduled in process has no written form: the admin request is refused by name."""
    from xarm_emu.server.admin import AdminError, execute

    st = make_server(stepped=True, admin=True)
    emu, srv = st.emulator, st.server
    st.call(lambda: emu.at(5.0, lambda: None))
    with pytest.raises(AdminError, match=r"cannot be saved: .*lambda"):
        st.call(lambda: execute(srv, {"cmd": "checkpoint-save", "name": "x"}))
    assert st.call(lambda: srv.checkpoints) == {}


def test_a_saved_schedule_needs_a_server_to_act_on(make_server, tmp_path: Path) -> None:
    """Bytes with a pending fault schedule load into a served box, and are refused by name (not
    half-loaded) by a bare emulator that has no server for the faults to act on."""
    from xarm_emu.controller.core.state_bytes import StateBytesError

    path = tmp_path / "faults.toml"
    path.write_text(SCHEDULE)
    st = make_server(stepped=True, admin=True, faults=path)
    data = st.call(st.emulator.checkpoint_bytes)
    bare = Emulator(6)
    bare.advance(0.1)
    with pytest.raises(StateBytesError, match="refers to the 'server'"):
        bare.restore_bytes(data)
    assert bare.time == pytest.approx(0.1)
    other = make_server(stepped=True, admin=True, faults=path)
    other.call(lambda: other.emulator.restore_bytes(data))
    other.call(lambda: other.server.advance(1.0))
    assert other.call(lambda: other.emulator.controller.error_code) == 31
