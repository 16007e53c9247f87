"""Jerk-limited one-dimensional motion profiles (manual 1.3, Table 1.2: speed,
acceleration and jerk limits of TCP and joint motion).

A profile is a chain of constant-jerk segments. :class:`SCurve` is the
time-optimal 7-segment rest-to-rest profile over a distance;
:class:`MovingProfile` goes from a moving state to rest at a distance.

``sample_many(ts)`` samples an array of times at once (numpy, ``np.searchsorted``
on the segment starts) with the arithmetic of ``sample``: the same numbers, bit
for bit.
"""

from __future__ import annotations

import math
from bisect import bisect_right
from collections.abc import Sequence

import numpy as np

_EPS = 1e-12


class JerkProfile:
    """Piecewise constant-jerk motion from ``(s=0, v0, a0)``.

    ``segments`` are ``(duration, jerk)`` pairs. ``sample(t)`` returns
    ``(s, v, a)``; before 0 it returns the start state (position 0), after the
    end the final position with ``v`` and ``a`` of the final state.
    """

    __slots__ = ("duration", "distance", "_t", "_s", "_v", "_a", "_j", "_end", "_starts", "_table")

    def __init__(self, segments: Sequence[tuple[float, float]], v0: float = 0.0, a0: float = 0.0,
                 end: tuple[float, float, float] | None = None) -> None:
        t = s = 0.0
        v, a = v0, a0
        self._t: list[float] = []
        self._s: list[float] = []
        self._v: list[float] = []
        self._a: list[float] = []
        self._j: list[float] = []
        for dt, j in segments:
            if dt <= 0.0:
                continue
            self._t.append(t)
            self._s.append(s)
            self._v.append(v)
            self._a.append(a)
            self._j.append(j)
            s += dt * (v + dt * (a / 2.0 + dt * j / 6.0))
            v += dt * (a + dt * j / 2.0)
            a += dt * j
            t += dt
        self.duration = t
        #: Final state; an exact ``end`` replaces the integrated one (no round-off at arrival).
        self._end = end if end is not None else (s, v, a)
        self.distance = self._end[0]
        if not self._t:
            self._t.append(0.0)
            self._s.append(0.0)
            self._v.append(v0)
            self._a.append(a0)
            self._j.append(0.0)
        # sample_many: searchsorted on the segment starts after the first gives the segment index, and
        # on the duration after them the final state (one more column, started at the duration).
        self._starts = np.array([*self._t[1:], t])
        end_s, end_v, end_a = self._end
        self._table = _segment_table([*self._s, end_s], [*self._v, end_v], [*self._a, end_a],
                                     [*self._j, 0.0], [*self._t, t])

    @property
    def start(self) -> tuple[float, float]:
        """Initial ``(v, a)``."""
        return self._v[0], self._a[0]

    def sample(self, t: float) -> tuple[float, float, float]:
        """``(s, v, a)`` at time ``t`` (clamped to ``[0, duration]``)."""
        if t >= self.duration:
            return self._end
        if t <= 0.0:
            return 0.0, self._v[0], self._a[0]
        i = bisect_right(self._t, t) - 1
        dt = t - self._t[i]
        v, a, j = self._v[i], self._a[i], self._j[i]
        return (self._s[i] + dt * (v + dt * (a / 2.0 + dt * j / 6.0)),
                v + dt * (a + dt * j / 2.0),
                a + dt * j)

    def sample_many(self, ts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`sample` of each entry of ``ts`` (N,): ``s``, ``v`` and ``a`` as three (N,) arrays."""
        # Times clamped to [0, duration]: at 0 the first segment's start state (0, v0, a0), at the
        # duration the final state, both from a step of exactly 0 (which adds a zero to each).
        t = np.minimum(np.maximum(ts, 0.0), self.duration)
        rows = self._table.take(np.searchsorted(self._starts, t, side="right"), axis=1)
        return _integrate(t - rows[_T0], rows)


#: Rows of a segment table (:func:`_segment_table`).
_S0, _T0, _A, _J = 0, 1, 3, 6
_HALF_A_AND_A, _V_TWICE = slice(2, 4), slice(4, 6)
_DIVISORS = np.array((6.0, 2.0))[:, None]


def _segment_table(s: Sequence[float], v: Sequence[float], a: Sequence[float], j: Sequence[float],
                   t: Sequence[float]) -> np.ndarray:
    """Constant-jerk segments as columns: start position, start time, ``a / 2``, ``a``, ``v``, ``v``,
    jerk (the rows :func:`_integrate` takes its terms from)."""
    return np.array([s, t, [x / 2.0 for x in a], a, v, v, j], dtype=float)


def _integrate(dt: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Position, speed and acceleration ``dt`` into the constant-jerk segments of ``rows`` (columns of
    a segment table): ``s + dt (v + dt (a / 2 + dt j / 6))``, ``v + dt (a + dt j / 2)``, ``a + dt j``,
    each operation as :meth:`JerkProfile.sample` (and ruckig's integration) does it; the two Horner
    forms side by side as the rows of one array."""
    dj = dt * rows[_J]
    inner = rows[_V_TWICE] + dt * (rows[_HALF_A_AND_A] + dj / _DIVISORS)
    return rows[_S0] + dt * inner[0], inner[1], rows[_A] + dj


def _accel_phase(v: float, amax: float, jmax: float) -> tuple[float, float]:
    """Time at the jerk limit and total time to go from rest to speed ``v``."""
    if v * jmax >= amax * amax:
        tj = amax / jmax
        return tj, v / amax + tj
    tj = math.sqrt(v / jmax)
    return tj, 2.0 * tj


class PlanningError(RuntimeError):
    """No trajectory for the given state and limits (the controller raises C25, planning error)."""


def _check_limits(vmax: float, amax: float, jmax: float) -> None:
    for name, x in (("vmax", vmax), ("amax", amax), ("jmax", jmax)):
        if not (x > 0.0 and math.isfinite(x)):
            raise ValueError(f"{name} must be positive and finite, got {x!r}")


class SCurve(JerkProfile):
    """Time-optimal rest-to-rest 7-segment S-curve over ``distance``.

    Segments: jerk up, constant acceleration, jerk down, cruise, and the mirror
    image. When ``distance`` is too short to reach ``vmax`` the peak speed is
    lowered (and when it is too short to reach ``amax``, the constant
    acceleration phases vanish), which is the minimum-time profile for the
    given limits. A negative distance runs backwards (``s`` goes from 0 to
    ``distance``). For a long move ``duration = d/v + v/a + a/j``.
    """

    __slots__ = ("vpeak", "apeak", "vmax", "amax", "jmax")

    def __init__(self, distance: float, vmax: float, amax: float, jmax: float) -> None:
        _check_limits(vmax, amax, jmax)
        if not math.isfinite(distance):
            raise ValueError(f"distance must be finite, got {distance!r}")
        self.vmax, self.amax, self.jmax = vmax, amax, jmax
        sign = 1.0 if distance >= 0.0 else -1.0
        d = abs(distance)
        if d <= _EPS:
            self.vpeak = self.apeak = 0.0
            super().__init__([], end=(distance, 0.0, 0.0))
            return
        tj, ta = _accel_phase(vmax, amax, jmax)
        if d >= vmax * ta:  # vmax is reached: cruise for the rest
            vp, tv = vmax, (d - vmax * ta) / vmax
        else:
            tv = 0.0
            # Peak speed with amax reached: vp^2/a + vp*a/j = d.
            vp = 0.5 * (-amax * amax / jmax + math.sqrt((amax * amax / jmax) ** 2 + 4.0 * amax * d))
            if vp * jmax < amax * amax:  # amax not reached either: d = 2 vp^1.5 / sqrt(j)
                vp = (0.5 * d * math.sqrt(jmax)) ** (2.0 / 3.0)
            tj, ta = _accel_phase(vp, amax, jmax)
        self.vpeak = vp
        self.apeak = tj * jmax
        tc = ta - 2.0 * tj
        j = sign * jmax
        segs = [(tj, j), (tc, 0.0), (tj, -j), (tv, 0.0), (tj, -j), (tc, 0.0), (tj, j)]
        super().__init__(segs, end=(distance, 0.0, 0.0))


class MovingProfile:
    """Jerk-limited profile from a moving state ``(s=0, v0, a0)`` to rest at ``distance``.

    Used when a blended move arrives while the arm already moves (register 22): the remaining path is
    re-planned from the current path speed and acceleration without stopping. Solved time-optimally
    by ruckig (offline, one degree of freedom); same interface as :class:`JerkProfile`.
    """

    __slots__ = ("duration", "distance", "_traj", "_end", "_tables", "_inputs")

    def __init__(self, distance: float, v0: float, a0: float, vmax: float, amax: float, jmax: float) -> None:
        from ruckig import InputParameter, Result, Ruckig, RuckigError, Trajectory

        self._inputs = (distance, v0, a0, vmax, amax, jmax)
        _check_limits(vmax, amax, jmax)
        inp = InputParameter(1)
        inp.current_position = [0.0]
        inp.current_velocity = [v0]
        inp.current_acceleration = [a0]
        inp.target_position = [distance]
        inp.target_velocity = [0.0]
        inp.target_acceleration = [0.0]
        inp.max_velocity = [max(vmax, abs(v0))]
        inp.max_acceleration = [max(amax, abs(a0))]
        inp.max_jerk = [jmax]
        traj = Trajectory(1)
        try:
            result = Ruckig(1).calculate(inp, traj)
        except (RuckigError, ValueError) as exc:  # ValueError: a result code the binding does not name
            raise PlanningError(f"ruckig: {exc}".strip()) from exc
        if result not in (Result.Working, Result.Finished):
            raise PlanningError("no jerk-limited profile from this moving state")
        self._traj = traj
        self.duration = float(traj.duration)
        self.distance = distance
        self._end = (distance, 0.0, 0.0)
        self._tables: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None

    def __reduce__(self) -> tuple[object, tuple[object, ...]]:
        """Copied and saved as the inputs it was planned from, planned again when loaded (a ruckig
        trajectory is not data; planning the same inputs gives the same trajectory)."""
        return MovingProfile, self._inputs

    def sample(self, t: float) -> tuple[float, float, float]:
        """``(s, v, a)`` at time ``t`` (clamped to ``[0, duration]``)."""
        if t >= self.duration:
            return self._end
        p, v, a = self._traj.at_time(max(t, 0.0))
        return float(p[0]), float(v[0]), float(a[0])

    def _segment_tables(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The trajectory's segments as ruckig's ``Trajectory.at_time`` samples them (one section):
        the brake pre-trajectory's duration and the start of its second segment, its two segments,
        the profile's partial sums of segment times (ruckig's, in its order), and its seven segments
        with the constant-acceleration tail after them (a segment table each)."""
        if self._tables is None:
            prof = self._traj.profiles[0][0]
            brake = prof.brake
            t_sum: list[float] = []
            for k, dt in enumerate(prof.t):
                t_sum.append(dt if k == 0 else t_sum[-1] + dt)
            brake_t0 = float(brake.t[0])
            brake_rows = _segment_table(brake.p, brake.v, brake.a, brake.j, [0.0, brake_t0])
            # The tail (column 7) starts where the last segment ends.
            rows = _segment_table(prof.p, prof.v, prof.a, [*prof.j, 0.0], [0.0, *t_sum])
            self._tables = (np.array([float(brake.duration), brake_t0]), brake_rows, np.array(t_sum), rows)
        return self._tables

    def sample_many(self, ts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`sample` of each entry of ``ts`` (N,): ``s``, ``v`` and ``a`` as three (N,) arrays."""
        (brake_duration, brake_t0), brake_rows, t_sum, table = self._segment_tables()
        t = np.maximum(ts, 0.0)
        td = t - brake_duration if brake_duration > 0.0 else t
        # upper_bound on the partial sums: the segment; at or past the last sum, the tail with the
        # time after that sum (every partial sum but the last is a segment start, as in ruckig).
        rows = table.take(np.searchsorted(t_sum, td, side="right"), axis=1)
        dt = td - rows[_T0]
        if brake_duration > 0.0:
            braking = t < brake_duration
            if np.count_nonzero(braking):
                tb = t[braking]
                second = (tb >= brake_t0).astype(np.intp)
                brows = brake_rows.take(second, axis=1)
                dt[braking] = np.where(second, tb - brows[_T0], tb)
                rows[:, braking] = brows
        s, v, a = _integrate(dt, rows)
        end = ts >= self.duration
        if np.count_nonzero(end):
            s[end], v[end], a[end] = self._end
        return s, v, a
