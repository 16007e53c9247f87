"""Motion execution: takes commands from the buffer, plans them from the
current state and samples the plan every control period.

Suspend (state 3) and stop (state 4) slow the *path time* down with a smooth
ramp, so the arm stays on the planned path and a resumed move continues the
same path (manual register 12).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..model import kinematics as kin
from ..model.robots import RobotModel
from . import motion
from .base import C_CIRCLE, C_JOINT_LIMIT, C_KINEMATIC, C_SPEED, CommandError
from .commands import CircleMove, Dwell, JointMove, LineMove, QueuedCommand, Task
from .poses import resolve_line_target, wire_pose_to_matrix

#: Shortest time to ramp the path rate between full speed and rest for suspend/stop (s); faster
#: motion ramps longer so that the deceleration stays within the acceleration limit.
RAMP_TIME = 0.2
#: Peak slope of the smoothstep ramp (3u^2 - 2u^3) relative to a linear one.
_SMOOTHSTEP_PEAK = 1.5

#: A Cartesian step may exceed the joint speed limit by this factor before C24 (sampling slack).
SPEED_TOLERANCE = 1.05


@dataclass
class Limits:
    """Jerk and maximum-acceleration settings that moves use (registers 31-34)."""

    tcp_jerk: float
    tcp_maxacc: float
    joint_jerk: float
    joint_maxacc: float
    max_joint_speed: float = math.pi  # Table 1.2; a Cartesian path needing more is error C24


class _Plan:
    """One planned command: a duration and joint positions at a path time."""

    duration: float = 0.0
    tcp_speed: float = 0.0

    def joints(self, t: float, seed: np.ndarray) -> np.ndarray | None:
        raise NotImplementedError

    def stop_time(self, t: float, limits: Limits) -> float:
        """Seconds to come to rest from path time ``t`` at the acceleration limit."""
        return 0.0


class _JointPlan(_Plan):
    def __init__(self, traj: motion.JointTrajectory, blend: tuple[float, np.ndarray] | None = None) -> None:
        self.traj = traj
        self.duration = traj.duration
        #: Blend radius (mm) and the TCP position (mm, base frame) at the target, when the command
        #: asked to blend into the next joint move (register 24 with a radius).
        self.blend = blend

    def joints(self, t: float, seed: np.ndarray) -> np.ndarray | None:
        return self.traj.at(t)[0]

    def stop_time(self, t: float, limits: Limits) -> float:
        qd = self.traj.at(min(t, self.duration))[1]
        return float(np.max(np.abs(qd))) / limits.joint_maxacc


class _DwellPlan(_Plan):
    def __init__(self, q: np.ndarray, seconds: float) -> None:
        self.q = q.copy()
        self.duration = seconds

    def joints(self, t: float, seed: np.ndarray) -> np.ndarray | None:
        return self.q


class _CartesianPlan(_Plan):
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

    def last_run(self, t: float) -> tuple[motion.CartesianMove, float] | None:
        """The final run of the plan and the time within it, if ``t`` lies in that run."""
        move = self.move
        if isinstance(move, motion.MoveChain):
            last_start = move.duration - move.moves[-1].duration
            if t < last_start:
                return None
            return move.moves[-1], t - last_start
        return move, t

    def joints(self, t: float, seed: np.ndarray) -> np.ndarray | None:
        pose, speed = self.move.at(t)
        self.tcp_speed = speed
        return kin.ik(self.model, self.to_flange(pose), seed, limited=False)

    def stop_time(self, t: float, limits: Limits) -> float:
        return self.tcp_speed / limits.tcp_maxacc


class Executor:
    """The command buffer and the motion that runs from it."""

    def __init__(self, model: RobotModel) -> None:
        self.model = model
        self.buffer: deque[QueuedCommand] = deque()
        self.plan: _Plan | None = None
        self.current: QueuedCommand | None = None
        self.t = 0.0  # path time within the current plan
        self.rate = 1.0  # path time per control time, 0..1
        self._ramp_from = 1.0
        self._ramp_to = 1.0
        self._ramp_u = 1.0  # progress of the current ramp, 0..1
        self._ramp_time = RAMP_TIME
        self.stopping = False  # a stop ramp is running; the plan ends when it reaches rest
        self.tcp_speed = 0.0
        self.merged = 0  # further commands of a blended chain that the current plan runs
        self.completed = 0  # commands run to their end (the report's command counter)

    # -- buffer ------------------------------------------------------------------------------
    @property
    def cmdnum(self) -> int:
        """Commands in the buffer, the running one included; 0 once a stop (state 4) discarded them,
        even while the arm is still coming to rest."""
        if self.stopping:
            return 0
        return len(self.buffer) + (1 + self.merged if self.current is not None else 0)

    @property
    def active(self) -> bool:
        return self.current is not None or bool(self.buffer)

    def clear(self) -> None:
        """Discard the buffer and the running motion at once."""
        self.buffer.clear()
        self.plan = None
        self.current = None
        self.t = 0.0
        self.rate = self._ramp_from = self._ramp_to = 1.0
        self._ramp_u = 1.0
        self.stopping = False
        self.tcp_speed = 0.0
        self.merged = 0

    def queue(self, cmd: QueuedCommand) -> None:
        """Append a validated command to the buffer."""
        self.buffer.append(cmd)

    @property
    def running(self) -> bool:
        """A command is being executed (planned and sampled)."""
        return self.plan is not None

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
        self.buffer.clear()
        self.stopping = True
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
        if target == self._ramp_to and self._ramp_u >= 1.0:
            return
        duration = RAMP_TIME
        if self.plan is not None and limits is not None:
            duration = max(duration, _SMOOTHSTEP_PEAK * self.plan.stop_time(self.t, limits))
        self._ramp_from = self.rate
        self._ramp_to = target
        self._ramp_u = 0.0
        self._ramp_time = duration

    def _advance_rate(self, dt: float) -> None:
        if self._ramp_u < 1.0:
            self._ramp_u = min(1.0, self._ramp_u + dt / self._ramp_time)
            u = self._ramp_u
            s = u * u * (3.0 - 2.0 * u)  # smoothstep: bounded acceleration of the path rate
            self.rate = self._ramp_from + (self._ramp_to - self._ramp_from) * s

    @property
    def at_rest(self) -> bool:
        return self.rate == 0.0 and self._ramp_u >= 1.0

    # -- stepping ----------------------------------------------------------------------------
    def step(self, dt: float, q: np.ndarray, limits: Limits,
             to_flange: Callable[[np.ndarray], np.ndarray],
             tcp_pose: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
        """Advance one period from joints ``q``; returns the new joints.

        Raises :class:`CommandError` for errors found while planning or moving.
        """
        self._advance_rate(dt)
        if self.stopping and self.at_rest:
            self.clear()
            return q
        if self.plan is None:
            if not self.buffer or self.rate == 0.0:
                self.tcp_speed = 0.0
                return q
            self.current = self.buffer.popleft()
            self.t = 0.0
            self.plan = self._plan(self.current, q, limits, to_flange, tcp_pose)
        elif isinstance(self.plan, _CartesianPlan) and self.plan.blend_into is not None:
            self._blend_late_arrival(q, limits, to_flange)
        elif isinstance(self.plan, _JointPlan) and self.plan.blend is not None:
            self._blend_joint_moves(q, limits, tcp_pose)
        self.t += dt * self.rate
        plan = self.plan
        t = min(self.t, plan.duration)
        new_q = plan.joints(t, q)
        if new_q is None:
            self.clear()
            raise CommandError(C_KINEMATIC, "no inverse kinematics solution along the path")
        if not kin.within_limits(self.model, new_q):
            self.clear()
            raise CommandError(C_JOINT_LIMIT, "path leaves the joint limits")
        if isinstance(plan, _CartesianPlan) and dt > 0.0:
            # Near a singularity a TCP path can need joint speeds beyond the limit (section 3.2.1, C24).
            speed = float(np.max(np.abs(np.asarray(new_q) - q))) / dt
            if speed > limits.max_joint_speed * SPEED_TOLERANCE:
                self.clear()
                raise CommandError(C_SPEED, f"path needs {speed:.2f} rad/s at a joint")
        self.tcp_speed = plan.tcp_speed * self.rate
        if self.t >= plan.duration:
            self.completed += 1 + self.merged
            self.plan = None
            self.current = None
            self.merged = 0
        return np.asarray(new_q, dtype=float)

    def _blend_late_arrival(self, q: np.ndarray, limits: Limits,
                            to_flange: Callable[[np.ndarray], np.ndarray]) -> None:
        """Register 22: a linear move queued while a blended move runs is still blended into.

        Once the TCP is on the last straight piece of the running plan, the rest of the path is
        re-planned through the new targets from the current path speed and acceleration, without
        stopping. Until then (or when the blend zone has begun) nothing changes.
        """
        plan = self.plan
        assert isinstance(plan, _CartesianPlan) and plan.blend_into is not None
        if not self.buffer or not isinstance(self.buffer[0], LineMove) or self.rate != 1.0 or self.stopping:
            return
        found = plan.last_run(self.t)
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
        last: LineMove | None = None
        extra = 0
        while self.buffer and isinstance(self.buffer[0], LineMove) and (last is None or last.radius > 0.0):
            nxt = self.buffer.popleft()
            assert isinstance(nxt, LineMove)
            poses.append(resolve_line_target(nxt, poses[-1]))
            radii.append(nxt.radius if nxt.radius > 0.0 else None)
            extra += 1
            last = nxt
        seed = q
        for pose in poses[2:]:
            sol = kin.ik(self.model, to_flange(pose), seed, limited=False, restarts=True)
            if sol is None:
                self.clear()
                raise CommandError(C_KINEMATIC, "target pose has no inverse kinematics solution")
            seed = sol
        assert last is not None
        radii[-1] = None
        acc = min(first.acc, limits.tcp_maxacc)
        runs = motion.blend_runs(poses, radii)
        profile = motion.MovingProfile(runs[0].length, v, a, first.speed, acc, limits.tcp_jerk)
        moves = [motion.CartesianMove(runs[0], first.speed, acc, limits.tcp_jerk, profile=profile)]
        moves += [motion.CartesianMove(r, first.speed, acc, limits.tcp_jerk) for r in runs[1:]]
        move: motion.CartesianMove | motion.MoveChain = (moves[0] if len(moves) == 1
                                                         else motion.MoveChain(moves))
        blend = (poses[-1], last.radius, first) if last.radius > 0.0 else None
        self.plan = _CartesianPlan(move, to_flange, self.model, blend)
        self.t = 0.0
        self.merged += extra

    def _blend_joint_moves(self, q: np.ndarray, limits: Limits,
                           tcp_pose: Callable[[np.ndarray], np.ndarray]) -> None:
        """Joint moves with a blend radius (the SDK's register 24 form): once the TCP comes within the
        radius of the move's target and the next joint move is queued, the arm heads for the next
        target from its current joint positions, speeds and accelerations without stopping
        (a jerk-limited ruckig move from the moving state)."""
        plan = self.plan
        assert isinstance(plan, _JointPlan) and plan.blend is not None
        if not self.buffer or not isinstance(self.buffer[0], JointMove) or self.rate != 1.0 or self.stopping:
            return
        radius, target_tcp = plan.blend
        if float(np.linalg.norm(tcp_pose(q)[:3, 3] - target_tcp)) > radius:
            return
        _, qd, qdd = plan.traj.at(min(self.t, plan.duration))
        nxt = self.buffer.popleft()
        assert isinstance(nxt, JointMove)
        self.completed += 1  # the blended-away command is done
        self.current = nxt
        acc = min(nxt.acc, limits.joint_maxacc)
        traj = motion.plan_joint_move(q, nxt.target, nxt.speed, acc, limits.joint_jerk, qd0=qd, qdd0=qdd)
        self.plan = _JointPlan(traj, self._joint_blend(nxt, tcp_pose))
        self.t = 0.0

    @staticmethod
    def _joint_blend(cmd: JointMove, tcp_pose: Callable[[np.ndarray], np.ndarray]
                     ) -> tuple[float, np.ndarray] | None:
        return (cmd.radius, tcp_pose(cmd.target)[:3, 3].copy()) if cmd.radius > 0.0 else None

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
            traj = motion.plan_joint_move(q, cmd.target, cmd.speed, acc, limits.joint_jerk)
            return _JointPlan(traj, self._joint_blend(cmd, tcp_pose))
        start = tcp_pose(q)
        acc = min(cmd.acc, limits.tcp_maxacc)
        blend_next = bool(self.buffer) and isinstance(self.buffer[0], LineMove)
        if isinstance(cmd, LineMove) and cmd.radius > 0.0 and blend_next:
            return self._plan_blended(cmd, start, q, acc, limits, to_flange)
        if isinstance(cmd, LineMove):
            target = resolve_line_target(cmd, start)
            path: motion.Path = motion.LinePath(start, target)
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
        move = motion.CartesianMove(path, cmd.speed, acc, limits.tcp_jerk)
        blend = (end_check, cmd.radius, cmd) if isinstance(cmd, LineMove) and cmd.radius > 0.0 else None
        return _CartesianPlan(move, to_flange, self.model, blend)


    def _plan_blended(self, cmd: LineMove, start: np.ndarray, q: np.ndarray, acc: float, limits: Limits,
                      to_flange: Callable[[np.ndarray], np.ndarray]) -> _Plan:
        """Register 22: linear moves with arc blending become one continuous move.

        The chain takes every following linear move while the previous one has a blend radius;
        the corner after a move is rounded with that move's radius (paths.blend_runs), and the
        TCP does not stop there. The chain uses the first move's speed and acceleration, and the
        buffer count drops by the whole chain when it ends.
        """
        poses = [start, resolve_line_target(cmd, start)]
        radii: list[float | None] = [cmd.radius]
        last = cmd
        while self.buffer and isinstance(self.buffer[0], LineMove) and last.radius > 0.0:
            nxt = self.buffer.popleft()
            assert isinstance(nxt, LineMove)
            poses.append(resolve_line_target(nxt, poses[-1]))
            radii.append(nxt.radius if nxt.radius > 0.0 else None)
            self.merged += 1
            last = nxt
        radii[-1] = None  # the chain ends at rest on its last target
        seed = q
        for target in poses[1:]:
            sol = kin.ik(self.model, to_flange(target), seed, limited=False, restarts=True)
            if sol is None:
                raise CommandError(C_KINEMATIC, "target pose has no inverse kinematics solution")
            seed = sol
        move = motion.plan_blended(poses, radii, cmd.speed, acc, limits.tcp_jerk)
        blend = (poses[-1], last.radius, cmd) if last.radius > 0.0 else None
        return _CartesianPlan(move, to_flange, self.model, blend)
