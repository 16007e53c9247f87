"""The SDK's own F/T example programs (its ``example/wrapper/common/8000-8010``), run unchanged as
subprocesses against an emulator with the sensor mounted: each gets the address on its command line
as the examples read it, and the SDK's port constants pointed at the emulator's free ports.

The examples are not part of the installed SDK package: ``make sdk-examples`` unpacks them from the
SDK's source distribution (or ``XARM_SDK_EXAMPLES`` names a checkout); without them these tests are
skipped, saying so."""

from __future__ import annotations

import ast
import json
import os
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from helpers import SDK_EXAMPLES_MISSING, sdk_examples

from xarm_emu.controller.devices import ft_sensor as ft
from xarm_emu.testing import running_emulator

_ROOT = sdk_examples()
EXAMPLES = _ROOT / "wrapper" / "common" if _ROOT is not None else Path("absent")
pytestmark = pytest.mark.skipif(not (EXAMPLES / "8005-read_force_data.py").is_file(),
                                reason=SDK_EXAMPLES_MISSING)

#: Runs one example file with the SDK pointed at the ports given as JSON.
BOOT = """
import json, runpy, sys, types
from xarm_emu.testing import sdk_pointed_at
ports, path = json.loads(sys.argv[1]), sys.argv[2]
with sdk_pointed_at(types.SimpleNamespace(ports=ports)):
    sys.argv = [path, "127.0.0.1"]
    runpy.run_path(path, run_name="__main__")
"""

PAYLOAD = (0.6, (4.0, -6.0, 70.0))


def example(name: str) -> Path:
    (path,) = EXAMPLES.glob(f"{name}-*.py")
    return path


def launch(st: Any, name: str) -> subprocess.Popen[str]:
    src = str(Path(__file__).resolve().parents[1] / "src")
    env = {**os.environ, "PYTHONPATH": src + os.pathsep + os.environ.get("PYTHONPATH", ""),
           "PYTHONUNBUFFERED": "1"}
    return subprocess.Popen([sys.executable, "-c", BOOT, json.dumps(st.ports), str(example(name))],
                            cwd=EXAMPLES, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True)


def run(st: Any, name: str, timeout: float = 60.0) -> str:
    proc = launch(st, name)
    try:
        out, _ = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        out, _ = proc.communicate()
        raise AssertionError(f"{name} did not end:\n{out}") from None
    assert proc.returncode == 0, out
    assert "Traceback" not in out, out
    return out


def result_of(out: str) -> tuple[int, list[float]]:
    m = re.search(r"code=(-?\d+), result=(\[[^\]]*\])", out)
    assert m, out
    return int(m.group(1)), list(ast.literal_eval(m.group(2)))


def box(**kw: Any) -> Any:
    return running_emulator(6, firmware="2.7.103", ft_sensor=True, ft_noise=False, speed=5.0, **kw)


def test_8000_identifies_the_tcp_load_from_the_joint_torques() -> None:
    with box() as st:
        st.call(lambda: st.emulator.set_payload(*PAYLOAD))
        code, result = result_of(run(st, "8000"))
    total = PAYLOAD[0] + ft.SENSOR_MASS  # the joints carry the sensor too
    assert code == 0 and result[0] == pytest.approx(total, rel=0.03)


def test_8004_identifies_the_load_below_the_sensor() -> None:
    with box() as st:
        st.call(lambda: st.emulator.set_payload(*PAYLOAD))
        code, result = result_of(run(st, "8004"))
        enabled = st.call(lambda: ft.enabled(st.emulator.controller))
    assert code == 0 and len(result) == 10
    assert result[0] == pytest.approx(PAYLOAD[0], rel=0.01)
    assert result[3] == pytest.approx(PAYLOAD[1][2] - ft.SENSOR_HEIGHT, abs=1.0)
    assert enabled is False  # the example switches the sensor off at its end


def test_8005_prints_the_report_forces_until_an_error() -> None:
    with box() as st:
        st.call(lambda: st.emulator.set_payload(*PAYLOAD))
        proc = launch(st, "8005")
        lines = []
        try:
            assert proc.stdout is not None
            for line in proc.stdout:
                lines.append(line)
                if sum("exe_force" in x for x in lines) >= 3:
                    break
            st.call(lambda: st.emulator.inject_ft_error(3))  # C50 ends the example's loop
            out, _ = proc.communicate(timeout=30)
        finally:
            if proc.poll() is None:
                proc.kill()
        code = proc.returncode
    text = "".join(lines) + out
    assert code == 0 and "Traceback" not in text, text
    raw = [ast.literal_eval(m) for m in re.findall(r"raw_force: (\[[^\]]*\])", text)]
    ext = [ast.literal_eval(m) for m in re.findall(r"exe_force: (\[[^\]]*\])", text)]
    # After the example's zero, the external force reads zero while the raw one keeps the gravity.
    assert ext and all(abs(x) < 1e-3 for x in ext[-1])
    assert raw and raw[-1][2] == pytest.approx(PAYLOAD[0] * 9.81, abs=0.05)


def test_8006_zeroes_and_saves_and_8010_reads_the_configuration(tmp_path: Path) -> None:
    with box(config_dir=tmp_path) as st:
        st.call(lambda: st.emulator.set_payload(*PAYLOAD))
        assert "Traceback" not in run(st, "8006")
        zero = st.call(lambda: ft.compensation(st.emulator.controller))
    with box(config_dir=tmp_path) as st:  # the saved zero (register 40) comes back at power-on
        st.call(lambda: st.emulator.handle(201, b"\x01"))
        out = run(st, "8010")
    assert zero[2] == pytest.approx(PAYLOAD[0] * 9.81, abs=0.05)
    started = re.search(r"ft_is_started: (\d+)", out)
    ft_zero = re.search(r"ft_zero: (\[[^\]]*\])", out)
    assert started and ft_zero and re.search(r"ft_type: ([1-9]\d*)", out), out
    assert ast.literal_eval(ft_zero.group(1))[2] == pytest.approx(PAYLOAD[0] * 9.81, abs=0.05)
