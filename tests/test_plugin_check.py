"""``scripts/plugin-check VENV``: the scratch project (scripts/plugin_project/) run outside the
checkout by VENV's pytest with plugins loaded automatically, once per firmware profile. Here VENV is
this interpreter's environment, where xarm-emu is installed (editable) and registers the plugin; the
release check runs it with a venv holding only the built wheel."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parent.parent / "scripts" / "plugin-check"
VENV = sys.prefix


def plugin_check(*args: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTEST_DISABLE_PLUGIN_AUTOLOAD": "1"}  # as `make test` sets it: the check unsets it
    return subprocess.run([sys.executable, str(SCRIPT), *args], capture_output=True, text=True, env=env,
                          timeout=300)


def test_the_scratch_project_runs_once_per_profile_and_passes() -> None:
    proc = plugin_check(VENV)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert proc.stdout == (f"plugin-check: ok: 3 tests x 2 firmware profiles (1.6.0, 2.7.103), 6 passed, "
                           f"with the plugin {VENV} registers\n")


def test_a_test_not_run_per_profile_fails_the_check_with_one_line(tmp_path: Path) -> None:
    """A test without the emulator runs once, not once per profile: the check names it."""
    (tmp_path / "test_user.py").write_text("def test_alone():\n    pass\n")
    proc = plugin_check(VENV, "--project", str(tmp_path))
    assert (proc.returncode, proc.stdout) == (1, "")
    line, = proc.stderr.splitlines()
    assert line.startswith("plugin-check: FAIL: the tests did not run once per profile: missing ['test_alone"
                           "[1.6.0]', 'test_alone[2.7.103]'], unexpected ['test_alone'] (output in ")
    kept = Path(line.rsplit("(output in ", 1)[1].rstrip(")"))
    assert "1 passed" in kept.read_text()
    shutil.rmtree(kept.parent)


def test_usage_mistakes_exit_2(tmp_path: Path) -> None:
    proc = plugin_check(str(tmp_path / "no-venv"))
    assert (proc.returncode, proc.stdout) == (2, "")
    no_venv = tmp_path / "no-venv"
    assert proc.stderr == f"plugin-check: {no_venv} is not a virtual environment (no bin/python)\n"
    proc = plugin_check(VENV, "--project", str(tmp_path))
    assert (proc.returncode, proc.stderr) == (2, f"plugin-check: no test functions in {tmp_path}\n")
