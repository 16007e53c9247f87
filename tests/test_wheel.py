"""`pip install xarm-emu` from a built wheel: the wheel installed into a clean virtual environment
(its dependencies seen from this environment's site-packages) serves, and `status` reaches it; the
wheel holds every file of the package and nothing else. The fast in-suite check: `make wheel-check`
(scripts/wheel-check, run by CI) installs the wheel `make dist` builds with its dependencies from
the index, each extra too, and runs the official SDK's first move against it."""

from __future__ import annotations

import os
import subprocess
import sys
import sysconfig
import time
import zipfile
from pathlib import Path

import pytest
from helpers import free_ports, port_args

ROOT = Path(__file__).resolve().parent.parent
#: Without PYTHONPATH: the checkout's sources must not stand in for the installed wheel.
ENV = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}


@pytest.fixture(scope="module")
def wheel(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The wheel built from this checkout."""
    tmp = tmp_path_factory.mktemp("wheel")
    dist = tmp / "dist"
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", str(ROOT), "-w", str(dist)],
                   check=True, timeout=300, cwd=tmp, env=ENV)
    wheels = list(dist.glob("xarm_emu-*.whl"))
    assert len(wheels) == 1
    return wheels[0]


@pytest.fixture(scope="module")
def clean_venv(wheel: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A fresh venv holding only the wheel built from this checkout."""
    venv = tmp_path_factory.mktemp("venv") / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True, timeout=120,
                   env=ENV)
    py = venv / "bin" / "python"
    subprocess.run([sys.executable, "-m", "pip", "--python", str(py), "install", "-q", "--no-deps",
                    str(wheel)], check=True, timeout=300, env=ENV)
    site = Path(subprocess.run([str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                               check=True, capture_output=True, text=True, env=ENV).stdout.strip())
    # The dependencies (numpy, typer, ...) come from this environment, after the wheel's own files.
    (site / "shared-deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    return venv


def test_wheel_installs_its_command_that_serves_and_answers_status(clean_venv: Path, tmp_path: Path) -> None:
    exe = clean_venv / "bin" / "xarm-emu"
    assert exe.exists()
    which = [str(clean_venv / "bin" / "python"), "-c", "import xarm_emu; print(xarm_emu.__file__)"]
    where = subprocess.run(which, check=True, capture_output=True, text=True, cwd=tmp_path,
                           env=ENV).stdout
    assert where.startswith(str(clean_venv))  # the wheel's copy, not this checkout's
    cmd, normal, rich, develop = free_ports(4)
    env = ENV
    proc = subprocess.Popen([str(exe), "serve", *port_args(cmd, normal, rich, develop),
                             "--config-dir", str(tmp_path)], stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True, env=env, cwd=tmp_path)
    try:
        start = time.monotonic()
        probe = [str(exe), "status", "--wait", "30", "--port", str(cmd), "--report-port", str(develop)]
        done = subprocess.run(probe, capture_output=True, text=True, timeout=60, env=env, cwd=tmp_path)
        assert done.returncode == 0, done.stderr
        assert "sleep" in done.stdout or "stop" in done.stdout
        assert time.monotonic() - start < 30
    finally:
        proc.terminate()
        out, _ = proc.communicate(timeout=10)
    assert proc.returncode == 0
    assert f"command {cmd}" in out


def package_files() -> set[str]:
    """Every file of the package in the checkout (modules and the data beside them), as wheel paths."""
    src = ROOT / "src"
    return {p.relative_to(src).as_posix() for p in (src / "xarm_emu").rglob("*")
            if p.is_file() and "__pycache__" not in p.parts and p.suffix != ".pyc"}


def test_the_wheel_holds_the_package_with_its_data_its_license_and_no_tests(wheel: Path) -> None:
    from xarm_emu import __version__

    assert wheel.name == f"xarm_emu-{__version__}-py3-none-any.whl"
    with zipfile.ZipFile(wheel) as whl:
        names = set(whl.namelist())
        meta = whl.read(f"xarm_emu-{__version__}.dist-info/METADATA").decode()
    info = {n for n in names if n.startswith(f"xarm_emu-{__version__}.dist-info/")}
    assert names - info == package_files()  # py.typed and any data file beside the modules included
    assert f"xarm_emu-{__version__}.dist-info/licenses/LICENSE" in info
    assert not any(n.startswith(("tests/", "examples/", "bench/")) for n in names)
    assert f"\nVersion: {__version__}\n" in meta
    for python in ("3.11", "3.12", "3.13"):
        assert f"Classifier: Programming Language :: Python :: {python}\n" in meta
    assert "License-Expression: Apache-2.0\n" in meta


def test_the_installed_command_prints_the_wheel_s_version(clean_venv: Path, wheel: Path,
                                                          tmp_path: Path) -> None:
    done = subprocess.run([str(clean_venv / "bin" / "xarm-emu"), "--version"], capture_output=True,
                          text=True, timeout=60, env=ENV, cwd=tmp_path)
    assert (done.returncode, done.stderr) == (0, "")
    assert done.stdout == wheel.name.split("-")[1] + "\n"  # one line
