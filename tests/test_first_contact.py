"""First contact with the CLI: every bad option is one line on stderr and exit 2 before any port
opens, brackets shown as written; `codes 31`; `status --json` says its units; fault schedules count
from the first connection or the first motion; the server log tells connections, states and errors."""

from __future__ import annotations

import contextlib
import fcntl
import json
import math
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from helpers import free_ports, port_args, run_cli, serve_subprocess, wait_for

from xarm_emu.client import Client
from xarm_emu.server.faults import FaultScheduleError, read_schedule
from xarm_emu.testing import running_emulator


def _serve(tmp_path: Path, *args: str, timeout: float = 30.0) -> subprocess.CompletedProcess[str]:
    cmd = [sys.executable, "-m", "xarm_emu.cli", "serve", "--config-dir", str(tmp_path), *args]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout,
                          env={**os.environ, "COLUMNS": "80"})


BAD_SERVE = [
    (("--port", "70000"), "--port: a port is 0..65535"),
    (("--develop-port", "-1"), "--develop-port: a port is 0..65535"),
    (("--view", "--view-port", "99999"), "--view-port: a port is 0..65535"),
    (("--admin", "--admin-port", "65536"), "--admin-port: a port is 0..65535"),
    (("--host", "no-such-host.invalid"), "--host: cannot resolve 'no-such-host.invalid'"),
    (("--host", "192.0.2.1"), "--host: '192.0.2.1' is not an address of this machine"),
    (("--view", "--view-host", "192.0.2.1"), "--view-host: '192.0.2.1' is not an address of this machine"),
    (("--log-level", "LOUD"), "--log-level: one of CRITICAL, ERROR, WARNING, INFO, DEBUG"),
]


@pytest.mark.parametrize(("args", "message"), BAD_SERVE, ids=[" ".join(a) for a, _ in BAD_SERVE])
def test_each_bad_serve_option_is_one_line_and_exit_2(tmp_path: Path, args: tuple[str, ...],
                                                      message: str) -> None:
    cmd, normal, rich, develop = free_ports(4)
    done = _serve(tmp_path, *port_args(cmd, normal, rich, develop), *args)
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(message), done.stderr
    assert "Traceback" not in done.stderr + done.stdout


def test_fleet_host_that_is_not_local_is_one_line(tmp_path: Path) -> None:
    fleet = tmp_path / "fleet.toml"
    fleet.write_text('[[arm]]\nhost = "192.0.2.1"\nport = 0\nnormal_port = 0\nrich_port = 0\n'
                     'develop_port = 0\n')
    done = _serve(tmp_path, "--fleet", str(fleet))
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "arm 1 host: '192.0.2.1' is not an address of this machine" in lines[0]


def test_fault_file_message_shows_its_brackets(tmp_path: Path) -> None:
    faults = tmp_path / "faults.toml"
    faults.write_text('[fault]\nat = 1.0\ndo = "estop"\n')  # a table, not an array of tables
    done = _serve(tmp_path, *port_args(*free_ports(4)), "--faults", str(faults))
    assert done.returncode == 2
    assert "a list of [[fault]] tables" in done.stderr


def test_codes_takes_a_bare_number_and_a_label() -> None:
    code, bare = run_cli("codes", "31")
    assert code == 0 and bare.startswith("C31 ")
    code, label = run_cli("codes", "C31")
    assert code == 0 and label.startswith("C31 ")
    code, out = run_cli("codes", "9999")
    assert code == 2 and "9999 is neither a control box error nor a warning" in out


