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


def _measured(d: str, seconds: float) -> tuple[float, int, float, float, int]:
    """A session of ``seconds`` recorded and compared: (recorded s, bytes, compare s, replay s, frames)."""
    path = Path(d) / f"bench-{seconds:g}.xrec"
    elapsed = _session(path, seconds)
    t0 = time.perf_counter()
    result = compare(path)
    return (elapsed, path.stat().st_size, time.perf_counter() - t0, result.replay_seconds,
            int(result.totals["samples"]))


def run(seconds: float = SECONDS) -> list[str]:
    """Two sessions, of half the length and of the full length, compared one after the other once
    the short one has been compared once to warm this process: the 10-minute figures extrapolate
    from the full one by what the second half added (the fixed cost of a comparison, reading the
    file and starting an emulator, is not multiplied)."""
    with tempfile.TemporaryDirectory() as d:
        e1, b1, c1, _, _ = _measured(d, seconds / 2)
        t0 = time.perf_counter()
        compare(Path(d) / f"bench-{seconds / 2:g}.xrec")
        c1 = time.perf_counter() - t0
        e2, b2, c2, r2, frames = _measured(d, seconds)
    per_s_bytes, per_s_compare = (b2 - b1) / (e2 - e1), max(0.0, c2 - c1) / (e2 - e1)
    size10 = b2 + per_s_bytes * (TEN_MINUTES - e2)
    compare10 = c2 + per_s_compare * (TEN_MINUTES - e2)
    return [f"{e2:.1f} s recorded: {b2 / 1e6:.2f} MB, {frames} real-time frames, "
            f"compare {c2:.2f} s (replay {r2:.2f} s); {e1:.1f} s recorded: compare {c1:.2f} s",
            f"10 minutes extrapolated: {size10 / 1e6:.1f} MB (target < 50), "
            f"compare {compare10:.1f} s (target < 30)"]


if __name__ == "__main__":
    for line in run():
        print(line)
