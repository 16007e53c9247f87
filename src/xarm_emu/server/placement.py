"""Where a recorded request can have been answered on the box's clock, from what the recording shows.

The real-time report (port 30000, manual 2.1.6 and firmware 2.x) carries a frame for every control
period, stamped with the box's clock. The proxy's clock orders a request, its reply and the frames:

- a frame the proxy received before the request was made before the box had the request, so it
  shows the state before the request's effect: the request was answered no earlier than its stamp;
- a frame received after the reply was, as a rule, made after the request was answered; but the box
  writes its report and its reply on separate connections and the proxy may read the reply first, so
  a frame that came right after the reply may still show the state before (:data:`SLACK_FRAMES`).

A request's place is a *slot*, the index of the first frame that shows its effect, and a controller
time ``t`` between the stamps of the frames either side of the slot (a request answered at the very
period a frame is stamped with may come before or after that frame is made). :func:`windows` gives
each request's slots; :func:`candidates` the places they leave open, which ``compare`` tells apart by
the frames that follow (:mod:`xarm_emu.fidelity.compare`). Without real-time frames the places are
left to the proxy's clock (``compare`` says so per command).

Both ``compare`` and ``xarm-emu replay`` (:mod:`xarm_emu.replay`) re-run what they re-run by
:func:`run_to`: the stepped emulator run up to the controller time (or after the control period) a
request or an outside change was placed at, in whole periods, never back.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..controller.core.interface import PERIOD

#: Frames received after a reply that may still have been made before the request was answered, when
#: the first of them came within ``SLACK_SECONDS`` of the reply (the box wrote it before the reply and
#: the proxy read the reply's connection first; one that came later was made after).
SLACK_FRAMES, SLACK_SECONDS = 1, PERIOD / 2
#: The most places listed for one request (a box starved of its processor sends no frames for a
#: while, so a window can be long), and the most tried: those nearest the proxy clock's estimate.
MAX_CANDIDATES, MAX_TRIED = 2000, 20


@dataclass(frozen=True)
class Window:
    """The real-time frames around one request: ``first`` is the first frame received after the
    request (no earlier frame can show it), ``last`` the last slot its reply leaves open (frame
    ``last`` is the first that surely shows it; ``len(frames)`` when none does)."""

    first: int
    last: int


def windows(recv: np.ndarray, requests: list[tuple[float, float | None]]) -> list[Window]:
    """The :class:`Window` of each ``(request time, reply time or None)`` on the proxy's clock, among
    real-time frames received at proxy times ``recv`` (ascending)."""
    times = recv.tolist()
    n = len(times)
    out = []
    for req_t, rep_t in requests:
        first = bisect.bisect_right(times, req_t)
        if rep_t is None:
            last = n
        else:
            last = bisect.bisect_right(times, rep_t)
            if last < n and times[last] - rep_t <= SLACK_SECONDS:  # read with the reply: maybe made before
                last = min(n, last + SLACK_FRAMES)
        out.append(Window(first, max(first, last)))
    return out


def nearest(cands: list[tuple[float, int]], estimates: tuple[float, ...]) -> list[tuple[float, int]]:
    """The :data:`MAX_TRIED` places of ``cands`` nearest any of the controller times ``estimates``
    (the proxy clock's for the request and for its reply: a box starved of the processor answers
    late, at the period it resumed in), in order."""
    if len(cands) <= MAX_TRIED:
        return cands
    keep = sorted(range(len(cands)), key=lambda n: (min(abs(cands[n][0] - e) for e in estimates), n))
    return [cands[n] for n in sorted(keep[:MAX_TRIED])]


def candidates(ts: np.ndarray, window: Window, after: tuple[float, int]) -> list[tuple[float, int]]:
    """The places ``(controller time, slot)`` a request of ``window`` can have been answered at, on
    the control-period grid, no earlier than ``after`` (the place of the request before it), among
    frames stamped ``ts``: for slot ``s``, every period from frame ``s - 1``'s stamp to frame
    ``s``'s (a frame stamped with the request's period may be made before or after it is answered).
    At most :data:`MAX_CANDIDATES`, the earliest first."""
    n = len(ts)
    t_prev, s_prev = after
    out: list[tuple[float, int]] = []
    for s in range(max(window.first, s_prev), window.last + 1):
        lo = float(ts[s - 1]) if s > 0 else (float(ts[0]) if n else t_prev)
        hi = float(ts[s]) if s < n else lo
        lo = max(lo, t_prev)
        if hi < lo - 1e-9:
            continue
        steps = int(round((hi - lo) / PERIOD))
        for k in range(steps + 1):
            out.append((lo + k * PERIOD if k < steps else hi, s))
            if len(out) == MAX_CANDIDATES:
                return out
    if not out:  # the request before it was placed later than the frames allow: right after it
        out.append((t_prev, max(s_prev, window.first)))
    return out


def undecided(lo: float, hi: float) -> bool:
    """Whether a window of controller times ``lo``..``hi`` leaves more than one control period open."""
    return not math.isfinite(hi) or hi - lo > PERIOD + 1e-9


def run_to(server: Any, t: float, period: int | None = None) -> None:
    """Run ``server``'s emulator (stepped, :meth:`~xarm_emu.server.core.EmulatorServer.advance`) up
    to where a request or a change is placed: after control ``period`` when given (a trace's
    ``outside`` line), else up to controller time ``t``, in whole periods. Never back: a place at or
    before the emulator's time is now."""
    emu = server.emulator
    if period is not None:
        n = int(period) - int(emu.controller.data.steps)
        if n > 0:
            server.advance(n * emu.controller.period)
    elif t > emu.time + 1e-9:
        server.advance(t - emu.time)
