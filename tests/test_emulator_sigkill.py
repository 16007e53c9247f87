"""SIGKILL during save_conf: an emulator process that saves its configuration in a loop is
killed at random moments; every time, a fresh emulator loads one whole generation of values."""

from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

from xarm_emu.controller.emulator import Emulator

WRITER = r"""
import struct, sys
from xarm_emu.controller.emulator import Emulator
from xarm_emu.protocol.registers import REGISTERS
emu = Emulator(6, config_dir=sys.argv[1])
def call(code, **v):
    emu.handle(code, REGISTERS[code].request.encode(v))
k = 0
print("ready", flush=True)
while True:
    k += 1
    # one generation: every value derives from k, so a mix of two generations is detectable
    call(35, pose=(0.0, 0.0, float(k), 0.0, 0.0, 0.0))
    call(36, mass=float(k % 5), center=(0.0, 0.0, float(k)))
    call(37, sensitivity=k % 6)
    call(31, jerk=float(1000 + k % 9000))
    call(40)
"""


def test_sigkill_mid_save_never_leaves_a_broken_or_mixed_configuration(tmp_path: Path) -> None:
    rng = random.Random(7)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    last = 0
    loaded = 0
    for _ in range(30):
        proc = subprocess.Popen([sys.executable, "-c", WRITER, str(tmp_path)], stdout=subprocess.PIPE,
                                env=env)
        assert proc.stdout is not None
        assert proc.stdout.readline().strip() == b"ready"
        time.sleep(rng.uniform(0.0, 0.05))
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        proc.stdout.close()
        emu = Emulator(6, config_dir=tmp_path)
        assert emu.config_message is None, emu.config_message
        s = emu.controller.settings
        k = round(s.tcp_offset[2])
        if k == 0:
            continue  # killed before the first save completed
        loaded += 1
        assert s.tcp_load == [float(k % 5), 0.0, 0.0, float(k)]
        assert s.collision_sensitivity == k % 6
        assert s.tcp_jerk == float(1000 + k % 9000)
        assert k >= 1
        last = k
    assert loaded >= 10 and last > 0
    assert not any(".corrupt" in p.name for p in tmp_path.iterdir())
