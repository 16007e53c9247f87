"""Cartesian paths in pose space (4x4 matrices, mm): linear moves (registers 21,
28, 92), arc-blended linear moves (register 22) and circles (register 27),
manual 2.1.3.2.

A path maps a path coordinate ``s`` in ``[0, length]`` to a pose. ``s`` is an
*equivalent length* in mm so that one speed, acceleration and jerk (manual 1.3,
Table 1.2) time the whole move:

- position changes: ``s`` is the TCP distance travelled (note 1 of 1.3: the
  speed is the linear speed);
- orientation changes: the rotation counts ``ROT_MM_PER_RAD`` mm per rad, so a
  speed of 1000 is 180 deg/s (note 2 of 1.3), and likewise for acceleration
  and jerk;
- a line that changes both is timed by whichever is longer: the linear speed
  is the given speed unless the rotation would then exceed the matching
  rotation speed, in which case the rotation sets the pace and the TCP goes
  slower. ``linear_ratio(s)`` (mm of TCP travel per unit ``s``) gives the TCP
  speed from the path speed.

``pose_many(s)`` and ``linear_ratio_many(s)`` take an array of path coordinates
and return the same values, stacked ((N, 4, 4) and (N,)); every path here
computes them with numpy in the same arithmetic as ``pose`` (bit for bit where
numpy's ``sin`` and ``cos`` match :mod:`math`'s). A path class without them gets
the base class's loop over ``pose``.
"""

from __future__ import annotations

import math
from bisect import bisect_right
from collections.abc import Sequence

import numpy as np

from ._rot import Quat, Slerp, SlerpSet, pose_matrices, pose_matrix, quat_from_matrix

#: Equivalent mm per rad of orientation change: speed 1000 <-> 180 deg/s (manual 1.3, note 2).
ROT_MM_PER_RAD = 1000.0 / math.pi

Vec = tuple[float, float, float]


class CollinearError(ValueError):
    """The three circle points are collinear or coincide (the controller raises C32)."""


def _vec(t: np.ndarray) -> Vec:
    return (float(t[0, 3]), float(t[1, 3]), float(t[2, 3]))


def _sub(a: Vec, b: Vec) -> Vec:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def _dot(a: Vec, b: Vec) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _cross(a: Vec, b: Vec) -> Vec:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _norm(a: Vec) -> float:
    return math.sqrt(_dot(a, a))


def _scale(a: Vec, k: float) -> Vec:
    return (a[0] * k, a[1] * k, a[2] * k)


