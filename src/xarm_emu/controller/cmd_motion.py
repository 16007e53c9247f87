"""Motion commands (manual 2.1.3, registers 21-30, 92 and 93): queued moves and servo targets."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..model import kinematics as kin
from ..model import rotations as rot
from .base import (
    C_JOINT_LIMIT,
    WARN_NO_SOLUTION,
    CommandError,
    CommandWarning,
    Handler,
    ParameterError,
    Values,
)
from .commands import CircleMove, Dwell, JointMove, LineMove
from .core import (
    ControllerCore,
)
from .poses import apply_offset, wire_pose_to_matrix
from .settings import (
    in_range,
)


class MotionCommands(ControllerCore):
    """Registers 21-23 and 25-30, 92, 93 (24 is shared, see :class:`Controller`)."""

    def register_handlers(self) -> dict[int, Handler]:
        h = super().register_handlers()
        h.update({
            21: self._h_move_line,
            22: self._h_move_line,
            23: self._h_move_joint,
            25: self._h_move_home,
            26: self._h_dwell,
            27: self._h_move_circle,
            28: self._h_move_line,
            29: self._h_servoj,
            30: self._h_servo_cartesian,
            92: self._h_move_line_aa,
            93: self._h_servo_cartesian_aa,
        })
        return h

    # motion commands
    def _check_speed(self, speed: float, acc: float, vmax: float, amax: float) -> None:
        if not (in_range(speed, vmax) and speed > 0.0 and in_range(acc, amax) and acc > 0.0):
            raise ParameterError("speed or acceleration outside Table 1.2")

    def _h_move_line(self, v: Values) -> dict[str, Any]:
        self._check_speed(v["speed"], v["acc"], self.model.max_tcp_speed, self.model.max_tcp_acc)
        self._require_motion_allowed()
        code = self._current_code
        radius = float(v.get("radius", -1.0))
        cmd = LineMove(code, tuple(v["pose"]), v["speed"], v["acc"], radius=radius, tool_frame=(code == 28),
                       relative=(code == 28))
        return self._queue(cmd)

    def _h_move_line_aa(self, v: Values) -> dict[str, Any]:
        self._check_speed(v["speed"], v["acc"], self.model.max_tcp_speed, self.model.max_tcp_acc)
        if v["coord"] not in (0, 1) or v["relative"] not in (0, 1):
            raise ParameterError("coordinate and relative flags are 0 or 1")
        self._require_motion_allowed()
        cmd = LineMove(92, tuple(v["pose"]), v["speed"], v["acc"], tool_frame=bool(v["coord"]),
                       relative=bool(v["relative"]) or bool(v["coord"]), axis_angle=True)
        return self._queue(cmd)

    def _joint_target(self, joints: tuple[float, ...]) -> np.ndarray:
        q = np.asarray(joints[: self.dof], dtype=float)
        if not kin.within_limits(self.model, q):
            raise CommandError(C_JOINT_LIMIT, "joint target outside the limits")
        return q

    def _h_move_joint(self, v: Values) -> dict[str, Any]:
        self._check_speed(v["speed"], v["acc"], self.model.max_joint_speed, self.model.max_joint_acc)
        self._require_motion_allowed()
        q = self._joint_target(v["joints"])
        radius = float(v.get("radius", -1.0))  # register 24's SDK form: blend into the next joint move
        return self._queue(JointMove(self._current_code, q, v["speed"], v["acc"], radius=radius))

    def _h_move_home(self, v: Values) -> dict[str, Any]:
        self._check_speed(v["speed"], v["acc"], self.model.max_joint_speed, self.model.max_joint_acc)
        self._require_motion_allowed()
        return self._queue(JointMove(25, np.zeros(self.dof), v["speed"], v["acc"]))

    def _h_dwell(self, v: Values) -> dict[str, Any]:
        t = v["seconds"]
        if not (math.isfinite(t) and t >= 0.0):
            raise ParameterError("pause time must be >= 0")
        self._require_motion_allowed()
        return self._queue(Dwell(26, t))

    def _h_move_circle(self, v: Values) -> dict[str, Any]:
        self._check_speed(v["speed"], v["acc"], self.model.max_tcp_speed, self.model.max_tcp_acc)
        if v["percent"] <= 0.0:
            raise ParameterError("percent must be > 0")
        self._require_motion_allowed()
        return self._queue(CircleMove(27, tuple(v["pose1"]), tuple(v["pose2"]), v["speed"], v["acc"],
                                      v["percent"]))

    def _h_servoj(self, v: Values) -> None:
        self._require_motion_allowed(servo=True)
        self.servo_target = self._joint_target(v["joints"])
        return None

    def _servo_cartesian(self, T: np.ndarray) -> None:
        q = kin.ik(self.model, self.flange_target(T), self.q, limited=False)
        if q is None:
            raise CommandWarning(WARN_NO_SOLUTION)
        if not kin.within_limits(self.model, q):
            raise CommandError(C_JOINT_LIMIT)
        self.servo_target = q

    def _h_servo_cartesian(self, v: Values) -> None:
        self._require_motion_allowed(servo=True)
        delta = wire_pose_to_matrix(v["pose"])
        T = apply_offset(self.tcp_matrix(), delta, v["coord"] != 0.0, False)
        self._servo_cartesian(T)
        return None

    def _h_servo_cartesian_aa(self, v: Values) -> None:
        self._require_motion_allowed(servo=True)
        delta = rot.pose_aa_to_matrix(np.asarray(v["pose"], dtype=float))
        tool = v["coord"] != 0.0
        T = apply_offset(self.tcp_matrix(), delta, tool, int(v.get("relative", 0)) == 1)
        self._servo_cartesian(T)
        return None

