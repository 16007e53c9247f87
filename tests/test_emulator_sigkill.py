"""SIGKILL during save_conf: an emulator process that saves its configuration in a loop is
killed at random moments; every time, a fresh emulator loads one whole generation of values."""

from __future__ import annotations

import os
import random
import subprocess
import sys
from pathlib import Path

from xarm_emu.controller.emulator import Emulator

WRITER = r"""
import os, signal, struct, sys, time
from xarm_emu.controller.emulator import Emulator
from xarm_emu.protocol.registers import REGISTERS

def write(config_dir):
    emu = Emulator(6, config_dir=config_dir)
    def call(code, **v):
        emu.handle(code, REGISTERS[code].request.encode(v))
    k = 0
    while True:
        k += 1
        # one generation: every value derives from k, so a mix of two generations is detectable
        call(35, pose=(0.0, 0.0, float(k), 0.0, 0.0, 0.0))
        call(36, mass=float(k % 5), center=(0.0, 0.0, float(k)))
        call(37, sensitivity=k % 6)
        call(31, jerk=float(1000 + k % 9000))
        call(40)

print("ready", flush=True)
for line in sys.stdin:  # one round per line: a writer process killed after the given seconds
    pid = os.fork()
    if pid == 0:
        write(sys.argv[1])
    time.sleep(float(line))
    os.kill(pid, signal.SIGKILL)
    os.waitpid(pid, 0)
    print("killed", flush=True)
"""


def test_sigkill_mid_save_never_leaves_a_broken_or_mixed_configuration(tmp_path: Path) -> None:
    """Each round a fresh process (forked from one that has loaded the emulator's code) saves in a
    loop and is killed with SIGKILL at a random moment; then a fresh emulator loads the files."""
    rng = random.Random(7)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    last = 0
    loaded = 0
    proc = subprocess.Popen([sys.executable, "-c", WRITER, str(tmp_path)], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, env=env)
    assert proc.stdin is not None and proc.stdout is not None
    try:
        assert proc.stdout.readline().strip() == b"ready"
        for _ in range(30):
            proc.stdin.write(f"{rng.uniform(0.02, 0.12)}\n".encode())
            proc.stdin.flush()
            assert proc.stdout.readline().strip() == b"killed"
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
    finally:
        proc.kill()
        proc.wait()
        proc.stdin.close()
        proc.stdout.close()
    assert loaded >= 10 and last > 0
    assert not any(".corrupt" in p.name for p in tmp_path.iterdir())