class Path:
    """Base of all paths: ``length`` (equivalent mm) and ``pose(s)``."""

    length: float

    def pose(self, s: float) -> np.ndarray:
        raise NotImplementedError

    def linear_ratio(self, s: float) -> float:
        """TCP mm travelled per unit of ``s`` at ``s`` (1 unless the rotation sets the pace)."""
        raise NotImplementedError

    def pose_many(self, s: np.ndarray) -> np.ndarray:
        """``pose`` of each entry of ``s`` (N,) -> (N, 4, 4)."""
        pq = self._pq_many(s)
        if pq is not None:
            return pose_matrices(*pq)
        out = np.empty((len(s), 4, 4))
        for k, x in enumerate(s.tolist()):
            out[k] = self.pose(x)
        return out

    def linear_ratio_many(self, s: np.ndarray) -> np.ndarray:
        """``linear_ratio`` of each entry of ``s`` (N,) -> (N,)."""
        return np.array([self.linear_ratio(x) for x in s.tolist()], dtype=float)

    def pose_ratio_many(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`pose_many` and :meth:`linear_ratio_many` of ``s`` together."""
        return self.pose_many(s), self.linear_ratio_many(s)

    #: TCP mm per unit ``s``, the same all along the path (``None``: it varies, ask ``linear_ratio``).
    constant_ratio: float | None = None

    def _pq_many(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """Positions (3, N) and unit quaternions (4, N) of :meth:`pose_many`, one sample a column;
        ``None``: the path has no vectorised form (``pose_many`` then loops over ``pose``)."""
        return None


class LinePath(Path):
    """Straight TCP line from ``T0`` to ``T1``; orientation by slerp on the shortest rotation.

    ``length = max(distance, ROT_MM_PER_RAD * angle)`` (see the module notes).
    """

    def __init__(self, t0: np.ndarray, t1: np.ndarray) -> None:
        self.p0, self.p1 = _vec(t0), _vec(t1)
        self.delta = _sub(self.p1, self.p0)
        self.distance = _norm(self.delta)
        self.slerp = Slerp(quat_from_matrix(t0[:3, :3]), quat_from_matrix(t1[:3, :3]))
        self.angle = self.slerp.angle
        self.length = max(self.distance, ROT_MM_PER_RAD * self.angle)
        self._ratio = self.distance / self.length if self.length > 0.0 else 1.0
        self.constant_ratio = self._ratio
        self._p0_array, self._delta_array = np.array(self.p0)[:, None], np.array(self.delta)[:, None]

    def point_u(self, u: float) -> Vec:
        p, d = self.p0, self.delta
        return (p[0] + u * d[0], p[1] + u * d[1], p[2] + u * d[2])

    def pose_u(self, u: float) -> np.ndarray:
        """Pose at fraction ``u`` of the line (0..1)."""
        return pose_matrix(self.point_u(u), self.slerp.at(u))

    def pose(self, s: float) -> np.ndarray:
        if self.length <= 0.0:
            return self.pose_u(1.0)
        return self.pose_u(min(max(s / self.length, 0.0), 1.0))

    def linear_ratio(self, s: float) -> float:
        return self._ratio

    def pq_u_many(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Positions (3, N) and quaternions (4, N) at the fractions ``u`` (as :meth:`pose_u`)."""
        return self._p0_array + u * self._delta_array, self.slerp.at_many(u)

    def _pq_many(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if self.length <= 0.0:
            return self.pq_u_many(np.ones(len(s)))
        return self.pq_u_many(np.minimum(np.maximum(s / self.length, 0.0), 1.0))

    def linear_ratio_many(self, s: np.ndarray) -> np.ndarray:
        return np.full(len(s), self._ratio)


class CirclePath(Path):
    """Circle through the current point ``T0``, ``P1`` and ``P2`` (register 27).

    The TCP starts at ``T0``, passes ``P1`` then ``P2`` and travels ``percent``
    of the circumference (more than 100 goes round again). ``s`` is the arc
    length in mm. Orientation is a periodic function of the angle travelled:
    slerp from the orientation of ``T0`` to ``P1`` between those points, ``P1``
    to ``P2`` between them, and back from ``P2`` to ``T0`` on the rest of the
    circle, so a full turn returns to the start pose. The TCP speed is the
    given speed (the orientation is not allowed to set the pace on a circle).
    Collinear or coincident points raise :class:`CollinearError`.
    """

    #: Sine of the smallest angle between the chords that still defines a circle.
    MIN_SINE = 1e-6

    def __init__(self, t0: np.ndarray, p1: np.ndarray, p2: np.ndarray, percent: float) -> None:
        a0, a1, a2 = _vec(t0), _vec(p1), _vec(p2)
        a, b = _sub(a1, a0), _sub(a2, a0)
        n = _cross(a, b)
        la, lb, ln = _norm(a), _norm(b), _norm(n)
        if la < 1e-6 or lb < 1e-6 or _norm(_sub(a2, a1)) < 1e-6 or ln <= self.MIN_SINE * la * lb:
            raise CollinearError("circle points are collinear or coincide")
        if not math.isfinite(percent) or percent < 0.0:
            raise ValueError(f"percent must be finite and >= 0, got {percent!r}")
        w = _sub(_scale(b, la * la), _scale(a, lb * lb))
        off = _scale(_cross(w, n), 1.0 / (2.0 * ln * ln))
        self.center: Vec = (a0[0] + off[0], a0[1] + off[1], a0[2] + off[2])
        self.radius = _norm(off)
        self.normal: Vec = _scale(n, 1.0 / ln)
        self.e1: Vec = _scale(off, -1.0 / self.radius)  # center -> start point
        self.e2: Vec = _cross(self.normal, self.e1)
        self.percent = percent
        self.sweep = 2.0 * math.pi * percent / 100.0
        self.length = self.radius * self.sweep
        self.phi1 = self._angle_of(a1)
        self.phi2 = self._angle_of(a2)
        q0, q1, q2 = (quat_from_matrix(t[:3, :3]) for t in (t0, p1, p2))
        self._bounds = (0.0, self.phi1, self.phi2, 2.0 * math.pi)
        self._slerps = (Slerp(q0, q1), Slerp(q1, q2), Slerp(q2, q0))
        bd = self._bounds
        self._many = (np.array(bd[1:3]), np.array([bd[:3], [bd[i + 1] - bd[i] for i in range(3)]]),
                      SlerpSet(self._slerps), np.array(self.center)[:, None], np.array(self.e1)[:, None],
                      np.array(self.e2)[:, None])
        self._sorted = self.phi1 <= self.phi2
        self._one_turn = self.length / self.radius < 6.0  # every angle well within the first turn
        self.constant_ratio = 1.0

    def _angle_of(self, p: Vec) -> float:
        d = _sub(p, self.center)
        phi = math.atan2(_dot(d, self.e2), _dot(d, self.e1))
        return phi if phi > 0.0 else phi + 2.0 * math.pi

    def point_at_angle(self, phi: float) -> Vec:
        c, s, r = math.cos(phi) * self.radius, math.sin(phi) * self.radius, self.center
        e1, e2 = self.e1, self.e2
        return (r[0] + c * e1[0] + s * e2[0], r[1] + c * e1[1] + s * e2[1], r[2] + c * e1[2] + s * e2[2])

    def orientation_at_angle(self, phi: float) -> Quat:
        turns = math.floor(phi / (2.0 * math.pi))
        f = phi - turns * 2.0 * math.pi
        b = self._bounds
        i = 0 if f < b[1] else (1 if f < b[2] else 2)
        return self._slerps[i].at((f - b[i]) / (b[i + 1] - b[i]))

    def pose(self, s: float) -> np.ndarray:
        phi = min(max(s, 0.0), self.length) / self.radius
        return pose_matrix(self.point_at_angle(phi), self.orientation_at_angle(phi))

    def linear_ratio(self, s: float) -> float:
        return 1.0

    def _pq_many(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        inner, parts, slerps, center, e1, e2 = self._many
        phi = np.minimum(np.maximum(s, 0.0), self.length) / self.radius
        c, sn = np.cos(phi) * self.radius, np.sin(phi) * self.radius
        p = center + c * e1 + sn * e2
        # orientation_at_angle: the angle within the turn, the slerp of its part of the circle
        f = phi if self._one_turn else phi - np.floor(phi / (2.0 * math.pi)) * 2.0 * math.pi
        if self._sorted:
            i = np.searchsorted(inner, f, side="right")
        else:  # (only for points so close to collinear that round-off reorders them)
            i = np.where(f < inner[0], 0, np.where(f < inner[1], 1, 2))
        lower, width = parts.take(i, axis=1)
        return p, slerps.at(i, (f - lower) / width)

    def linear_ratio_many(self, s: np.ndarray) -> np.ndarray:
        return np.ones(len(s))


class _LinePiece(Path):
    """The part ``[u0, u1]`` of a :class:`LinePath`."""

    def __init__(self, line: LinePath, u0: float, u1: float) -> None:
        self.line, self.u0, self.du = line, u0, u1 - u0
        self.length = line.length * self.du
        self.constant_ratio = line.constant_ratio

    def pose(self, s: float) -> np.ndarray:
        return self.line.pose_u(self.u0 + self.du * (s / self.length if self.length > 0.0 else 1.0))

    def linear_ratio(self, s: float) -> float:
        return self.line.linear_ratio(s)

    def _pq_many(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        f = s / self.length if self.length > 0.0 else np.ones(len(s))
        return self.line.pq_u_many(self.u0 + self.du * f)

    def linear_ratio_many(self, s: np.ndarray) -> np.ndarray:
        return self.line.linear_ratio_many(s)


class BlendArc(Path):
    """Arc rounding the corner ``pc`` between two lines (register 22).

    ``radius`` is the blend-zone radius: the TCP leaves the incoming line
    ``radius`` mm before the corner and joins the outgoing one ``radius`` mm
    after it, on a circular arc tangent to both lines. The arc's own radius is
    ``radius / tan(turn / 2)``; every point of it lies within ``radius`` of the
    corner. Orientation: slerp between the poses where the arc meets the lines.
    """

    def __init__(self, pc: Vec, d_in: Vec, d_out: Vec, radius: float, q_in: Quat, q_out: Quat) -> None:
        cosa = min(max(_dot(d_in, d_out), -1.0), 1.0)
        self.turn = math.acos(cosa)
        self.arc_radius = radius / math.tan(0.5 * self.turn)
        perp = _sub(d_out, _scale(d_in, cosa))
        m = _scale(perp, 1.0 / _norm(perp))
        self.start: Vec = _sub(pc, _scale(d_in, radius))
        self.center: Vec = (self.start[0] + self.arc_radius * m[0], self.start[1] + self.arc_radius * m[1],
                            self.start[2] + self.arc_radius * m[2])
        self._m, self._d = m, d_in
        self.distance = self.arc_radius * self.turn
        self.slerp = Slerp(q_in, q_out)
        self.length = max(self.distance, ROT_MM_PER_RAD * self.slerp.angle)
        self._ratio = self.distance / self.length if self.length > 0.0 else 1.0
        self.constant_ratio = self._ratio
        self._arrays = np.array(self.center)[:, None], np.array(m)[:, None], np.array(d_in)[:, None]

    def point_at_angle(self, psi: float) -> Vec:
        c, s, r = -math.cos(psi) * self.arc_radius, math.sin(psi) * self.arc_radius, self.center
        m, d = self._m, self._d
        return (r[0] + c * m[0] + s * d[0], r[1] + c * m[1] + s * d[1], r[2] + c * m[2] + s * d[2])

    def pose(self, s: float) -> np.ndarray:
        u = min(max(s / self.length, 0.0), 1.0) if self.length > 0.0 else 1.0
        return pose_matrix(self.point_at_angle(u * self.turn), self.slerp.at(u))

    def linear_ratio(self, s: float) -> float:
        return self._ratio

    def _pq_many(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if self.length > 0.0:
            u = np.minimum(np.maximum(s / self.length, 0.0), 1.0)
        else:
            u = np.ones(len(s))
        psi = u * self.turn
        center, m, d = self._arrays
        c, sn = -np.cos(psi) * self.arc_radius, np.sin(psi) * self.arc_radius
        return center + c * m + sn * d, self.slerp.at_many(u)

    def linear_ratio_many(self, s: np.ndarray) -> np.ndarray:
        return np.full(len(s), self._ratio)


class CompositePath(Path):
    """Pieces joined end to end (a run of blended lines)."""

    def __init__(self, pieces: Sequence[Path]) -> None:
        self.pieces = [p for p in pieces if p.length > 0.0] or list(pieces[-1:])
        self._starts: list[float] = []
        total = 0.0
        for p in self.pieces:
            self._starts.append(total)
            total += p.length
        self.length = total
        self._starts_array = np.array(self._starts)
        self._inner_starts = self._starts_array[1:]  # searchsorted on these: the piece index
        ratios = [p.constant_ratio for p in self.pieces]
        self._ratios = None if None in ratios else np.array(ratios, dtype=float)

    @property
    def starts(self) -> tuple[float, ...]:
        """Path length at which each piece starts (mm)."""
        return tuple(self._starts)

    def _find(self, s: float) -> int:
        return max(bisect_right(self._starts, s) - 1, 0)

    def pose(self, s: float) -> np.ndarray:
        if s >= self.length:
            return self.pieces[-1].pose(self.pieces[-1].length)
        i = self._find(s)
        return self.pieces[i].pose(s - self._starts[i])

    def linear_ratio(self, s: float) -> float:
        i = self._find(min(s, self.length))
        return self.pieces[i].linear_ratio(s - self._starts[i])

    def _split(self, s: np.ndarray, clamp_end: bool) -> tuple[np.ndarray, np.ndarray]:
        """The piece of each entry and the coordinate within it (as :meth:`pose` with
        ``clamp_end``, else as :meth:`linear_ratio`)."""
        i = np.searchsorted(self._inner_starts, np.minimum(s, self.length), side="right")
        local = s - self._starts_array.take(i)
        if clamp_end:
            end = s >= self.length
            if np.count_nonzero(end):
                i[end] = len(self.pieces) - 1
                local[end] = self.pieces[-1].length
        return i, local

    @staticmethod
    def _groups(i: np.ndarray) -> list[tuple[int, np.ndarray | None]]:
        """The pieces present in ``i``, each with its entries (``None``: all of them)."""
        first = int(i[0])
        if not np.count_nonzero(i != first):
            return [(first, None)]
        return [(int(k), np.flatnonzero(i == k)) for k in np.unique(i)]

    def pose_many(self, s: np.ndarray) -> np.ndarray:
        if not len(s):
            return np.empty((0, 4, 4))
        i, local = self._split(s, True)
        groups = self._groups(i)
        if len(groups) == 1:
            return self.pieces[groups[0][0]].pose_many(local)
        return self._pose_groups(groups, local)

    def _pose_groups(self, groups: list[tuple[int, np.ndarray | None]], local: np.ndarray) -> np.ndarray:
        """Poses of the entries of several pieces (their coordinates ``local`` within them)."""
        n = len(local)
        p, q = np.empty((3, n)), np.zeros((4, n))
        q[0] = 1.0
        direct: list[tuple[np.ndarray, np.ndarray]] = []
        for k, rows in groups:
            assert rows is not None
            piece, sub = self.pieces[k], local[rows]
            pq = piece._pq_many(sub)
            if pq is None:
                direct.append((rows, piece.pose_many(sub)))
            else:
                p[:, rows], q[:, rows] = pq
        out = pose_matrices(p, q)
        for rows, poses in direct:
            out[rows] = poses
        return out

    def _pq_many(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        if not len(s):
            return np.empty((3, 0)), np.empty((4, 0))
        i, local = self._split(s, True)
        groups = self._groups(i)
        if len(groups) == 1:
            return self.pieces[groups[0][0]]._pq_many(local)
        p, q = np.empty((3, len(s))), np.empty((4, len(s)))
        for k, rows in groups:
            pq = self.pieces[k]._pq_many(local[rows])
            if pq is None:
                return None
            p[:, rows], q[:, rows] = pq
        return p, q

    def pose_ratio_many(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if self._ratios is None or not len(s):
            return self.pose_many(s), self.linear_ratio_many(s)
        # linear_ratio's piece is pose's (at and past the end both take the last one).
        i, local = self._split(s, True)
        ratios = self._ratios.take(i)
        groups = self._groups(i)
        if len(groups) == 1:
            return self.pieces[groups[0][0]].pose_many(local), ratios
        return self._pose_groups(groups, local), ratios

    def linear_ratio_many(self, s: np.ndarray) -> np.ndarray:
        if not len(s):
            return np.empty(0)
        i, local = self._split(s, False)
        groups = self._groups(i)
        if len(groups) == 1:
            return self.pieces[groups[0][0]].linear_ratio_many(local)
        out = np.empty(len(s))
        for k, rows in groups:
            out[rows] = self.pieces[k].linear_ratio_many(local[rows])
        return out


#: Turns below this (rad) are travelled as a straight line through the blend zone.
MIN_BLEND_TURN = 1e-6
#: Turns sharper than this (rad from a full reversal) are not blended: the TCP stops at the corner.
MAX_BLEND_TURN = math.pi - 1e-3


def blend_runs(poses: Sequence[np.ndarray], radii: Sequence[float | None]) -> list[CompositePath]:
    """Split a chain of linear moves into runs that are travelled without stopping.

    ``poses[0]`` is the start; move ``k`` goes to ``poses[k + 1]`` with blend
    radius ``radii[k]`` at its end (``None`` or <= 0: stop there; the last
    move's radius is ignored, there is nothing to blend into). A radius larger
    than half of either adjacent line is shrunk to that half, so neighbouring
    blends never overlap. A corner where either line has no TCP travel (pure
    rotation) or that reverses the direction is not blended.
    """
    if len(poses) < 2:
        raise ValueError("need at least two poses")
    every = [LinePath(poses[k], poses[k + 1]) for k in range(len(poses) - 1)]
    keep = [k for k, ln in enumerate(every) if ln.length > 0.0] or [len(every) - 1]
    lines = [every[k] for k in keep]  # null moves are dropped; radii follow the surviving lines
    asked = [float(radii[k] or 0.0) if k < len(radii) else 0.0 for k in keep]
    # Blend radius at the end of each line (the corner into the next line); NaN and <= 0: none.
    corner: list[float] = []
    for k in range(len(lines) - 1):
        a, b = lines[k], lines[k + 1]
        r = asked[k]
        r = min(r, a.distance / 2.0, b.distance / 2.0) if r > 0.0 else 0.0
        if r > 0.0:
            cosa = _dot(a.delta, b.delta) / (a.distance * b.distance)
            if math.acos(min(max(cosa, -1.0), 1.0)) > MAX_BLEND_TURN:
                r = 0.0
        corner.append(r)
    corner.append(0.0)
    runs: list[CompositePath] = []
    pieces: list[Path] = []
    r_prev = 0.0
    for k, ln in enumerate(lines):
        u0 = r_prev / ln.distance if r_prev > 0.0 else 0.0
        r = corner[k]
        u1 = 1.0 - r / ln.distance if r > 0.0 else 1.0
        pieces.append(_LinePiece(ln, u0, u1))
        if r > 0.0:
            nxt = lines[k + 1]
            d_in = _scale(ln.delta, 1.0 / ln.distance)
            d_out = _scale(nxt.delta, 1.0 / nxt.distance)
            q_in, q_out = ln.slerp.at(u1), nxt.slerp.at(r / nxt.distance)
            if _dot(d_in, d_out) < math.cos(MIN_BLEND_TURN):
                pieces.append(BlendArc(ln.p1, d_in, d_out, r, q_in, q_out))
            else:  # (nearly) straight on: the blend zone is a line
                pieces.append(LinePath(ln.pose_u(u1), nxt.pose_u(r / nxt.distance)))
        else:
            runs.append(CompositePath(pieces))
            pieces = []
        r_prev = r
    return runs
