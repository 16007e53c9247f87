"""A process that planned online (modes 6/7), velocity moves (mode 4) and read the standard Modbus
map exits without noise: no leak report from ruckig's bindings, nothing on stderr. An emulator the
program dropped is freed (a ruckig trajectory alive at exit is what the bindings report)."""

from __future__ import annotations

import subprocess
import sys
import textwrap

SCRIPT = textwrap.dedent("""
    import gc, struct, tempfile, weakref
    from pathlib import Path
    from xarm_emu.controller.emulator import Emulator
    from xarm_emu.controller.modbus_map import answer

    for mode in (4, 6, 7):
        emu = Emulator(6, config_dir=Path(tempfile.mkdtemp()), firmware="2.7.103")
        emu.handle(11, bytes([8, 1]))
        answer(emu, 1, 1, struct.pack(">BHH", 0x06, 32, mode))  # the mode through holding 32
        emu.handle(12, bytes([0]))
        if mode == 4:
            emu.handle(81, struct.pack("<7fB", 0.1, 0, 0, 0, 0, 0, 0, 0))
        elif mode == 6:
            emu.handle(23, struct.pack("<7f3f", 0.3, 0, 0, 0, 0, 0, 0, 1.0, 10.0, 0.0))
        else:
            emu.handle(21, struct.pack("<6f3f", 220.0, 0, 400.0, 3.14159, 0, 0, 50.0, 500.0, 0.0))
        emu.advance(0.2)
        assert emu.controller.mode == mode, emu.controller.mode
        gone = weakref.ref(emu)
        del emu  # a server that ended: nothing may keep its emulator (and its trajectories) alive
        gc.collect()
        assert gone() is None, f"the emulator of mode {mode} outlives its last reference"
    print("ok")
""")


def test_no_noise_at_exit(tmp_path):
    done = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True, timeout=120,
                          cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "ok"
    assert "leaked" not in done.stderr and "nanobind" not in done.stderr, done.stderr[-2000:]
    assert done.stderr == ""
