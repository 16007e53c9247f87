"""Timed Cartesian moves: a path (:mod:`.paths`) travelled with a jerk-limited
profile along its length (manual 1.3, Table 1.2; registers 21, 22, 27, 28, 92).

Every move offers the same small interface the controller samples every
control period: ``duration`` and ``at(t) -> (T 4x4, TCP speed mm/s)``;
a single move also gives ``state(t)`` (path coordinate, speed, acceleration).
``at_many(ts)`` samples many path times at once (numpy): the poses (N, 4, 4) and
TCP speeds (N,) of ``at`` at each time, bit for bit where numpy's ``sin`` and
``cos`` match :mod:`math`'s (see :mod:`.paths`).
"""

from __future__ import annotations

from bisect import bisect_right
from collections.abc import Sequence

import numpy as np

from .paths import Path, blend_runs
from .profile import JerkProfile, MovingProfile, SCurve


class CartesianMove:
    """``path`` travelled from ``s0`` with ``profile`` (default: an S-curve to the end).

    ``speed``, ``acc`` and ``jerk`` are in mm/s, mm/s2, mm/s3 of path
    coordinate (see :mod:`.paths` for how rotation counts).
    """

    __slots__ = ("path", "speed", "acc", "jerk", "s0", "profile", "duration")

    def __init__(self, path: Path, speed: float, acc: float, jerk: float, *, s0: float = 0.0,
                 profile: JerkProfile | MovingProfile | None = None) -> None:
        self.path, self.speed, self.acc, self.jerk, self.s0 = path, speed, acc, jerk, s0
        self.profile = profile if profile is not None else SCurve(path.length - s0, speed, acc, jerk)
        self.duration = self.profile.duration

    def state(self, t: float) -> tuple[float, float, float]:
        """Path coordinate, path speed and path acceleration at ``t``."""
        s, v, a = self.profile.sample(t)
        return min(max(self.s0 + s, 0.0), self.path.length), v, a

    def at(self, t: float) -> tuple[np.ndarray, float]:
        """Pose (4x4, mm) and TCP linear speed (mm/s) at ``t``."""
        s, v, _ = self.profile.sample(t)
        path = self.path
        s = min(max(self.s0 + s, 0.0), path.length)  # as :meth:`state`
        return path.pose(s), abs(v) * path.linear_ratio(s)

    def at_many(self, ts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`at` of each entry of the path times ``ts`` (N,): poses (N, 4, 4), TCP speeds (N,)."""
        ts = np.asarray(ts, dtype=float)
        profile = self.profile
        if hasattr(profile, "sample_many"):
            s, v, _ = profile.sample_many(ts)
        else:  # a profile without the vectorised form
            rows = np.array([profile.sample(t) for t in ts.tolist()], dtype=float).reshape(len(ts), 3)
            s, v = rows[:, 0], rows[:, 1]
        path = self.path
        s = np.minimum(np.maximum(self.s0 + s, 0.0), path.length)
        ratio = path.constant_ratio
        if ratio is not None:
            return path.pose_many(s), np.abs(v) * ratio
        poses, ratios = path.pose_ratio_many(s)
        return poses, np.abs(v) * ratios


class MoveChain:
    """Moves played one after the other (runs of a blended chain split at unblended corners)."""

    __slots__ = ("moves", "duration", "_starts", "_starts_array")

    def __init__(self, moves: Sequence[CartesianMove]) -> None:
        self.moves = list(moves)
        self._starts: list[float] = []
        t = 0.0
        for m in self.moves:
            self._starts.append(t)
            t += m.duration
        self.duration = t
        self._starts_array = np.array(self._starts)

    def _find(self, t: float) -> int:
        return min(max(bisect_right(self._starts, t) - 1, 0), len(self.moves) - 1)

    def at(self, t: float) -> tuple[np.ndarray, float]:
        if t >= self.duration:
            return self.moves[-1].at(self.moves[-1].duration)
        i = self._find(t)
        return self.moves[i].at(t - self._starts[i])

    def at_many(self, ts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`at` of each entry of the path times ``ts`` (N,): poses (N, 4, 4), TCP speeds (N,)."""
        ts = np.asarray(ts, dtype=float)
        starts = self._starts_array
        last = len(self.moves) - 1
        i = np.minimum(np.maximum(np.searchsorted(starts, ts, side="right") - 1, 0), last)
        local = ts - starts[i]
        end = ts >= self.duration
        if end.any():
            i[end] = last
            local[end] = self.moves[-1].duration
        lo, hi = (int(i.min()), int(i.max())) if len(ts) else (0, 0)
        if lo == hi:
            return self.moves[lo].at_many(local)
        poses, speeds = np.empty((len(ts), 4, 4)), np.empty(len(ts))
        for k in range(lo, hi + 1):
            rows = np.flatnonzero(i == k)
            if len(rows):
                poses[rows], speeds[rows] = self.moves[k].at_many(local[rows])
        return poses, speeds


def plan_blended(poses: Sequence[np.ndarray], radii: Sequence[float | None], speed: float, acc: float,
                 jerk: float) -> CartesianMove | MoveChain:
    """One continuous move through queued linear moves with arc blending (register 22).

    ``poses[0]`` is the current pose, move ``k`` ends at ``poses[k + 1]`` with
    blend radius ``radii[k]`` (see :func:`.paths.blend_runs`). The TCP does not
    stop at blended corners: each run between unblended corners is one
    S-curve over its whole length, so the path speed stays at the cruise speed
    through the arcs.
    """
    moves = [CartesianMove(run, speed, acc, jerk) for run in blend_runs(poses, radii)]
    return moves[0] if len(moves) == 1 else MoveChain(moves)
