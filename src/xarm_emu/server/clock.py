"""Clocks that drive the controller: real time, scaled time and stepped time.

- real time: one control period of controller time per period of wall time;
- scaled time (``speed``): ``speed`` periods of controller time per period of wall
  time (10 runs ten times faster than the wall clock, 0.1 ten times slower);
- stepped time: nothing advances unless the owner calls ``step()`` (tests, lockstep).
"""

from __future__ import annotations

import asyncio
import contextlib
import heapq
import math
import time
from dataclasses import dataclass
from typing import Any


@dataclass
class ScaledClock:
    """Converts wall time to the number of controller steps that are due."""

    period: float
    speed: float = 1.0
    _wall0: float | None = None
    _steps: int = 0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.speed) and self.speed > 0.0):
            raise ValueError("speed must be a positive number")

    def start(self, wall: float) -> None:
        self._wall0 = wall
        self._steps = 0

    def due(self, wall: float, limit: int | None = None) -> int:
        """Steps to run now to catch up with ``wall``; at most ``limit`` (the rest stays due, so a
        machine too slow for the requested speed runs slower instead of stalling in one burst)."""
        if self._wall0 is None:
            self.start(wall)
        assert self._wall0 is not None
        target = int((wall - self._wall0) * self.speed / self.period)
        n = max(0, target - self._steps)
        if limit is not None:
            n = min(n, limit)
        self._steps += n
        return n

    def next_wall(self) -> float:
        """Wall time at which the next step falls due."""
        assert self._wall0 is not None
        return self._wall0 + (self._steps + 1) * self.period / self.speed


class Ticker:
    """Wakes coroutines at precise wall times (``time.perf_counter``) from a helper thread.

    Event-loop timers have millisecond resolution (asyncio rounds epoll timeouts up, uvloop's libuv
    timers truncate and fire early), which alone makes a 100 Hz report jitter by up to 1 ms. A thread
    sleeping with ``time.sleep`` wakes within tens of microseconds and hands the wake-up to the loop.
    """

    def __init__(self) -> None:
        import threading

        self._cond = threading.Condition()
        self._heap: list[tuple[float, int, Any]] = []
        self._seq = 0
        self._stop = False
        self._thread = threading.Thread(target=self._run, name="xarm-emu-ticker", daemon=True)
        self._thread.start()

    def wait_until(self, deadline: float) -> asyncio.Future[None]:
        """A future of the running loop that completes at ``deadline`` (perf_counter seconds)."""
        loop = asyncio.get_running_loop()
        fut: asyncio.Future[None] = loop.create_future()
        with self._cond:
            self._seq += 1
            heapq.heappush(self._heap, (deadline, self._seq, (loop, fut)))
            self._cond.notify()
        return fut

    def _run(self) -> None:
        cond = self._cond
        while True:
            with cond:
                while not self._stop and not self._heap:
                    cond.wait()
                if self._stop:
                    return
                deadline = self._heap[0][0]
                delay = deadline - time.perf_counter()
                if delay > 0.002:  # long waits on the condition (a new, earlier deadline wakes us)
                    cond.wait(delay - 0.001)
                    continue
                if delay > 0:
                    due = None
                else:
                    _, _, due = heapq.heappop(self._heap)
            if due is None:
                time.sleep(delay)  # short, precise sleep outside the lock
                continue
            loop, fut = due
            with contextlib.suppress(RuntimeError):  # loop closed meanwhile
                loop.call_soon_threadsafe(_resolve, fut)

    def close(self) -> None:
        with self._cond:
            self._stop = True
            self._cond.notify()
        self._thread.join(2)


def _resolve(fut: asyncio.Future[None]) -> None:
    if not fut.done():
        fut.set_result(None)
