"""A recording through ``xarm-emu proxy`` at full report rates, its size and the time ``compare`` takes
to replay it, both extrapolated to 10 minutes from a shorter session.

The session: an arm in continuous joint and linear moves (the program of the client below, always in
motion, the costly case for the replay) with a reader on every report port (30000 at 250 Hz, 30003 at
100 Hz, 30001 and 30002 at 5 Hz), the proxy in front of it. Targets: 10 minutes under 50 MB, replayed
in under 30 s. Run: ``python -m bench fidelity`` (``SECONDS`` of recording, 20 by default).
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

from xarm_emu.client import Client
from xarm_emu.fidelity.compare import compare
from xarm_emu.protocol.firmware import SERVE_VERSION
from xarm_emu.testing import reading_reports, running_emulator, running_proxy

SECONDS = 20.0
TEN_MINUTES = 600.0


def _session(path: Path, seconds: float) -> float:
    with running_emulator(firmware=SERVE_VERSION) as st, running_proxy(st, path) as px, \
            reading_reports(px, ("realtime", "develop", "normal", "rich")):
        t0 = time.perf_counter()
        with Client("127.0.0.1", px.ports["command"]) as c:
            c.get_version()
            c.motion_enable(True)
            c.set_mode(0)
            c.set_state(0)
            targets = [(0.8, -0.3, -0.2, 0.0, 0.4, 0.3, 0.0), (-0.8, 0.1, -0.6, 0.3, 0.2, -0.3, 0.0)]
            i = 0
            while time.perf_counter() - t0 < seconds:
                if c.get_cmdnum() < 2:
                    c.call(23, joints=targets[i % 2], speed=1.0, acc=5.0, mvtime=0.0)
                    i += 1
                c.get_joints()
                time.sleep(0.02)
        elapsed = time.perf_counter() - t0
    return elapsed


def run(seconds: float = SECONDS) -> list[str]:
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "bench.xrec"
        elapsed = _session(path, seconds)
        size = path.stat().st_size
        t0 = time.perf_counter()
        result = compare(path)
        replay = time.perf_counter() - t0
    scale = TEN_MINUTES / elapsed
    frames = int(result.totals["samples"])
    return [f"{elapsed:.1f} s recorded: {size / 1e6:.2f} MB, {frames} real-time frames, "
            f"compare {replay:.2f} s (replay {result.replay_seconds:.2f} s)",
            f"10 minutes extrapolated: {size * scale / 1e6:.1f} MB (target < 50), "
            f"compare {replay * scale:.1f} s (target < 30)"]


if __name__ == "__main__":
    for line in run():
        print(line)