def test_status_json_says_its_units_and_gives_degrees() -> None:
    with running_emulator() as st:
        with Client("127.0.0.1", st.ports["command"]) as c:
            c.motion_enable(True)
            c.set_mode(0)
            c.set_state(0)
            c.call(23, joints=(0.5, 0, 0, 0, 0, 0, 0), speed=3.0, acc=20.0, mvtime=0.0)
            assert wait_for(lambda: c.get_state() == 2)
        code, out = run_cli("status", "--json", "--port", str(st.ports["command"]),
                            "--report-port", str(st.ports["develop"]))
    data = json.loads(out)
    assert code == 0
    assert data["units"]["joints"] == "rad" and data["units"]["joints_deg"] == "deg"
    assert data["joints"][0] == pytest.approx(0.5, abs=1e-5)
    assert data["joints_deg"][0] == pytest.approx(math.degrees(0.5), abs=1e-3)
    assert data["pose_mm_deg"][:3] == pytest.approx(data["pose"][:3])
    assert data["pose_mm_deg"][3] == pytest.approx(math.degrees(data["pose"][3]), abs=1e-3)


def _schedule(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "faults.toml"
    path.write_text(text)
    return path


def test_fault_entry_with_an_unknown_key_is_refused(tmp_path: Path) -> None:
    path = _schedule(tmp_path, '[[fault]]\nat = 1.0\ndo = "error"\ncode = "C31"\njiont = 2\n')
    with pytest.raises(FaultScheduleError, match="fault 1 \\(error\\): unknown key 'jiont'"):
        read_schedule(path)
    path = _schedule(tmp_path, '[[fault]]\nat = 1.0\nafter = "boot"\ndo = "estop"\n')
    with pytest.raises(FaultScheduleError, match="after is one of start, connect, motion"):
        read_schedule(path)


def test_every_schedulable_command_has_its_arguments_listed() -> None:
    from xarm_emu.server.admin import SCHEDULABLE
    from xarm_emu.server.faults import ARGUMENTS

    assert set(ARGUMENTS) == set(SCHEDULABLE)  # else its arguments would be refused as unknown keys


def _error(st: object) -> int:
    return st.emulator.controller.error_code  # type: ignore[attr-defined]


def test_fault_after_connect_counts_from_the_first_connection(tmp_path: Path) -> None:
    path = _schedule(tmp_path, '[[fault]]\nafter = "connect"\nat = 0.5\ndo = "error"\ncode = "C31"\n')
    with running_emulator(speed=5.0, faults=path) as st:
        time.sleep(0.5)  # 2.5 s of controller time with nobody connected: nothing fires
        assert st.call(lambda: _error(st)) == 0
        with Client("127.0.0.1", st.ports["command"]) as c:
            t0 = st.call(lambda: st.emulator.time)
            assert wait_for(lambda: c.get_err_warn()[0] == 31)
            fired = st.call(lambda: st.emulator.time)
    assert 0.4 <= fired - t0 <= 0.5 + 0.3  # t0 is read a little after the connection itself


def test_fault_after_motion_counts_from_the_first_move(tmp_path: Path) -> None:
    path = _schedule(tmp_path, '[[fault]]\nafter = "motion"\nat = 0.2\ndo = "estop"\n')
    with running_emulator(speed=5.0, faults=path) as st:
        with Client("127.0.0.1", st.ports["command"]) as c:
            c.motion_enable(True)
            c.set_mode(0)
            c.set_state(0)
            time.sleep(0.3)  # enabled and connected, not yet moving
            assert c.get_err_warn()[0] == 0
            c.call(23, joints=(1.5, 0, 0, 0, 0, 0, 0), speed=0.5, acc=5.0, mvtime=0.0)
            assert wait_for(lambda: c.get_err_warn()[0] == 1)  # C1, the emergency stop
            j1 = c.get_joints()[0]
    assert 0.0 < j1 < 1.5  # stopped on the way, about 0.2 s into the move


def test_server_log_tells_connects_states_and_errors(tmp_path: Path) -> None:
    cmd, normal, rich, develop, admin = free_ports(5)
    proc = subprocess.Popen(
        [sys.executable, "-m", "xarm_emu.cli", "serve", *port_args(cmd, normal, rich, develop), "--admin",
         "--admin-port", str(admin), "--config-dir", str(tmp_path), "--log-json"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert run_cli("status", "--wait", "20", "--port", str(cmd))[0] == 0
        with Client("127.0.0.1", cmd) as c:
            c.motion_enable(True)
            c.set_state(0)
            time.sleep(0.2)
            assert run_cli("inject", "error", "C31", "--port", str(cmd), "--admin-port", str(admin))[0] == 0
            time.sleep(0.3)
    finally:
        proc.terminate()
        _, err = proc.communicate(timeout=10)
    records = [json.loads(line) for line in err.splitlines() if line.startswith("{")]
    messages = [r["message"] for r in records]
    assert all(set(r) == {"time", "level", "logger", "message"} for r in records)
    assert "command client connected from 127.0.0.1" in messages
    assert "state 2 (sleep (ready))" in messages
    errors = [r for r in records if r["message"].startswith("error C31 Collision")]
    assert errors and errors[0]["level"] == "WARNING"
    assert any(m.startswith("command client from 127.0.0.1 left") for m in messages)


def test_serve_without_checks_failing_still_starts(tmp_path: Path) -> None:
    cmd, normal, rich, develop = free_ports(4)
    with serve_subprocess(tmp_path, *port_args(cmd, normal, rich, develop), "--host", "localhost"):
        code, _ = run_cli("status", "--wait", "20", "--port", str(cmd))
    assert code == 0


def test_inject_collision_names_an_error_already_active() -> None:
    with running_emulator(admin=True) as st:
        where = ("--port", str(st.ports["command"]), "--admin-port", str(st.ports["admin"]))
        with Client("127.0.0.1", st.ports["command"]) as c:
            c.motion_enable(True)
            c.set_state(0)
            assert run_cli("inject", "error", "C24", *where)[0] == 0
            code, out = run_cli("inject", "collision", "--joint", "2", "--torque", "100", *where)
            assert code == 0 and out.strip().startswith(
                "collision of 100 N m on joint 2 not detected (error C24")
            assert out.strip().endswith("is already active)")
            assert c.get_err_warn()[0] == 24


def test_view_without_viser_shows_the_extra_in_brackets(tmp_path: Path) -> None:
    cmd, normal, rich, develop = free_ports(4)
    argv = ["xarm-emu", "serve", *port_args(cmd, normal, rich, develop), "--view",
            "--config-dir", str(tmp_path)]
    code = ("import sys; sys.modules['viser'] = None; sys.argv = " + repr(argv)
            + "; from xarm_emu.cli import main; main()")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=30)
    assert done.returncode == 2
    assert done.stderr.strip() == "--view: the 3D view needs viser: pip install 'xarm-emu[view]'"


@pytest.mark.parametrize("args", [("status", "--port", "70000"), ("status", "--report-port", "-1"),
                                  ("inject", "estop", "--port", "70000"), ("clear", "--admin-port", "99999"),
                                  ("step", "1s", "--port", "-5")])
def test_client_commands_refuse_a_port_out_of_range(args: tuple[str, ...]) -> None:
    code, out = run_cli(*args)
    assert code == 2
    assert len(out.strip().splitlines()) == 1 and ": a port is 0..65535 (0: any free port), got " in out


# -- the README's quick start, verbatim -----------------------------------------------------------

ROOT = Path(__file__).resolve().parent.parent


def _quick_start() -> tuple[list[tuple[str, str]], str]:
    """The quick start's code blocks as (language, text), and what it says the program prints."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    start = text.index("## Quick start")
    section = text[start:text.index("\n## ", start + 1)]
    printed = re.search(r"It prints `([^`]+)`", section)
    assert printed is not None, "the quick start says what the program prints"
    return re.findall(r"```(\w+)\n(.*?)```", section, re.S), printed.group(1)


def _commands(block: str) -> list[str]:
    return [line for line in block.splitlines() if line.strip() and not line.lstrip().startswith("#")]


@contextlib.contextmanager
def _one_at_a_time() -> Iterator[None]:
    """The quick start uses the fixed ports 502 and 30000-30003: runs of this test on one machine
    (several checkouts) take turns."""
    with open(Path(tempfile.gettempdir()) / "xarm-emu-quick-start.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


def _run_quick_start(where: Path, serve: str, setup: list[str], program: str, port: int) -> str:
    """``serve`` in the background, then ``setup`` in order, in a directory that holds the checkout's
    Makefile and venv as a fresh clone after `make serve` does, and ``program`` as first_move.py;
    returns what the program printed."""
    for name in ("Makefile", "pyproject.toml", ".venv"):
        if not (where / name).exists():
            (where / name).symlink_to(ROOT / name)
    (where / "first_move.py").write_text(program, encoding="utf-8")
    env = {**os.environ, "XDG_CONFIG_HOME": str(where / "config")}  # the user's own configuration stays
    server = subprocess.Popen(["bash", "-c", serve], cwd=where, env=env, start_new_session=True,
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        probe = subprocess.run([str(ROOT / ".venv" / "bin" / "xarm-emu"), "status", "--wait", "60",
                                "--port", str(port)], capture_output=True, text=True, timeout=90)
        assert probe.returncode == 0, probe.stdout + probe.stderr
        out = ""
        for line in setup:
            done = subprocess.run(["bash", "-c", line], cwd=where, env=env, capture_output=True, text=True,
                                  timeout=120)
            assert done.returncode == 0, (line, done.stdout, done.stderr)
            out = done.stdout
        return out
    finally:
        os.killpg(server.pid, signal.SIGTERM)
        try:
            server.communicate(timeout=15)
        except subprocess.TimeoutExpired:
            os.killpg(server.pid, signal.SIGKILL)
            server.communicate()


def test_the_readme_quick_start_runs_verbatim(tmp_path: Path) -> None:
    blocks, printed = _quick_start()
    langs = [lang for lang, _ in blocks]
    assert langs == ["sh", "sh", "python", "sh", "python"], langs
    (_, serve), (_, setup), (_, program), (_, serve_unprivileged), (_, port_line) = blocks
    assert _commands(serve) == ["make serve   # set-up (.venv with only what serve needs), then the emulator"]
    last = program.strip().splitlines()
    with _one_at_a_time():
        if os.geteuid() == 0:  # the root path: port 502
            out = _run_quick_start(tmp_path, serve.strip(), _commands(setup), program, 502)
            assert out.strip().splitlines()[-1] == printed
        # the unprivileged path: --port 5020 and the one line above XArmAPI(...)
        at = next(i for i, line in enumerate(last) if line.startswith("arm = XArmAPI("))
        moved = "\n".join(last[:at] + port_line.strip().splitlines() + last[at:]) + "\n"
        out = _run_quick_start(tmp_path, serve_unprivileged.strip(), _commands(setup), moved, 5020)
        assert out.strip().splitlines()[-1] == printed


def test_replay_prints_the_box_lines_before_its_own_verdict(tmp_path: Path) -> None:
    trace = tmp_path / "wire.jsonl"
    with running_emulator(trace=trace) as st, Client("127.0.0.1", st.ports["command"]) as c:
        c.motion_enable(True)
        c.set_mode(0)
        c.set_state(0)
        c.call(23, joints=(9.0, 0, 0, 0, 0, 0, 0), speed=1.0, acc=10.0, mvtime=0.0)  # beyond J1's range
        assert c.get_err_warn()[0] == 23
    done = subprocess.run([sys.executable, "-m", "xarm_emu.cli", "replay", str(trace), "--firmware", "1.6.0"],
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=60)
    lines = done.stdout.strip().splitlines()
    assert done.returncode == 0, done.stdout
    assert lines[-1].endswith("requests replayed: every reply is the same")
    assert any(line.startswith("error C23 ") for line in lines[:-1])  # the replayed box's, before it
