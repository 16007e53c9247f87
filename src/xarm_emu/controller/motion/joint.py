"""Joint-space point-to-point motion (registers 23, 24, 25; manual 2.1.3.2) with
ruckig's offline, time-optimal, jerk-limited planner: all joints arrive together.

Only ``Ruckig(dof).calculate(input, trajectory)`` is used (no control cycle,
no cloud features). Speeds in rad/s, accelerations rad/s2, jerks rad/s3
(manual 1.4, Table 1.3); a scalar limit applies to every joint.

Synchronisation is ruckig's *phase* synchronisation where possible (a move
from rest is then a straight line in joint space) and *time* synchronisation otherwise; both give the same,
minimum duration from rest.

ruckig bounds a trajectory's duration (about two hours). A slower move from rest,
which the manual does not forbid, runs as the same straight joint-space line
with one S-curve along it (:class:`StraightLine`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import numpy as np
from ruckig import InputParameter, Result, Ruckig, RuckigError, Synchronization, Trajectory

from .profile import PlanningError, SCurve

Limit = float | Sequence[float] | np.ndarray


class _Samples(Protocol):
    """What :class:`JointTrajectory` needs of a planned trajectory (ruckig's or a straight line)."""

    @property
    def duration(self) -> float: ...

    def at_time(self, t: float) -> tuple[list[float], list[float], list[float]]: ...


class StraightLine:
    """A rest-to-rest move along the joint-space line from ``q0`` to ``q1``: one S-curve of the line
    parameter, scaled so that no joint exceeds its limits. That is the path and timing of a
    phase-synchronised move from rest; used where ruckig refuses the duration.
    """

    __slots__ = ("duration", "_q0", "_dq", "_curve")

    def __init__(self, q0: np.ndarray, q1: np.ndarray, limits: tuple[list[float], list[float], list[float]]
                 ) -> None:
        self._q0 = q0
        self._dq = q1 - q0
        span = np.abs(self._dq)
        moving = span > 0.0
        if not moving.any():
            raise ValueError("q0 and q1 are the same")

        def scale(lim: list[float]) -> float:
            return float(np.min(np.asarray(lim)[moving] / span[moving]))

        self._curve = SCurve(1.0, scale(limits[0]), scale(limits[1]), scale(limits[2]))
        self.duration = self._curve.duration

    def at_time(self, t: float) -> tuple[list[float], list[float], list[float]]:
        u, du, ddu = self._curve.sample(t)
        return ((self._q0 + self._dq * u).tolist(), (self._dq * du).tolist(), (self._dq * ddu).tolist())


def _limits(x: Limit, dof: int, name: str) -> list[float]:
    arr = np.broadcast_to(np.asarray(x, dtype=float), (dof,))
    if not np.all(np.isfinite(arr)) or np.any(arr <= 0.0):
        raise ValueError(f"{name} must be positive and finite")
    return [float(v) for v in arr]


class JointTrajectory:
    """A planned joint motion: ``duration`` and ``at(t) -> (q, qd, qdd)``.

    Outside ``[0, duration]`` the start and the exact end state are returned.
    ``target`` is where the move is going.
    """

    __slots__ = ("dof", "duration", "target", "limits", "_traj", "_start", "_end", "_inputs")

    def __init__(self, traj: _Samples | Trajectory | None, start: tuple[np.ndarray, np.ndarray, np.ndarray],
                 end: tuple[np.ndarray, np.ndarray, np.ndarray], target: np.ndarray,
                 limits: tuple[list[float], list[float], list[float]]) -> None:
        self._traj = traj
        self.dof = len(target)
        self.duration = float(traj.duration) if traj is not None else 0.0
        self._start, self._end = start, end
        self.target = target
        self.limits = limits
        #: The arguments of :func:`plan_joint_move` that planned it (set there).
        self._inputs: tuple[object, ...] = ()

    def __reduce__(self) -> tuple[object, tuple[object, ...]]:
        """Copied and saved as the inputs it was planned from, planned again when loaded (a ruckig
        trajectory is not data; planning the same inputs gives the same trajectory)."""
        return plan_joint_move, self._inputs

    def at(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if t >= self.duration or self._traj is None:
            q, qd, qdd = self._end
            return q.copy(), qd.copy(), qdd.copy()
        if t <= 0.0:
            q, qd, qdd = self._start
            return q.copy(), qd.copy(), qdd.copy()
        pos, vel, acc = self._traj.at_time(t)
        return np.array(pos), np.array(vel), np.array(acc)

    def position(self, t: float) -> tuple[np.ndarray, list[float]]:
        """``at(t)[0]`` (a new array) and the same joints as a list of floats, without the speeds and
        accelerations (what a control period needs)."""
        if t >= self.duration or self._traj is None or t <= 0.0:
            q = self.at(t)[0]
            return q, q.tolist()
        pos = self._traj.at_time(t)[0]
        return np.array(pos), pos


def _run(inp: InputParameter, dof: int) -> Trajectory:
    traj = Trajectory(dof)
    try:
        result = Ruckig(dof).calculate(inp, traj)
    except (RuckigError, ValueError) as exc:  # ValueError: a result code the binding does not name
        raise PlanningError(f"ruckig: {exc}".strip()) from exc
    if result not in (Result.Working, Result.Finished):
        raise PlanningError(f"ruckig: {result}")
    return traj


def plan_joint_move(q0: Sequence[float] | np.ndarray, q1: Sequence[float] | np.ndarray, vmax: Limit,
                    amax: Limit, jmax: Limit, qd0: Sequence[float] | np.ndarray | None = None,
                    qdd0: Sequence[float] | np.ndarray | None = None) -> JointTrajectory:
    """Time-optimal jerk-limited move from ``q0`` (with ``qd0``, ``qdd0``, default rest) to rest at ``q1``."""
    start_q = np.array(q0, dtype=float)
    target = np.array(q1, dtype=float)
    dof = len(start_q)
    if target.shape != (dof,) or not (np.all(np.isfinite(start_q)) and np.all(np.isfinite(target))):
        raise ValueError("q0 and q1 must be finite and of the same length")
    zero = np.zeros(dof)
    v0 = zero.copy() if qd0 is None else np.array(qd0, dtype=float)
    a0 = zero.copy() if qdd0 is None else np.array(qdd0, dtype=float)
    limits = (_limits(vmax, dof, "vmax"), _limits(amax, dof, "amax"), _limits(jmax, dof, "jmax"))
    start = (start_q, v0, a0)
    end = (target, zero, zero.copy())
    inputs = (start_q.copy(), target.copy(), *limits, v0.copy(), a0.copy())
    if np.array_equal(start_q, target) and not v0.any() and not a0.any():
        out = JointTrajectory(None, start, end, target, limits)
        out._inputs = inputs
        return out
    inp = InputParameter(dof)
    inp.current_position = start_q.tolist()
    inp.current_velocity = v0.tolist()
    inp.current_acceleration = a0.tolist()
    inp.target_position = target.tolist()
    inp.max_velocity, inp.max_acceleration, inp.max_jerk = limits
    inp.synchronization = Synchronization.Phase
    try:
        traj: _Samples | Trajectory = _run(inp, dof)
    except PlanningError:
        if v0.any() or a0.any():
            raise
        traj = StraightLine(start_q, target, limits)
    out = JointTrajectory(traj, start, end, target, limits)
    out._inputs = inputs
    return out
