"""Clocks that drive the controller: real time, scaled time and stepped time.

- real time: one control period of controller time per period of wall time;
- scaled time (``speed``): ``speed`` periods of controller time per period of wall
  time (10 runs ten times faster than the wall clock, 0.1 ten times slower);
- stepped time: nothing advances unless the owner calls ``step()`` (tests, lockstep).

Report frames keep wall time on their own schedule (:mod:`.report_sender`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

#: Seconds short of the next step's wall time within which :meth:`ScaledClock.due` computes in full.
QUIET_MARGIN = 1e-6


@dataclass
class ScaledClock:
    """Converts wall time to the number of controller steps that are due."""

    period: float
    speed: float = 1.0
    _wall0: float | None = None
    _steps: int = 0
    #: Wall time before which no step can fall due (a margin short of :meth:`next_wall`, far wider
    #: than the rounding of its arithmetic): most calls of :meth:`due` compare once, and a caller may
    #: compare itself before calling.
    quiet_until: float = -math.inf

    def __post_init__(self) -> None:
        if not (math.isfinite(self.speed) and self.speed > 0.0):
            raise ValueError("speed must be a positive number")

    def start(self, wall: float) -> None:
        self._wall0 = wall
        self._steps = 0
        self.quiet_until = -math.inf

    def due(self, wall: float, limit: int | None = None) -> int:
        """Steps to run now to catch up with ``wall``; at most ``limit`` (the rest stays due, so a
        machine too slow for the requested speed runs slower instead of stalling in one burst)."""
        if wall < self.quiet_until:
            return 0
        if self._wall0 is None:
            self.start(wall)
        assert self._wall0 is not None
        target = int((wall - self._wall0) * self.speed / self.period)
        n = max(0, target - self._steps)
        if limit is not None:
            n = min(n, limit)
        self._steps += n
        self.quiet_until = self.next_wall() - QUIET_MARGIN
        return n

    @property
    def steps(self) -> int:
        """Steps run (or handed out by :meth:`due`) since :meth:`start`."""
        return self._steps

    def steps_at(self, wall: float) -> int:
        """Steps due by ``wall`` since :meth:`start`: the control period of that instant."""
        assert self._wall0 is not None
        return int((wall - self._wall0) * self.speed / self.period)

    def next_wall(self) -> float:
        """Wall time at which the next step falls due."""
        return self.wall_after(0)

    def wall_after(self, k: float) -> float:
        """Wall time at which the step after the next ``k`` falls due (``k`` may be ``math.inf``)."""
        assert self._wall0 is not None
        if k == math.inf:
            return math.inf
        return self._wall0 + (self._steps + k + 1) * self.period / self.speed
