"""Motion execution: takes commands from the buffer, plans them from the
current state and samples the plan every control period.

Suspend (state 3) and stop (state 4) slow the *path time* down with a smooth
ramp, so the arm stays on the planned path and a resumed move continues the
same path (manual register 12). The buffer and the plan live in a
:class:`~.controller_state.PlanState`, part of the controller's :class:`~.controller_state.ControllerState`.

With ``FirmwareProfile.inf_unchanged`` a +inf value of a pose (register 21) or joint target (23) keeps
that component where the move starts (:func:`keep_unchanged_pose`,
:func:`keep_unchanged_joints`).

A period (:meth:`Executor.step`): the running plan (a queued command planned when it starts, a
blended move re-planned when the next one can join it), its joints at the path time, the joint
limits (C23) and, on a TCP path, the joint speed (C24). Speed comes from three mechanisms, none of
which changes a value:

- floats beside arrays: a plan answers a period with the joints as an array and as floats
  (:data:`Answer`), and the limit and speed checks run on the floats (CPU time of one period of an
  xArm6, best of 45: a joint move 6.4 us against 9.2 us with the checks on arrays, a TCP line 18.5
  us against 23.4 us);
- a Cartesian plan samples its path for :data:`SAMPLE_BATCH` periods at once while the path rate
  is steady (:meth:`_CartesianPlan.sample`; ``bench/bench_sample_many.py``: 1.2 us a period for 64
  samples at once, 0.6 us for 256, against 5 to 7.5 us sampling one pose at a time);
- it solves a period by the chord solve from the extrapolation of its last answers, with the step
  matrix kept (:meth:`_CartesianPlan._track`, ``kinematics.track``; ``bench/bench_kinematics.py``,
  the Cartesian period's joints, against the full solve every period).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from operator import le, sub

import numpy as np

from ...model import kinematics as kin
from ...model import rotations as rot
from ...model.robots import RobotModel
from .. import motion
from .commands import CircleMove, Dwell, JointMove, LineMove, QueuedCommand, Task
from .controller_state import RAMP_TIME, PlanState
from .interface import C_CIRCLE, C_JOINT_LIMIT, C_KINEMATIC, C_SPEED, CommandError
from .poses import resolve_line_target, wire_pose_to_matrix

#: Points at which a TCP line is tried for joint solutions (register 21, motion type 1).
LINE_SAMPLES = 24
#: Peak slope of the smoothstep ramp (3u^2 - 2u^3) relative to a linear one.
_SMOOTHSTEP_PEAK = 1.5

#: A Cartesian step may exceed the joint speed limit by this factor before C24 (sampling slack).
SPEED_TOLERANCE = 1.05

#: Control periods of a Cartesian path sampled at once while the path rate is steady.
SAMPLE_BATCH = 128

#: Largest ratio of path-time steps over which a Cartesian plan extrapolates its IK seed.
_EXTRAPOLATE_MAX = 2.0

#: A plan's answer for one period: the joints as an array (the controller keeps it) and the same
#: joints as floats (the per-period checks read them; see the module's docstring).
Answer = tuple[np.ndarray, Sequence[float]]


def keep_unchanged_joints(target: np.ndarray, q: np.ndarray) -> np.ndarray:
    """A joint target with its +inf values (``FirmwareProfile.inf_unchanged``: "unchanged", register 23)
    taken from the joints ``q`` the move starts from."""
    return np.where(np.isposinf(target), q, target) if np.isposinf(target).any() else target


def keep_unchanged_pose(cmd: LineMove, start: np.ndarray) -> LineMove:
    """A linear move with its +inf pose values (``FirmwareProfile.inf_unchanged``: "unchanged", register 21)
    resolved from the TCP pose ``start`` the move starts from: the start's own component for an
    absolute base-frame pose, no motion (0) for relative and tool-frame poses."""
    if not any(x == math.inf for x in cmd.pose):
        return cmd
    if cmd.tool_frame or cmd.relative:
        ref: tuple[float, ...] = (0.0,) * 6
    else:
        to_pose = rot.matrix_to_pose_aa if cmd.axis_angle else rot.matrix_to_pose
        ref = tuple(float(x) for x in to_pose(start))
    return replace(cmd, pose=tuple(r if x == math.inf else x for x, r in zip(cmd.pose, ref, strict=False)))


def line_target(cmd: LineMove, start: np.ndarray) -> np.ndarray:
    """The absolute target (4x4, user frame) of a linear move from ``start``, kept components
    resolved (:func:`keep_unchanged_pose`, :func:`~xarm_emu.controller.core.poses.resolve_line_target`)."""
    return resolve_line_target(keep_unchanged_pose(cmd, start), start)


@dataclass
class Limits:
    """Jerk and maximum-acceleration settings that moves use (registers 31-34)."""

    tcp_jerk: float
    tcp_maxacc: float
    joint_jerk: float
    joint_maxacc: float
    max_joint_speed: float = math.pi  # Table 1.2; a Cartesian path needing more is error C24
    #: Speed caps of queued moves (reduced mode, registers 47/48): mm/s for Cartesian, rad/s joint.
    tcp_speed_cap: float = math.inf
    joint_speed_cap: float = math.inf


class _Plan:
    """One planned command: a duration and the joints at a path time (:meth:`joints`)."""

    duration: float = 0.0
    tcp_speed: float = 0.0

    def joints(self, t: float, seed: np.ndarray, increment: float = 0.0) -> Answer | None:
        """The joints at path time ``t`` from the joints ``seed`` of the period before (``None``: no
        solution); ``increment`` > 0: the path time goes on growing by this much a period."""
        raise NotImplementedError

    def stop_time(self, t: float, limits: Limits) -> float:
        """Seconds to come to rest from path time ``t`` at the acceleration limit."""
        return 0.0


class _JointPlan(_Plan):
    """A joint move (registers 23-25, and a line made a joint move): its jerk-limited trajectory."""

    def __init__(self, traj: motion.JointTrajectory, blend: tuple[float, np.ndarray] | None = None) -> None:
        self.traj = traj
        self.duration = traj.duration
        #: Blend radius (mm) and the TCP position (mm, base frame) at the target, when the command
        #: asked to blend into the next joint move (register 24 with a radius).
        self.blend = blend

    def joints(self, t: float, seed: np.ndarray, increment: float = 0.0) -> Answer | None:
        return self.traj.position(t)

    def stop_time(self, t: float, limits: Limits) -> float:
        qd = self.traj.at(min(t, self.duration))[1]
        return float(np.max(np.abs(qd))) / limits.joint_maxacc


class _DwellPlan(_Plan):
    """A dwell (register 26), or a task queued behind moves (no time): the joints held."""

    def __init__(self, q: np.ndarray, seconds: float) -> None:
        self.q = q.copy()
        self.duration = seconds

    def joints(self, t: float, seed: np.ndarray, increment: float = 0.0) -> Answer | None:
        return self.q, self.q.tolist()


class _CartesianPlan(_Plan):
    """A TCP path (a line, an arc, a blended chain) solved for the joints period by period."""

    def __init__(self, move: motion.CartesianMove | motion.MoveChain,
                 to_flange: Callable[[np.ndarray], np.ndarray], model: RobotModel,
                 blend_into: tuple[np.ndarray, float, LineMove] | None = None) -> None:
        self.move = move
        self.duration = move.duration
        self.to_flange = to_flange
        self.model = model
        #: For a line (chain) whose last move has a blend radius: (its target, the radius, the first
        #: command of the chain), so that a linear move arriving later can still be blended into.
        self.blend_into = blend_into
        #: The last answers along the path: (path time, joints as floats), oldest first, at most four.
        self._hist: tuple[tuple[float, tuple[float, ...]], ...] = ()
        #: The step matrix of the chord solve (kinematics.track), kept from period to period.
        self._matrix: tuple[float, ...] | None = None
        #: Path samples of upcoming periods (:meth:`sample`): path times, poses (N, 4, 4), TCP speeds;
        #: and the index of the next one.
        self._batch: tuple[list[float], np.ndarray, list[float]] | None = None
        self._next = 0

    def last_run(self, t: float) -> tuple[motion.CartesianMove, float] | None:
        """The final run of the plan and the time within it, if ``t`` lies in that run."""
        move = self.move
        if isinstance(move, motion.MoveChain):
            last_start = move.duration - move.moves[-1].duration
            if t < last_start:
                return None
            return move.moves[-1], t - last_start
        return move, t

    def sample(self, t: float, increment: float) -> tuple[np.ndarray, float]:
        """The path's pose (4x4, user frame) and TCP speed at path time ``t``.

        ``increment`` > 0: the path time will go on growing by this much a period (the executor's
        path rate is steady), so the next :data:`SAMPLE_BATCH` path times, summed as the executor sums
        them, are sampled at once (``at_many``) and later periods whose path time matches one of
        them, bit for bit, take it from there. Which periods come from a batch depends only on the
        sequence of path times, never on how the control periods are stepped."""
        b = self._batch
        if b is not None:
            i = self._next
            ts = b[0]
            if i < len(ts) and ts[i] == t:
                self._next = i + 1
                return b[1][i], b[2][i]
        if increment > 0.0 and t < self.duration:
            n = min(SAMPLE_BATCH, int((self.duration - t) / increment) + 2)
            times = np.add.accumulate(np.concatenate(((t,), np.full(n - 1, increment))))
            np.minimum(times, self.duration, out=times)  # the executor passes min(path time, duration)
            poses, speeds = self.move.at_many(times)
            self._batch = (times.tolist(), poses, speeds.tolist())
            self._next = 1
            return poses[0], float(speeds[0])
        self._batch = None
        return self.move.at(t)

    def joints(self, t: float, seed: np.ndarray, increment: float = 0.0) -> Answer | None:
        """The joints that put the TCP on the path at ``t``: with no answer of the plan to go on from
        (its first period, or the joints were changed under it: ``seed`` is not the plan's last
        answer, value for value) or on the xArm5 (its closed form needs no start), the full solve
        from ``seed``; in the period that ends the plan, the full solve from the last answer
        (:meth:`_solve`); else the chord solve from the extrapolated answers (:meth:`_track`)."""
        pose, self.tcp_speed = self.sample(t, increment)
        target = self.to_flange(pose)
        h = self._hist
        if h and tuple(seed.tolist()) != h[-1][1]:
            h = ()  # the joints were changed under the plan: its answers are no start
        if not h or self.model.fixed_roll_pitch:
            q = self._solve(target, (seed,))
        elif t >= self.duration:
            q = self._solve(target, (h[-1][1], *_first_order(h, t)))
        else:
            q = self._track(target, h, t)
        if q is None:
            self._hist = ()
            return None
        self._hist = (*h[-3:], (t, q))
        return np.array(q), q

    def _solve(self, target: np.ndarray, starts: tuple[Sequence[float] | np.ndarray, ...]
               ) -> tuple[float, ...] | None:
        """The full solve (``kinematics.ik``) from the first of ``starts`` it converges from. In the
        period that ends the plan its quadratic convergence puts the arm at rest on the target some
        orders of magnitude closer than the convergence test asks; the chord solve starts afresh."""
        self._matrix = None
        for start in starts:
            sol = kin.ik(self.model, target, start, limited=False)
            if sol is not None:
                return tuple(sol.tolist())
        return None

    def _track(self, target: np.ndarray, h: tuple[tuple[float, tuple[float, ...]], ...],
               t: float) -> tuple[float, ...] | None:
        """The chord solve (``kinematics.track``) from the extrapolation of the answers ``h`` to ``t``
        (:func:`_start`), with the step matrix kept; the full solve from the first-order start and
        the last answer decides when it does not converge. On equal steps with a kept matrix (the
        usual period of a six-joint arm) the third-order start is computed in the generated code
        itself (``kinematics.track_steady``)."""
        model, matrix = self.model, self._matrix
        def fallbacks() -> tuple[tuple[float, ...], ...]:
            return _first_order(h, t)

        if matrix is not None and model.dof == 6 and _steps(h, t) == _EQUAL:
            q, self._matrix = kin.track_steady(model, target, (h[0][1], h[1][1], h[2][1], h[3][1]),
                                               matrix, fallbacks)
        else:
            q, self._matrix = kin.track(model, target, _start(h, t), matrix, h[-1][1], fallbacks)
        return q

    def stop_time(self, t: float, limits: Limits) -> float:
        return self.tcp_speed / limits.tcp_maxacc


def _first_order(h: tuple[tuple[float, tuple[float, ...]], ...], t: float) -> tuple[tuple[float, ...], ...]:
    """The first-order extrapolation to path time ``t`` of the last two answers of ``h`` ((path time,
    joints), oldest first; the step ratio capped at :data:`_EXTRAPOLATE_MAX`), as the one extra seed
    of the full solve (what a Cartesian plan started its solve from before the chord solve); none
    without two answers at different times."""
    if len(h) < 2 or not h[-1][0] > h[-2][0]:
        return ()
    (t2, q2), (t3, q3) = h[-2], h[-1]
    r = min((t - t3) / (t3 - t2), _EXTRAPOLATE_MAX)
    return (tuple([b + (b - a) * r for a, b in zip(q2, q3, strict=True)]),)


#: How the path times of a plan's last answers and the next one lie (:func:`_steps`).
_UNSTEADY, _STEADY, _EQUAL = 0, 1, 2
_INF = math.inf


def _steps(h: tuple[tuple[float, tuple[float, ...]], ...], t: float) -> int:
    """How the path times of the answers ``h`` and ``t`` lie: :data:`_EQUAL` (four answers, the three
    steps between them and the one to ``t`` equal within 1e-9 of the last), :data:`_STEADY` (four
    answers, no step more than :data:`_EXTRAPOLATE_MAX` times another) or :data:`_UNSTEADY`.

    Equal steps are tested first (the usual period): for a finite, non-negative last step they lie
    within the steady bounds too, and the tolerance of an infinite one never counts as equal."""
    if len(h) < 4:
        return _UNSTEADY
    (t0, _), (t1, _), (t2, _), (t3, _) = h
    step = t3 - t2
    s1, s2, d = t1 - t0, t2 - t1, t - t3
    tol = step * 1e-9
    if tol < _INF and abs(s1 - step) <= tol and abs(s2 - step) <= tol and abs(d - step) <= tol:
        return _EQUAL
    lo, hi = step / _EXTRAPOLATE_MAX, step * _EXTRAPOLATE_MAX
    if lo <= s1 <= hi and lo <= s2 <= hi and 0.0 <= d <= hi:
        return _STEADY
    return _UNSTEADY


def _start(h: tuple[tuple[float, tuple[float, ...]], ...], t: float) -> tuple[float, ...]:
    """The start of a Cartesian plan's chord solve at path time ``t`` from its last answers ``h``
    ((path time, joints), oldest first).

    With four answers along a steady path time (no step more than :data:`_EXTRAPOLATE_MAX` times
    another) the third-order extrapolation (Lagrange through the four; on equal steps the weights
    -1, 4, -6, 4), which on the jerk-limited paths lies closest to the answer of the first to fifth
    orders, so that one chord step usually converges; else the first-order one; else the last answer.
    """
    how = _steps(h, t)
    if how == _UNSTEADY:
        first = _first_order(h, t)
        return first[0] if first else h[-1][1]
    (t0, q0), (t1, q1), (t2, q2), (t3, q3) = h
    if how == _EQUAL:
        return tuple([4.0 * (d_ + b) - 6.0 * c - a for a, b, c, d_ in zip(q0, q1, q2, q3, strict=False)])
    d0, d1, d2, d3 = t - t0, t - t1, t - t2, t - t3  # Lagrange weights of the four answers at t
    w0 = d1 * d2 * d3 / ((t0 - t1) * (t0 - t2) * (t0 - t3))
    w1 = d0 * d2 * d3 / ((t1 - t0) * (t1 - t2) * (t1 - t3))
    w2 = d0 * d1 * d3 / ((t2 - t0) * (t2 - t1) * (t2 - t3))
    w3 = d0 * d1 * d2 / ((t3 - t0) * (t3 - t1) * (t3 - t2))
    return tuple([w0 * a + w1 * b + w2 * c + w3 * d_ for a, b, c, d_ in zip(q0, q1, q2, q3, strict=False)])


class Executor:
    """The command buffer and the motion that runs from it."""

    def __init__(self, model: RobotModel, data: PlanState | None = None) -> None:
        self.model = model
        #: The model's lower and upper joint limits as floats, for the per-period check.
        self._bounds = (tuple(float(j.lower) for j in model.joints),
                        tuple(float(j.upper) for j in model.joints))
        #: The buffer and plan state; part of the controller's :class:`~.controller_state.ControllerState`.
        self.data = PlanState() if data is None else data

    @property
    def buffer(self) -> deque[QueuedCommand]:
        return self.data.buffer

    @property
    def current(self) -> QueuedCommand | None:
        return self.data.current

    @property
    def stopping(self) -> bool:
        return self.data.stopping

    @property
    def tcp_speed(self) -> float:
        return self.data.tcp_speed

    @property
    def completed(self) -> int:
        return self.data.completed

    # -- buffer ------------------------------------------------------------------------------
    @property
    def cmdnum(self) -> int:
        """Commands in the buffer, the running one included; 0 once a stop (state 4) discarded them,
        even while the arm is still coming to rest."""
        return self.data.cmdnum

    @property
    def active(self) -> bool:
        return self.data.current is not None or bool(self.data.buffer)

    def clear(self) -> None:
        """Discard the buffer and the running motion at once."""
        self.data.buffer.clear()
        self.data.plan = None
        self.data.current = None
        self.data.t = 0.0
        self.data.rate = self.data.ramp_from = self.data.ramp_to = 1.0
        self.data.ramp_u = 1.0
        self.data.stopping = False
        self.data.tcp_speed = 0.0
        self.data.merged = 0

    def queue(self, cmd: QueuedCommand) -> None:
        """Append a validated command to the buffer."""
        self.data.buffer.append(cmd)

    @property
    def running(self) -> bool:
        """A command is being executed (planned and sampled)."""
        return self.data.plan is not None

    # -- intents (register 12, errors, system reset) -------------------------------------------
    def suspend(self, limits: Limits) -> None:
        """State 3: slow the path down to rest, keeping the buffer and the plan."""
        self.ramp_to(0.0, limits)

    def resume(self, limits: Limits) -> None:
        """Leave state 3: speed the path up again from where it rests."""
        self.ramp_to(1.0, limits)

    def stop_smoothly(self, limits: Limits) -> None:
        """State 4 while a command runs: the buffer is discarded at once, the running motion ramps to
        rest on its path and then ends."""
        self.data.buffer.clear()
        self.data.stopping = True
        self.ramp_to(0.0, limits)

    def discard(self) -> None:
        """Discard the buffer and the running motion at once (errors, system reset)."""
        self.clear()

    # -- rate ramps (suspend, resume, stop) --------------------------------------------------
    def ramp_to(self, target: float, limits: Limits | None = None) -> None:
        """Ramp the path rate to ``target`` (0: suspend/stop, 1: resume) along the same path.

        The ramp lasts at least :data:`RAMP_TIME` and long enough that slowing the current motion
        down stays within the acceleration limit of ``limits``.
        """
        if target == self.data.ramp_to and self.data.ramp_u >= 1.0:
            return
        duration = RAMP_TIME
        if self.data.plan is not None and limits is not None:
            duration = max(duration, _SMOOTHSTEP_PEAK * self.data.plan.stop_time(self.data.t, limits))
        self.data.ramp_from = self.data.rate
        self.data.ramp_to = target
        self.data.ramp_u = 0.0
        self.data.ramp_time = duration

    def _advance_rate(self, dt: float) -> None:
        if self.data.ramp_u < 1.0:
            self.data.ramp_u = min(1.0, self.data.ramp_u + dt / self.data.ramp_time)
            u = self.data.ramp_u
            s = u * u * (3.0 - 2.0 * u)  # smoothstep: bounded acceleration of the path rate
            self.data.rate = self.data.ramp_from + (self.data.ramp_to - self.data.ramp_from) * s

    def dwell_rate(self, q: np.ndarray) -> float | None:
        """The path rate of a running dwell (register 26) whose control periods only advance its path
        time: its plan holds the joints ``q`` (the very array), no rate ramp or stop runs and the TCP
        speed is already 0; ``None`` otherwise. The period in which it ends runs in full."""
        d = self.data
        plan = d.plan
        if (isinstance(plan, _DwellPlan) and plan.q is q and not d.stopping and d.ramp_u >= 1.0
                and d.tcp_speed == 0.0 and math.copysign(1.0, d.tcp_speed) > 0.0):
            return d.rate
        return None

    @property
    def at_rest(self) -> bool:
        return self.data.rate == 0.0 and self.data.ramp_u >= 1.0

    # -- stepping ----------------------------------------------------------------------------
    def step(self, dt: float, q: np.ndarray, limits: Limits,
             to_flange: Callable[[np.ndarray], np.ndarray],
             tcp_pose: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
        """Advance one period from joints ``q``; returns the new joints.

        Raises :class:`CommandError` for errors found while planning or moving.
        """
        d = self.data
        if d.ramp_u < 1.0:
            self._advance_rate(dt)
        if d.stopping and self.at_rest:
            self.clear()
            return q
        plan = self._running_plan(q, limits, to_flange, tcp_pose)
        if plan is None:
            d.tcp_speed = 0.0
            return q
        d.t += dt * d.rate
        t = d.t
        duration = plan.duration
        steady = d.ramp_u >= 1.0 and not d.stopping  # the plan may sample the next periods at once
        answer = plan.joints(t if t < duration else duration, q, dt * d.rate if steady else 0.0)
        if answer is None:
            self.clear()
            raise CommandError(C_KINEMATIC, "no inverse kinematics solution along the path")
        new_q, values = answer
        self._check_limits(new_q, values)
        if dt > 0.0 and isinstance(plan, _CartesianPlan):
            self._check_speed(values, q.tolist(), dt, limits)
        d.tcp_speed = plan.tcp_speed * d.rate
        if t >= duration:
            d.completed += 1 + d.merged
            d.plan = None
            d.current = None
            d.merged = 0
        return new_q

    def _running_plan(self, q: np.ndarray, limits: Limits, to_flange: Callable[[np.ndarray], np.ndarray],
                      tcp_pose: Callable[[np.ndarray], np.ndarray]) -> _Plan | None:
        """The plan this period runs: the running one, blended into the next queued move once that
        can be done (:meth:`_blend_late_arrival`, :meth:`_blend_joint_moves`); else the next queued
        command's, planned from the joints ``q`` (``None``: nothing queued, or the path rate is 0)."""
        d = self.data
        plan = d.plan
        if plan is None:
            if not d.buffer or d.rate == 0.0:
                return None
            d.current = d.buffer.popleft()
            d.t = 0.0
            d.plan = self._plan(d.current, q, limits, to_flange, tcp_pose)
        elif isinstance(plan, _CartesianPlan) and plan.blend_into is not None:
            self._blend_late_arrival(q, limits, to_flange)
        elif isinstance(plan, _JointPlan) and plan.blend is not None:
            self._blend_joint_moves(q, limits, tcp_pose)
        return d.plan

    def _check_limits(self, q: np.ndarray, values: Sequence[float]) -> None:
        """C23 unless the joints ``q`` (``values`` as floats) are finite and inside the limits (manual
        1.3): on the floats first (a NaN compares false), the arm's own joint count."""
        lo, hi = self._bounds
        if not (len(values) == len(lo) and all(map(le, lo, values)) and all(map(le, values, hi))):
            if not kin.within_limits(self.model, q):
                self.clear()
                raise CommandError(C_JOINT_LIMIT, "path leaves the joint limits")

    def _check_speed(self, values: Sequence[float], previous: Sequence[float], dt: float,
                     limits: Limits) -> None:
        """C24 when a TCP path needs a joint speed beyond the limit (near a singularity, section
        3.2.1): the joints ``values`` after the period against ``previous`` before it, as floats."""
        speed = max(map(abs, map(sub, values, previous))) / dt
        if speed > limits.max_joint_speed * SPEED_TOLERANCE:
            self.clear()
            raise CommandError(C_SPEED, f"path needs {speed:.2f} rad/s at a joint")

    def _blend_late_arrival(self, q: np.ndarray, limits: Limits,
                            to_flange: Callable[[np.ndarray], np.ndarray]) -> None:
        """Register 22: a linear move queued while a blended move runs is still blended into.

        Once the TCP is on the last straight piece of the running plan, the rest of the path is
        re-planned through the new targets from the current path speed and acceleration, without
        stopping. Until then (or when the blend zone has begun) nothing changes.
        """
        d = self.data
        plan = d.plan
        assert isinstance(plan, _CartesianPlan) and plan.blend_into is not None
        if not d.buffer or not isinstance(d.buffer[0], LineMove) or d.rate != 1.0 or d.stopping:
            return
        found = plan.last_run(d.t)
        if found is None:
            return
        run, t_run = found
        path = run.path
        s, v, a = run.state(t_run)
        last_piece = path.starts[-1] if isinstance(path, motion.CompositePath) else 0.0
        target, radius, first = plan.blend_into
        if s < last_piece or path.length - s <= radius:
            return  # still before the last straight piece, or already inside the blend zone
        poses = [path.pose(s), target]
        radii: list[float | None] = [radius]
        last = self._chain(poses, radii)
        self._reachable(poses[2:], q, to_flange)
        acc = min(first.acc, limits.tcp_maxacc)
        runs = motion.blend_runs(poses, radii)
        speed = min(first.speed, limits.tcp_speed_cap)
        profile = motion.MovingProfile(runs[0].length, v, a, speed, acc, limits.tcp_jerk)
        moves = [motion.CartesianMove(runs[0], speed, acc, limits.tcp_jerk, profile=profile)]
        moves += [motion.CartesianMove(r, speed, acc, limits.tcp_jerk) for r in runs[1:]]
        move: motion.CartesianMove | motion.MoveChain = (moves[0] if len(moves) == 1
                                                         else motion.MoveChain(moves))
        blend = (poses[-1], last.radius, first) if last.radius > 0.0 else None
        d.plan = _CartesianPlan(move, to_flange, self.model, blend)
        d.t = 0.0

    def _chain(self, poses: list[np.ndarray], radii: list[float | None]) -> LineMove:
        """Register 22: take from the buffer the linear moves that go on from a blended one (at least
        one is queued), each while the one before it has a blend radius, into one chain: each target
        (from the one before, ``poses[-1]``) appended to ``poses``, each radius to ``radii`` (``None``:
        a sharp corner), the last one ``None`` (the chain ends at rest on its last target); the
        buffer count drops by the whole chain when it ends (``merged``). Returns the last move."""
        buffer = self.data.buffer
        last: LineMove | None = None
        while buffer and isinstance(buffer[0], LineMove) and (last is None or last.radius > 0.0):
            nxt = buffer.popleft()
            assert isinstance(nxt, LineMove)
            poses.append(line_target(nxt, poses[-1]))
            radii.append(nxt.radius if nxt.radius > 0.0 else None)
            self.data.merged += 1
            last = nxt
        assert last is not None
        radii[-1] = None
        return last

    def _reachable(self, targets: list[np.ndarray], q: np.ndarray,
                   to_flange: Callable[[np.ndarray], np.ndarray]) -> None:
        """C_KINEMATIC unless every TCP pose of ``targets`` has joints, each solved from the one
        before (the first from ``q``)."""
        seed = q
        for pose in targets:
            sol = kin.ik(self.model, to_flange(pose), seed, limited=False, restarts=True)
            if sol is None:
                self.clear()
                raise CommandError(C_KINEMATIC, "target pose has no inverse kinematics solution")
            seed = sol

    def _blend_joint_moves(self, q: np.ndarray, limits: Limits,
                           tcp_pose: Callable[[np.ndarray], np.ndarray]) -> None:
        """Joint moves with a blend radius (the SDK's register 24 form): once the TCP comes within the
        radius of the move's target and the next joint move is queued, the arm heads for the next
        target from its current joint positions, speeds and accelerations without stopping
        (a jerk-limited ruckig move from the moving state)."""
        d = self.data
        plan = d.plan
        assert isinstance(plan, _JointPlan) and plan.blend is not None
        if not d.buffer or not isinstance(d.buffer[0], JointMove) or d.rate != 1.0 or d.stopping:
            return
        radius, target_tcp = plan.blend
        if float(np.linalg.norm(tcp_pose(q)[:3, 3] - target_tcp)) > radius:
            return
        _, qd, qdd = plan.traj.at(min(self.data.t, plan.duration))
        queued = self.data.buffer.popleft()
        assert isinstance(queued, JointMove)
        nxt = self._absolute(queued, plan.traj.at(plan.duration)[0])
        self.data.completed += 1  # the blended-away command is done
        self.data.current = queued
        acc = min(nxt.acc, limits.joint_maxacc)
        speed = min(nxt.speed, limits.joint_speed_cap)
        traj = motion.plan_joint_move(q, nxt.target, speed, acc, limits.joint_jerk, qd0=qd, qdd0=qdd)
        self.data.plan = _JointPlan(traj, self._joint_blend(nxt, tcp_pose))
        self.data.t = 0.0

    def _absolute(self, cmd: JointMove, start: np.ndarray) -> JointMove:
        """``cmd`` with an absolute target from the joints ``start`` it begins at: a relative move's
        deltas added (register 83; C23 beyond the limits), +inf joints kept (register 23)."""
        if cmd.relative:
            target = start + cmd.target
            if not kin.within_limits(self.model, target):
                raise CommandError(C_JOINT_LIMIT, "relative joint target outside the limits")
            return replace(cmd, target=target, relative=False)
        return replace(cmd, target=keep_unchanged_joints(cmd.target, start))

    @staticmethod
    def _joint_blend(cmd: JointMove, tcp_pose: Callable[[np.ndarray], np.ndarray]
                     ) -> tuple[float, np.ndarray] | None:
        if cmd.radius <= 0.0:
            return None
        return (cmd.radius, tcp_pose(cmd.target)[:3, 3].copy())

    # -- planning ----------------------------------------------------------------------------
    def _plan(self, cmd: QueuedCommand, q: np.ndarray, limits: Limits,
              to_flange: Callable[[np.ndarray], np.ndarray],
              tcp_pose: Callable[[np.ndarray], np.ndarray]) -> _Plan:
        if isinstance(cmd, Dwell):
            return _DwellPlan(q, cmd.seconds)
        if isinstance(cmd, Task):
            cmd.run()
            return _DwellPlan(q, 0.0)
        if isinstance(cmd, JointMove):
            acc = min(cmd.acc, limits.joint_maxacc)
            # The queued command stays ``current`` (feedback frames and the buffer count follow it);
            # only the plan sees its target resolved (+inf joints kept, relative deltas added).
            cmd = self._absolute(cmd, q)
            speed = min(cmd.speed, limits.joint_speed_cap)
            traj = motion.plan_joint_move(q, cmd.target, speed, acc, limits.joint_jerk)
            return _JointPlan(traj, self._joint_blend(cmd, tcp_pose))
        start = tcp_pose(q)
        acc = min(cmd.acc, limits.tcp_maxacc)
        blend_next = bool(self.data.buffer) and isinstance(self.data.buffer[0], LineMove)
        if isinstance(cmd, LineMove) and cmd.radius > 0.0 and blend_next:
            return self._plan_blended(cmd, start, q, acc, limits, to_flange)
        if isinstance(cmd, LineMove):
            target = line_target(cmd, start)
            line = motion.LinePath(start, target)
            if cmd.motion_type == 2 or (cmd.motion_type == 1 and not self._line_feasible(line, q, to_flange)):
                return self._joint_plan_to(cmd, target, q, limits, to_flange)
            path: motion.Path = line
            end_check = target
        else:
            assert isinstance(cmd, CircleMove)
            try:
                p1, p2 = wire_pose_to_matrix(cmd.pose1), wire_pose_to_matrix(cmd.pose2)
                path = motion.CirclePath(start, p1, p2, cmd.percent)
            except motion.CollinearError as exc:
                raise CommandError(C_CIRCLE, str(exc)) from exc
            end_check = path.pose(path.length)
        if kin.ik(self.model, to_flange(end_check), q, limited=False, restarts=True) is None:
            raise CommandError(C_KINEMATIC, "target pose has no inverse kinematics solution")
        move = motion.CartesianMove(path, min(cmd.speed, limits.tcp_speed_cap), acc, limits.tcp_jerk)
        blend = (end_check, cmd.radius, cmd) if isinstance(cmd, LineMove) and cmd.radius > 0.0 else None
        return _CartesianPlan(move, to_flange, self.model, blend)

    def _line_feasible(self, path: motion.LinePath, q: np.ndarray,
                       to_flange: Callable[[np.ndarray], np.ndarray]) -> bool:
        """Whether a TCP line has joint solutions within the limits at :data:`LINE_SAMPLES` points."""
        seed = q
        for u in np.linspace(0.0, 1.0, LINE_SAMPLES):
            sol = kin.ik(self.model, to_flange(path.pose_u(float(u))), seed, limited=False)
            if sol is None or not kin.within_limits(self.model, sol):
                return False
            seed = sol
        return True

    def _joint_plan_to(self, cmd: LineMove, target: np.ndarray, q: np.ndarray, limits: Limits,
                       to_flange: Callable[[np.ndarray], np.ndarray]) -> _Plan:
        """Register 21's motion type 2 (and 1 where no line is possible): a joint move to the target
        pose, at the fraction of the joint maxima that the TCP speed and acceleration are of theirs
        (Table 1.2)."""
        m = self.model
        sol = kin.ik(m, to_flange(target), q, limited=False, restarts=True)
        if sol is None:
            raise CommandError(C_KINEMATIC, "target pose has no inverse kinematics solution")
        if not kin.within_limits(m, sol):
            raise CommandError(C_JOINT_LIMIT, "target pose needs joints outside the limits")
        speed = m.max_joint_speed * min(1.0, cmd.speed / m.max_tcp_speed)
        acc = min(m.max_joint_acc * min(1.0, cmd.acc / m.max_tcp_acc), limits.joint_maxacc)
        q_end = np.asarray(sol, dtype=float)
        return _JointPlan(motion.plan_joint_move(q, q_end, speed, acc, limits.joint_jerk))

    def _plan_blended(self, cmd: LineMove, start: np.ndarray, q: np.ndarray, acc: float, limits: Limits,
                      to_flange: Callable[[np.ndarray], np.ndarray]) -> _Plan:
        """Register 22: linear moves with arc blending become one continuous move (:meth:`_chain`):
        the corner after a move is rounded with that move's radius (paths.blend_runs), and the TCP
        does not stop there. The chain uses the first move's speed and acceleration."""
        poses = [start, line_target(cmd, start)]
        radii: list[float | None] = [cmd.radius]
        last = self._chain(poses, radii)
        self._reachable(poses[1:], q, to_flange)
        move = motion.plan_blended(poses, radii, min(cmd.speed, limits.tcp_speed_cap), acc, limits.tcp_jerk)
        blend = (poses[-1], last.radius, cmd) if last.radius > 0.0 else None
        return _CartesianPlan(move, to_flange, self.model, blend)
