"""The jump over idle control periods: what ``Emulator.step`` runs instead of periods in which
nothing but the clock would change.

With the controller at rest (``Controller.at_rest``) and every component idle
(:func:`~.interface.idle_until`), a control period changes the time and the period count, a running
dwell's path time (register 26) and, every :data:`~.thermal.THERMAL_EVERY` periods, the joint
temperatures, nothing else. :func:`jump` takes such periods by arithmetic: the controller time (and
a dwell's path time) summed period by period, as a step sums it (the same additions in the same
order), and the thermal steps due among them with the currents of the
arm at rest, so every value comes out bit for bit as if the periods had run
(``tests/test_clock_exact.py``). :func:`tick` is the same sum for a call whose periods all come
before the box's next event (``Emulator.next_event``).

One walk goes over the periods skipped, :data:`CHUNK` of them at a time: the sums of a chunk, then
the first of them that meets the horizon (a component's time, a scheduled action, the dwell's end)
found by bisection, since the sums only grow. Speed: a chunk of :data:`NUMPY_FROM` periods or more
is summed by numpy, a shorter one in Python (:func:`_sums`), as numpy's call costs more than a few
dozen additions.
"""

from __future__ import annotations

import math
from bisect import bisect_left
from collections.abc import Callable, Sequence
from itertools import accumulate, repeat

import numpy as np

from .controller_protocol import Controller
from .controller_state import ControllerState
from .interface import idle_until
from .thermal import THERMAL_EVERY, ThermalModel

#: Periods summed at once by :func:`jump` (the sums of a longer jump are made a chunk at a time, so a
#: jump that ends early sums at most one chunk more than the periods it took).
CHUNK = 1024

#: Chunks of at least this many periods are summed by numpy, shorter ones in Python (:func:`_sums`).
NUMPY_FROM = 64

#: How much before a scheduled action's time a period counts as reaching it (``Emulator.at``: the
#: action runs after the first period that ends at or after its time, less this).
SCHEDULE_SLACK = 1e-9


def tick(data: ControllerState, dt: float, n: int) -> None:
    """Run ``n`` control periods of length ``dt`` in which nothing changes but the clock: the time
    summed period by period, as a step sums it (a loop of additions: for the few periods between a
    reader's frames it costs less than :func:`_sums`, 1.8 us against 2.2 us for a step(25) at rest)."""
    t = data.time
    for _ in range(n):
        t += dt
    data.time = t
    data.steps += n


def _sums(start: float, step: float, m: int) -> Sequence[float]:
    """``start`` and the ``m`` values after it, ``step`` added one at a time as period after period
    adds it: by numpy's accumulation (which adds in order) from :data:`NUMPY_FROM` values, below
    that in Python, whose call costs less than numpy's for so few."""
    if m < NUMPY_FROM:
        return list(accumulate(repeat(step, m), initial=start))
    a = np.full(m + 1, step)
    a[0] = start
    return np.add.accumulate(a, out=a)  # type: ignore[return-value]  # an array of floats


def jump(ctl: Controller, thermal: ThermalModel, due: float, most: int,
         rest_currents: Callable[[], np.ndarray]) -> int:
    """Jump over at most ``most`` control periods of the controller ``ctl`` at rest, each one before
    every component's :func:`~.interface.idle_until`, before the scheduled action at time ``due``
    (``math.inf``: none) and, for a running dwell, before the dwell's last period; returns the number
    of periods jumped. ``rest_currents()`` gives the joint currents (absolute) of the arm at rest,
    asked for only when a thermal step falls due."""
    d = ctl.data
    dt = ctl.period
    t = d.time
    horizon = min((idle_until(c, ctl) for c in ctl.components), default=math.inf)
    if not (t + dt < horizon and due > t + dt + SCHEDULE_SLACK):
        return 0  # the first period meets the horizon or a scheduled action
    plan = d.motion
    path_t, path_dt, end = plan.t, 0.0, math.inf  # a running dwell's path time, its step and end
    if plan.plan is not None and (rate := ctl.executor.dwell_rate(d.q)) is not None:
        path_dt, end = dt * rate, plan.plan.duration
    k = 0
    while k < most:
        m = min(most - k, CHUNK)
        times = _sums(t, dt, m)  # times[i]: the time after i periods of the chunk
        taken = bisect_left(times, horizon, 1) - 1
        if due < math.inf:
            taken = min(taken, bisect_left(times, due, 1, key=lambda x: x + SCHEDULE_SLACK) - 1)
        if end < math.inf:
            paths = _sums(path_t, path_dt, m)
            taken = min(taken, bisect_left(paths, end, 1) - 1)
            path_t = float(paths[taken])
        t = float(times[taken])
        k += taken
        if taken < m:
            break
    _thermal_steps(thermal, d.steps, k, dt, rest_currents)
    d.time, d.steps = t, d.steps + k
    if end < math.inf:
        plan.t = path_t
    return k


def _thermal_steps(thermal: ThermalModel, steps: int, k: int, dt: float,
                   rest_currents: Callable[[], np.ndarray]) -> None:
    """The thermal steps (one every :data:`~.thermal.THERMAL_EVERY` periods, as ``Emulator.step``
    takes them) due in the ``k`` periods after period ``steps``, with the currents of the arm at
    rest: the temperatures do not depend on the clock, only on how many steps were taken."""
    for _ in range((steps + k) // THERMAL_EVERY - steps // THERMAL_EVERY):
        thermal.step(THERMAL_EVERY * dt, rest_currents())
