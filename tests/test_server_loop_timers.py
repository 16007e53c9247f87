"""What keeps time while the command port serves: the control loop's naps are ended by the
process's report sender thread (``ReportSender.wake_at``), and a connection's frame timer runs only
while its first frame, or the rest of one, is awaited. So a standard event loop serving whole frames
holds no timer (each pending timer costs every turn of the loop a timeout and the kernel a timer),
and controller time still keeps up with the wall clock while nobody asks."""

from __future__ import annotations

import asyncio
import threading
import time

from helpers import connect, recv_frame

from xarm_emu.controller.emulator import Emulator
from xarm_emu.protocol.frame import encode_request
from xarm_emu.server import report_sender
from xarm_emu.server.app import ServerThread
from xarm_emu.server.core import IDLE_WAKE, ServerConfig

GET_STATE = 13


def _config() -> ServerConfig:
    return ServerConfig(host="127.0.0.1", port=0, normal_port=0, rich_port=0, develop_port=0)


def _live_timers(st: ServerThread) -> list[asyncio.TimerHandle]:
    """The timers pending on the server's standard event loop (its heap of scheduled calls)."""
    async def look() -> list[asyncio.TimerHandle]:
        return [h for h in st.loop._scheduled if not h.cancelled()]  # type: ignore[attr-defined]

    return asyncio.run_coroutine_threadsafe(look(), st.loop).result(5)


def test_a_loop_serving_whole_frames_holds_no_timer() -> None:
    with ServerThread(Emulator(6), _config()) as st, connect(st.ports["command"]) as s:
        time.sleep(0.1)
        assert len(_live_timers(st)) == 1  # the first frame is awaited (serve --frame-timeout)
        for tid in range(1, 4):
            s.sendall(encode_request(tid, GET_STATE))
            recv_frame(s)
        time.sleep(3 * IDLE_WAKE)  # the control loop has napped (and been woken) since
        assert _live_timers(st) == []


def test_controller_time_keeps_up_while_a_client_is_connected_and_silent() -> None:
    """With a command client connected the control loop wakes every IDLE_WAKE (20 ms) to run the
    due control periods; here nobody asks, so only those wake-ups advance the controller."""
    with ServerThread(Emulator(6), _config()) as st, connect(st.ports["command"]) as s:
        s.sendall(encode_request(1, GET_STATE))
        recv_frame(s)
        server = st.server
        ctl = server.emulator.controller
        worst = 0.0
        end = time.monotonic() + 1.0
        while time.monotonic() < end:
            time.sleep(0.05)
            behind = server.clock.steps_at(time.monotonic()) - ctl.data.steps  # read, not stepped
            worst = max(worst, behind * ctl.period)
        # without the wake-ups it would be a whole second behind; a busy machine adds some delay
        assert worst < 0.3


def test_the_sender_calls_a_wake_at_its_time_unless_it_is_cancelled() -> None:
    sender = report_sender.acquire()
    try:
        fired: list[float] = []
        done = threading.Event()
        cancelled = sender.wake_at(time.perf_counter() + 0.05, lambda: fired.append(-1.0))
        t0 = time.perf_counter()

        def due() -> None:
            fired.append(time.perf_counter() - t0)
            done.set()

        sender.wake_at(t0 + 0.1, due)
        cancelled.cancel()
        assert done.wait(5)
        assert len(fired) == 1 and fired[0] >= 0.1
    finally:
        report_sender.release()
