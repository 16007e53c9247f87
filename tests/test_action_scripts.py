"""The GitHub Action's start and stop steps (scripts/action-start, scripts/action-stop; action.yml,
docs/ci.md) run here as the action runs them: a real ``xarm-emu serve`` on free loopback ports in
the background, ready when it answers the protocol, its address in the GITHUB_OUTPUT file; then
stopped by SIGTERM with its wire trace complete and the process gone."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
from pathlib import Path

from xarm_emu.client import Client

SCRIPTS = Path(__file__).resolve().parent.parent / "scripts"
XARM_EMU = str(Path(sys.executable).parent / "xarm-emu")


def free_block(n: int) -> int:
    """The first of ``n`` consecutive ports free on loopback now."""
    for _ in range(50):
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            base = s.getsockname()[1]
        if base + n > 65535:
            continue
        try:
            held = []
            for p in range(base, base + n):
                s = socket.socket()
                held.append(s)
                s.bind(("127.0.0.1", p))
            return base
        except OSError:
            continue
        finally:
            for s in held:
                s.close()
    raise RuntimeError("no block of free ports")


def script(name: str, env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    return subprocess.run([str(SCRIPTS / name)], env={**os.environ, **env}, capture_output=True, text=True,
                          timeout=120)


def test_start_waits_for_the_box_and_stop_keeps_the_trace(tmp_path: Path) -> None:
    base = free_block(5)  # real-time (two below the rich port), normal, rich, develop, command
    out = tmp_path / "github-output"
    env = {"XARM_EMU_BIN": XARM_EMU, "XARM_EMU_DIR": str(tmp_path / "emu"), "GITHUB_OUTPUT": str(out),
           "XARM_EMU_MODEL": "lite6", "XARM_EMU_FIRMWARE": "2.7.103", "XARM_EMU_SPEED": "5",
           "XARM_EMU_PORT": str(base + 4), "XARM_EMU_DEVICES": "vacuum, linear-track=1000",
           "XARM_EMU_ARGS": f"--normal-port {base + 1} --rich-port {base + 2} --develop-port {base + 3}"}
    started = script("action-start", env)
    assert started.returncode == 0, started.stdout + started.stderr
    outputs = dict(line.split("=", 1) for line in out.read_text().splitlines())
    assert outputs["address"] == f"127.0.0.1:{base + 4}"
    assert (outputs["host"], outputs["port"]) == ("127.0.0.1", str(base + 4))
    pid = int(outputs["pid"])
    assert started.stdout == (f"action-start: xarm-emu (model lite6, firmware 2.7.103, speed 5) ready at "
                              f"127.0.0.1:{base + 4}, pid {pid}\n")
    with Client("127.0.0.1", base + 4) as client:  # ready means it answers at once
        assert client.get_version().startswith("6,") and client.get_version().endswith("v2.7.103")
    stopped = script("action-stop", env)
    assert stopped.returncode == 0, stopped.stdout + stopped.stderr
    lines = [json.loads(line) for line in Path(outputs["trace"]).read_text().splitlines()]
    assert [r.get("name") for r in lines if r.get("register") == 1][-2:] == ["GET_VERSION", "GET_VERSION"]
    assert lines[-1]["event"] == "close"
    assert stopped.stdout == (f"action-stop: xarm-emu (pid {pid}) stopped; trace {outputs['trace']} "
                              f"({len(lines)} lines)\n")
    assert not Path(f"/proc/{pid}").exists()
    again = script("action-stop", env)
    assert again.returncode == 1
    assert again.stderr == f"action-stop: no emulator started in {tmp_path / 'emu'} (no pid file)\n"


def test_bad_inputs_are_one_line_and_exit_2(tmp_path: Path) -> None:
    env = {"XARM_EMU_BIN": XARM_EMU, "XARM_EMU_DIR": str(tmp_path / "emu"), "XARM_EMU_PORT": "5020"}
    proc = script("action-start", {**env, "XARM_EMU_DEVICES": "vacuum,laser"})
    assert (proc.returncode, proc.stdout) == (2, "")
    assert proc.stderr == ("action-start: unknown device 'laser' (vacuum, ft-sensor, linear-track[=MM], "
                           "gripper=NAME)\n")
    proc = script("action-start", {**env, "XARM_EMU_PORT": "http"})
    assert (proc.returncode, proc.stderr) == (2, "action-start: port 'http' is not a port number (1-65535)\n")
    proc = script("action-start", {**env, "XARM_EMU_SCENE": str(tmp_path / "none.toml")})
    missing = tmp_path / "none.toml"
    assert (proc.returncode, proc.stderr) == (2, f"action-start: scene file '{missing}' not found\n")
    assert not (tmp_path / "emu" / "pid").exists()


def test_an_emulator_that_refuses_to_start_is_one_line(tmp_path: Path) -> None:
    """serve's own refusal comes back as its exit status and its last log line, at once (serve
    played by a script that refuses as serve refuses a linear track on firmware 1.6.0, exit 2)."""
    fake = tmp_path / "xarm-emu"
    fake.write_text("#!/usr/bin/env bash\n"
                    "[ \"$1\" = serve ] || exit 1\n"
                    "echo '--firmware: the linear track needs firmware 1.8.0 or later, not 1.6.0' >&2\n"
                    "exit 2\n")
    fake.chmod(0o755)
    env = {"XARM_EMU_BIN": str(fake), "XARM_EMU_DIR": str(tmp_path / "emu"), "XARM_EMU_FIRMWARE": "1.6.0",
           "XARM_EMU_DEVICES": "linear-track", "XARM_EMU_PORT": "5020", "XARM_EMU_WAIT": "30"}
    proc = script("action-start", env)
    assert (proc.returncode, proc.stdout) == (2, ""), proc.stderr
    log = tmp_path / "emu" / "serve.log"
    assert proc.stderr == ("action-start: xarm-emu serve exited 2 before it answered: --firmware: the linear "
                           f"track needs firmware 1.8.0 or later, not 1.6.0 (log: {log})\n")
    assert not (tmp_path / "emu" / "pid").exists()
