"""Per-step safety checks: safety boundary (registers 52, 59; C35) and self-collision (77, 78; C22).

Pure functions for the controller, called once per control period with the joints it is about to
command. ``check_path_step`` answers None (go on) or a ``StepStop``: the error code and the joints to stop
at, found on the step from ``q_prev`` to ``q_next`` (joints interpolated linearly inside the step):

- C35 (manual 3.2.1, "Safety Boundary Limit"; register 52 gives x max, x min, y max, y min, z max, z min
  in mm, register 59 switches it): the TCP (flange plus the TCP offset, register 35) is checked in the base
  frame; the stop point is ON the boundary: inside it and within ``BOUNDARY_TOL`` of the face it crosses.
- C22 (manual 3.2.1, "Self-collision Error, Please Re-plan the Path"): the arm stops before contact, at
  the last point of the step whose minimum link distance is at least ``COLLISION_MARGIN`` (1 mm: the stop
  is taken while a gap of one millimetre is left, so links never overlap, even after float32 rounding of
  reported joints). A step that starts closer than the margin is allowed only when it moves the links
  apart (so an arm inside the margin can be driven out); otherwise it stops where it is.
- A TCP already outside an enabled boundary stops at once (fraction 0).

Collision detection (register 37, manual 1.5 and C31 of 3.2.1): an external torque on a joint, which
only fault injection can apply here, is detected when it reaches the threshold of the collision
sensitivity (:func:`collision_detected`), the emulator's table or a calibrated model's measured one
(:func:`collision_thresholds`). Level 0 switches detection off.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ...model.collision import NO_TOOL, ToolModel, self_collision
from ...model.kinematics import tcp_pose
from ...model.robots import RobotModel
from .interface import C_BOUNDARY, C_SELF_COLLISION

#: External joint torque (N m) that collision sensitivity 1..5 detects (C31). The vendor publishes
#: no figures, only that a higher level needs less torque; these are the emulator's, the same for
#: every joint.
COLLISION_THRESHOLDS = {1: 60.0, 2: 45.0, 3: 30.0, 4: 20.0, 5: 10.0}


def collision_thresholds(model: RobotModel) -> dict[int, float]:
    """The thresholds (N m) of ``model`` by sensitivity level: the emulator's, or those its
    calibration measured (``Calibration.collision_thresholds``)."""
    cal = model.calibration
    if cal is None or cal.collision_thresholds is None:
        return COLLISION_THRESHOLDS
    return {level: cal.collision_thresholds[level - 1] for level in COLLISION_THRESHOLDS}


def collision_detected(sensitivity: int, torque: float, thresholds: dict[int, float] | None = None) -> bool:
    """Whether an external ``torque`` (N m, either sign) trips collision detection at ``sensitivity``
    (``thresholds`` by level, :data:`COLLISION_THRESHOLDS` when not given)."""
    threshold = (COLLISION_THRESHOLDS if thresholds is None else thresholds).get(int(sensitivity))
    return threshold is not None and abs(torque) >= threshold

COLLISION_MARGIN = 1.0  # mm, minimum gap kept between links (module docstring)
BOUNDARY_TOL = 0.01  # mm, the boundary stop point lies this close to the face (or closer), inside
_COLLISION_BISECTIONS = 16  # step resolution 2^-16 of one control period
_BOUNDARY_ITER = 60


@dataclass(frozen=True)
class StepStop:
    """Where and why a step must stop: ``code`` (22 or 35), ``fraction`` of the step, joints ``q_stop``."""

    code: int
    fraction: float
    q_stop: np.ndarray
    reason: str


def boundary_violation(xyz: Sequence[float], boundary6: Sequence[float], on: bool) -> bool:
    """True when ``on`` and ``xyz`` (mm) lies outside the box (x max, x min, y max, y min, z max, z min).

    The faces belong to the inside (register 52).
    """
    if not on:
        return False
    return _excess(xyz, boundary6) > 0.0


def _excess(p: Sequence[float] | np.ndarray, b: Sequence[float]) -> float:
    """Largest signed distance outside the box along an axis (negative: inside by that much)."""
    return max(p[0] - b[0], b[1] - p[0], p[1] - b[2], b[3] - p[1], p[2] - b[4], b[5] - p[2])


def first_boundary_crossing(
    p0: Sequence[float] | np.ndarray, p1: Sequence[float] | np.ndarray, boundary: Sequence[float]
) -> float | None:
    """Fraction t in [0, 1] where segment p0 -> p1 first reaches a face it leaves by; None if p1 is inside.

    A p0 outside the box gives 0.0 (the step may not start).
    """
    if _excess(p0, boundary) > 0.0:
        return 0.0
    if _excess(p1, boundary) <= 0.0:
        return None
    t = 1.0
    for k in range(3):
        hi, lo = boundary[2 * k], boundary[2 * k + 1]
        d = p1[k] - p0[k]
        if p1[k] > hi:
            t = min(t, (hi - p0[k]) / d)
        elif p1[k] < lo:
            t = min(t, (lo - p0[k]) / d)
    return max(0.0, t)


def tcp_position(model: RobotModel, q: Sequence[float] | np.ndarray, tcp_offset: Sequence[float] = (0.0,) * 6
                 ) -> np.ndarray:
    """TCP position in the base frame (mm): flange pose times the TCP offset (register 35, manual 1.5)."""
    return tcp_pose(model, q, tcp_offset)[:3, 3]


def _lerp(q0: np.ndarray, q1: np.ndarray, s: float) -> np.ndarray:
    return q0 + (q1 - q0) * s


def _boundary_stop(
    model: RobotModel, q0: np.ndarray, q1: np.ndarray, boundary: Sequence[float], tcp_offset: Sequence[float]
) -> StepStop | None:
    p0 = tcp_position(model, q0, tcp_offset)
    p1 = tcp_position(model, q1, tcp_offset)
    g0, g1 = _excess(p0, boundary), _excess(p1, boundary)
    if g0 > 0.0:
        return StepStop(C_BOUNDARY, 0.0, q0.copy(), "TCP outside the safety boundary")
    if g1 <= 0.0:
        return None
    # Illinois regula falsi on g(s) = excess of the TCP at the interpolated joints; keep lo inside.
    lo, hi, glo, ghi = 0.0, 1.0, g0, g1
    s = first_boundary_crossing(p0, p1, boundary) or 0.0
    side = 0
    for _ in range(_BOUNDARY_ITER):
        if glo >= -BOUNDARY_TOL:
            break
        g = _excess(tcp_position(model, _lerp(q0, q1, s), tcp_offset), boundary)
        if g <= 0.0:
            lo, glo = s, g
            if side == -1:
                ghi *= 0.5
            side = -1
        else:
            hi, ghi = s, g
            if side == 1:
                glo *= 0.5
            side = 1
        s = lo + (hi - lo) * (-glo) / (ghi - glo)
        if not lo < s < hi:
            s = 0.5 * (lo + hi)
    return StepStop(C_BOUNDARY, float(lo), _lerp(q0, q1, lo), "TCP reached the safety boundary")


def _collision_stop(
    model: RobotModel, q0: np.ndarray, q1: np.ndarray, tool: ToolModel, margin: float
) -> StepStop | None:
    hit1, d1, _ = self_collision(model, q1, tool, margin)
    if not hit1:
        return None
    hit0, d0, _ = self_collision(model, q0, tool, margin)
    if hit0:
        if d1 > d0:
            return None  # moving out of the margin
        return StepStop(C_SELF_COLLISION, 0.0, q0.copy(), "links closer than the self-collision margin")
    lo, hi = 0.0, 1.0
    for _ in range(_COLLISION_BISECTIONS):
        mid = 0.5 * (lo + hi)
        if self_collision(model, _lerp(q0, q1, mid), tool, margin)[0]:
            hi = mid
        else:
            lo = mid
    return StepStop(C_SELF_COLLISION, lo, _lerp(q0, q1, lo), "self-collision ahead")


def check_path_step(
    model: RobotModel,
    q_prev: Sequence[float] | np.ndarray,
    q_next: Sequence[float] | np.ndarray,
    tool: ToolModel = NO_TOOL,
    self_collision_on: bool = False,
    boundary: Sequence[float] | None = None,
    boundary_on: bool = False,
    tcp_offset: Sequence[float] = (0.0,) * 6,
    margin: float = COLLISION_MARGIN,
) -> StepStop | None:
    """None when the step q_prev -> q_next is safe, else the earliest ``StepStop`` (C22 or C35).

    ``q_prev`` must be the joints the arm is at (already checked); only the first ``model.dof`` values count.
    """
    if not self_collision_on and not (boundary_on and boundary is not None):
        return None
    q0 = np.asarray(q_prev, dtype=float)[: model.dof]
    q1 = np.asarray(q_next, dtype=float)[: model.dof]
    stops = []
    if boundary_on and boundary is not None:
        stop = _boundary_stop(model, q0, q1, boundary, tcp_offset)
        if stop is not None:
            stops.append(stop)
    if self_collision_on:
        stop = _collision_stop(model, q0, q1, tool, margin)
        if stop is not None:
            stops.append(stop)
    if not stops:
        return None
    return min(stops, key=lambda st: st.fraction)
